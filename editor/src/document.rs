//! The document an artist edits: a hair asset, where it came from, its colour, and the edit
//! history. No UI here: every edit the panels make goes through [`Document`]'s methods, which
//! the tests call directly and through the UI.
//!
//! Edits are recorded as before/after pairs ([`Edit`]), so undo and redo restore values
//! exactly. Continuous gestures (a slider drag, a vertex drag) coalesce into one edit: the
//! caller passes the same [`Gesture`] on every frame of the gesture and calls
//! [`Document::end_gesture`] when it ends.
//!
//! The asset's own revision ([`HairAsset::revision`]) goes up with every change, undo and redo
//! included; [`Document::changes`] lists the [`AssetChange`]s since the asset was loaded, which
//! the preview uploads incrementally.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;
use hairmesh::asset::{AssetChange, HairAsset, VertexMove};
use hairmesh::convert::ConvertSettings;
use hairmesh::head_frame::HeadFrame;
use hairmesh::style::Style;
use render::occluder::OccluderGeometry;

use crate::EditorError;

/// Where the document's asset came from.
#[derive(Clone, Debug, PartialEq)]
#[expect(clippy::large_enum_variant, reason = "one per document")]
pub enum Source {
    /// Converted from a scalp file with these settings (not saved yet unless
    /// [`Document::save_path`] is set).
    Scalp { file: PathBuf, settings: ConvertSettings },
    /// Read from an asset folder.
    Asset { path: PathBuf },
}

/// One undoable edit, as the values before and after it.
#[derive(Clone, Debug, PartialEq)]
pub enum Edit {
    Style {
        before: Style,
        after: Style,
    },
    /// Hair-mesh vertices: their positions before the edit and after it (same vertices, same
    /// order), and how the edit was made when a sculpting tool made it.
    Vertices {
        before: Vec<VertexMove>,
        after: Vec<VertexMove>,
        made_by: Option<crate::sculpt::Sculpt>,
    },
    Color {
        before: HairColor,
        after: HairColor,
    },
    /// Bundles' tip layers (`(bundle, layer)`): before the edit and after it, same bundles in
    /// the same order.
    TipLayers {
        before: Vec<(u32, u32)>,
        after: Vec<(u32, u32)>,
    },
    /// A layer inserted, removed or extruded: the hair mesh before and after.
    Layers {
        op: LayerOp,
        before: Box<hairmesh::HairMesh>,
        after: Box<hairmesh::HairMesh>,
    },
}

/// An edit of the hair mesh's layers (`hairmesh::layer_ops`).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LayerOp {
    /// A layer between layers `at − 1` and `at`, halfway along every column's curve.
    Insert { at: u32 },
    /// Layer `layer` removed.
    Remove { layer: u32 },
    /// The bundles of `faces` one layer longer (a new outer layer when one already ends there).
    Extrude { faces: Vec<u32> },
}

impl LayerOp {
    fn apply(&self, mesh: &mut hairmesh::HairMesh) -> hairmesh::Result<()> {
        match self {
            LayerOp::Insert { at } => mesh.insert_layer(*at as usize),
            LayerOp::Remove { layer } => mesh.remove_layer(*layer as usize),
            LayerOp::Extrude { faces } => mesh.extrude_faces(faces).map(drop),
        }
    }
}

/// The hair's linear RGB base colour and per-strand variation.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HairColor {
    pub rgb: [f32; 3],
    pub variation: f32,
}

impl Default for HairColor {
    fn default() -> Self {
        Self { rgb: render::scene::DEFAULT_HAIR_COLOR, variation: render::scene::DEFAULT_COLOR_VARIATION }
    }
}

/// What a continuous interaction is editing; frames of one gesture merge into one edit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Gesture {
    /// A style control, by name.
    Style(String),
    /// A drag of hair-mesh vertices.
    Drag,
    /// A stroke of a hair brush ([`crate::brush`]).
    Brush,
    /// A grab, rotation or scale of the selected tips ([`crate::transform`]), which may be
    /// cancelled.
    Transform,
    Color,
}

/// The most changes kept for the preview's incremental upload before it uploads the asset
/// whole (keeps a long session's memory bounded).
const MAX_PENDING_CHANGES: usize = 256;

/// An open document.
#[derive(Debug)]
pub struct Document {
    pub source: Source,
    /// Where Save writes (an asset folder); `None` until saved or when opened from a scalp.
    pub save_path: Option<PathBuf>,
    asset: Arc<HairAsset>,
    color: HairColor,
    /// The scalp or head mesh drawn with the hair (it hides the hair behind it).
    pub occluder: Option<Arc<OccluderGeometry>>,
    /// The occluder as a surface for distance queries, made on first use.
    head: std::sync::OnceLock<Option<Arc<hairmesh::head::HeadSurface>>>,
    /// The head's frame estimated from the occluder, made on first use (or by the conversion).
    frame: std::sync::OnceLock<Option<HeadFrame>>,
    /// Bumped whenever the asset is replaced whole (open, convert, too many changes): the
    /// preview uploads it again.
    pub generation: u64,
    changes: Vec<AssetChange>,
    undo: Vec<(u64, Edit)>,
    redo: Vec<(u64, Edit)>,
    /// The gesture the last edit belongs to, while it lasts.
    open_gesture: Option<Gesture>,
    next_edit_id: u64,
    /// The id of the edit on top of the undo stack when the document was last saved (0: none).
    saved_edit: u64,
}

/// A fresh generation number for each document or replaced asset, unique in the process.
fn next_generation() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl Document {
    /// A document holding `asset`.
    pub fn new(source: Source, asset: HairAsset, occluder: Option<Arc<OccluderGeometry>>) -> Self {
        let save_path = match &source {
            Source::Asset { path } => Some(path.clone()),
            Source::Scalp { .. } => None,
        };
        Self {
            source,
            save_path,
            asset: Arc::new(asset),
            color: HairColor::default(),
            occluder,
            head: std::sync::OnceLock::new(),
            frame: std::sync::OnceLock::new(),
            generation: next_generation(),
            changes: Vec::new(),
            undo: Vec::new(),
            redo: Vec::new(),
            open_gesture: None,
            next_edit_id: 1,
            saved_edit: 0,
        }
    }

    /// Reads an asset folder (or its `hair.json`). Its scalp file, when the provenance names
    /// one that exists (as given, or relative to the asset), becomes the occluder.
    pub fn open_asset(path: &Path) -> Result<Self, EditorError> {
        let (asset, _) = hairmesh::asset_io::read_asset(path)
            .map_err(|source| EditorError::Asset { path: path.to_owned(), source })?;
        let dir =
            if path.is_dir() { path.to_owned() } else { path.parent().unwrap_or(Path::new(".")).to_owned() };
        let occluder =
            asset.provenance.as_ref().and_then(|p| p.locate(&dir)).and_then(|f| load_occluder(&f).ok());
        Ok(Self::new(Source::Asset { path: dir }, asset, occluder))
    }

    /// Converts a scalp file (runs for seconds on large scalps: call it off the UI thread).
    /// Gravity pulls against `frame`'s up; without a frame, the head's is estimated first.
    pub fn convert_scalp(
        file: &Path,
        settings: &ConvertSettings,
        frame: Option<HeadFrame>,
        progress: &mut dyn FnMut(&str),
    ) -> Result<Self, EditorError> {
        progress("loading the head mesh");
        let occluder = load_occluder(file).ok();
        let frame = match frame {
            Some(f) => Some(f),
            None => {
                progress("estimating the head's frame");
                occluder.as_deref().and_then(estimate_frame)
            }
        };
        let mut settings = settings.clone();
        if let Some(f) = &frame {
            settings.up = f.up;
        }
        let converted = hairmesh::convert::convert_scalp(file, &settings, progress)
            .map_err(|source| EditorError::Asset { path: file.to_owned(), source })?;
        let doc = Self::new(Source::Scalp { file: file.to_owned(), settings }, converted.asset, occluder);
        let _ = doc.frame.set(frame);
        Ok(doc)
    }

    /// The head's frame (centre, up, front, size) estimated from the occluder, if there is one.
    pub fn frame(&self) -> Option<HeadFrame> {
        *self.frame.get_or_init(|| self.occluder.as_deref().and_then(estimate_frame))
    }

    /// The head (the occluder mesh) for keeping edits outside it, when there is one.
    pub fn head_surface(&self) -> Option<Arc<hairmesh::head::HeadSurface>> {
        self.head
            .get_or_init(|| {
                let mesh = occluder_mesh(self.occluder.as_deref()?);
                Some(Arc::new(hairmesh::head::HeadSurface::from_mesh(&mesh)))
            })
            .clone()
    }

    pub fn asset(&self) -> &Arc<HairAsset> {
        &self.asset
    }

    /// The scalp file the hair was converted from, as recorded (it may not exist here).
    pub fn scalp_file(&self) -> Option<PathBuf> {
        match &self.source {
            Source::Scalp { file, .. } => Some(file.clone()),
            Source::Asset { path } => self
                .asset
                .provenance
                .as_ref()
                .map(|p| p.locate(path).unwrap_or_else(|| PathBuf::from(&p.file))),
        }
    }

    /// The longest hair-mesh column (object units): what the style panel's ranges and the
    /// presets scale with.
    pub fn hair_length(&self) -> f64 {
        self.asset.bundles.iter().map(|b| b.length).fold(0.0, f64::max)
    }

    pub fn style(&self) -> Style {
        self.asset.style
    }

    pub fn color(&self) -> HairColor {
        self.color
    }

    /// The changes since the asset was last replaced whole, oldest first.
    pub fn changes(&self) -> &[AssetChange] {
        &self.changes
    }

    /// The edits that made the document what it is, oldest first (the undo history; undone
    /// edits are not in it).
    pub fn history(&self) -> impl Iterator<Item = &Edit> {
        self.undo.iter().map(|(_, e)| e)
    }

    /// Whether there are edits since the last save (or since opening).
    pub fn is_dirty(&self) -> bool {
        self.undo.last().map_or(0, |(id, _)| *id) != self.saved_edit
            || matches!(self.source, Source::Scalp { .. }) && self.save_path.is_none()
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    /// A short name for title bars and prompts.
    pub fn title(&self) -> String {
        let path = match (&self.save_path, &self.source) {
            (Some(p), _) => p.clone(),
            (None, Source::Scalp { file, .. }) => file.clone(),
            (None, Source::Asset { path }) => path.clone(),
        };
        path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
    }

    /// Sets the style; frames of one `gesture` merge into one undo step.
    pub fn set_style(&mut self, style: Style, gesture: Option<Gesture>) {
        let before = self.asset.style;
        if before == style {
            return;
        }
        self.apply_style(style);
        self.record(Edit::Style { before, after: style }, gesture);
    }

    pub fn set_color(&mut self, color: HairColor, gesture: Option<Gesture>) {
        let before = self.color;
        if before == color {
            return;
        }
        self.color = color;
        self.record(Edit::Color { before, after: color }, gesture);
    }

    /// Moves hair-mesh vertices to new positions; frames of one drag merge into one undo step
    /// whose "before" is where the vertices were when the drag began.
    pub fn move_vertices(
        &mut self,
        moves: &[VertexMove],
        gesture: Option<Gesture>,
    ) -> Result<(), EditorError> {
        self.sculpt(moves, None, gesture)
    }

    /// [`Document::move_vertices`] for moves a sculpting tool made as `made_by` says (a session
    /// records it instead of the positions).
    pub fn sculpt(
        &mut self,
        moves: &[VertexMove],
        made_by: Option<crate::sculpt::Sculpt>,
        gesture: Option<Gesture>,
    ) -> Result<(), EditorError> {
        let mesh = self.asset.mesh();
        let before: Vec<VertexMove> = moves
            .iter()
            .map(|m| {
                let position = mesh
                    .layers
                    .get(m.layer as usize)
                    .and_then(|l| l.get(m.vertex as usize))
                    .copied()
                    .unwrap_or(DVec3::NAN);
                VertexMove { position, ..*m }
            })
            .collect();
        self.apply_moves(moves)?;
        self.record(Edit::Vertices { before, after: moves.to_vec(), made_by }, gesture);
        Ok(())
    }

    /// Ends bundles at new tip layers (`(bundle, layer)`, layers clamped to 1..=L): shorter or
    /// longer bundles of the same hair mesh, one undo step.
    pub fn set_tip_layers(&mut self, tips: &[(u32, u32)]) -> Result<(), EditorError> {
        let last = self.asset.mesh().layer_count() as u32;
        let after: Vec<(u32, u32)> = tips.iter().map(|&(b, l)| (b, l.clamp(1, last.max(1)))).collect();
        let before: Vec<(u32, u32)> = after.iter().map(|&(b, _)| (b, self.asset.tip_layer(b))).collect();
        if before == after {
            return Ok(());
        }
        self.apply_tips(&after)?;
        self.record(Edit::TipLayers { before, after }, None);
        Ok(())
    }

    /// Inserts, removes or extrudes a layer of the hair mesh (one undo step). The asset's
    /// textures are baked again and the preview uploads it whole.
    pub fn edit_layers(&mut self, op: &LayerOp) -> Result<(), EditorError> {
        let before = self.asset.mesh().clone();
        let mut after = before.clone();
        op.apply(&mut after).map_err(|source| EditorError::Edit { source })?;
        self.apply_mesh(&after)?;
        self.record(Edit::Layers { op: op.clone(), before: Box::new(before), after: Box::new(after) }, None);
        Ok(())
    }

    /// Ends the current gesture: the next edit starts a new undo step.
    pub fn end_gesture(&mut self) {
        self.open_gesture = None;
    }

    /// Takes back everything the open `gesture` did, leaving no undo or redo step (a cancelled
    /// transform). Nothing happens when another gesture, or none, is open.
    pub fn cancel_gesture(&mut self, gesture: &Gesture) -> Result<(), EditorError> {
        if self.open_gesture.as_ref() != Some(gesture) {
            return Ok(());
        }
        self.open_gesture = None;
        if let Some((_, edit)) = self.undo.pop() {
            self.apply_edit(&edit, false)?;
        }
        Ok(())
    }

    pub fn undo(&mut self) -> Result<(), EditorError> {
        self.end_gesture();
        let Some((id, edit)) = self.undo.pop() else { return Ok(()) };
        self.apply_edit(&edit, false)?;
        self.redo.push((id, edit));
        Ok(())
    }

    pub fn redo(&mut self) -> Result<(), EditorError> {
        self.end_gesture();
        let Some((id, edit)) = self.redo.pop() else { return Ok(()) };
        self.apply_edit(&edit, true)?;
        self.undo.push((id, edit));
        Ok(())
    }

    /// Writes the asset to `dir` atomically (the asset writer replaces the folder in one
    /// rename) and makes it the document's save path.
    /// A head of the third-party data set is recorded as `data:NAME`, so the asset finds it on
    /// any machine ([`data_set::portable_name`]).
    pub fn save_as(&mut self, dir: &Path) -> Result<(), EditorError> {
        let source = self.scalp_file();
        let scalp = self.asset.mesh().layers.first().map_or(&[][..], Vec::as_slice);
        let units = source.as_deref().map_or("file units", |path| hairmesh::convert::file_units(path, scalp));
        let portable = source.as_deref().and_then(data_set::portable_name);
        let mut asset = self.asset.clone();
        if let (Some(name), Some(p)) = (&portable, Arc::make_mut(&mut asset).provenance.as_mut()) {
            p.file = name.clone();
        }
        let recorded = portable.or_else(|| source.as_deref().and_then(Path::to_str).map(str::to_owned));
        hairmesh::asset_io::write_asset(
            dir,
            &asset,
            hairmesh::asset_io::Precision::F32,
            units,
            recorded.as_deref(),
        )
        .map_err(|source| EditorError::Asset { path: dir.to_owned(), source })?;
        self.save_path = Some(dir.to_owned());
        self.saved_edit = self.undo.last().map_or(0, |(id, _)| *id);
        Ok(())
    }

    /// [`Self::save_as`] the current save path.
    pub fn save(&mut self) -> Result<(), EditorError> {
        let Some(dir) = self.save_path.clone() else { return Err(EditorError::NoSavePath) };
        self.save_as(&dir)
    }

    fn record(&mut self, edit: Edit, gesture: Option<Gesture>) {
        self.redo.clear();
        if gesture.is_some()
            && gesture == self.open_gesture
            && let Some((_, last)) = self.undo.last_mut()
        {
            // A different kind of edit under the same gesture becomes a step of its own.
            if let Some(unmerged) = merge_into(last, edit) {
                self.push(unmerged);
            }
            return;
        }
        self.open_gesture = gesture;
        self.push(edit);
    }

    fn push(&mut self, edit: Edit) {
        let id = self.next_edit_id;
        self.next_edit_id += 1;
        self.undo.push((id, edit));
    }

    fn apply_edit(&mut self, edit: &Edit, forward: bool) -> Result<(), EditorError> {
        match edit {
            Edit::Style { before, after } => self.apply_style(if forward { *after } else { *before }),
            Edit::Color { before, after } => self.color = if forward { *after } else { *before },
            Edit::Vertices { before, after, .. } => self.apply_moves(if forward { after } else { before })?,
            Edit::TipLayers { before, after } => self.apply_tips(if forward { after } else { before })?,
            Edit::Layers { before, after, .. } => self.apply_mesh(if forward { after } else { before })?,
        }
        Ok(())
    }

    /// Replaces the hair mesh with one of the same faces and any number of layers: a new asset,
    /// uploaded whole.
    fn apply_mesh(&mut self, mesh: &hairmesh::HairMesh) -> Result<(), EditorError> {
        let asset = self.asset.with_layers(mesh.clone()).map_err(|source| EditorError::Edit { source })?;
        self.asset = Arc::new(asset);
        self.changes.clear();
        self.generation = next_generation();
        Ok(())
    }

    /// Sets each bundle's tip layer in one asset change (an unknown bundle is refused with
    /// nothing changed).
    fn apply_tips(&mut self, tips: &[(u32, u32)]) -> Result<(), EditorError> {
        let change = Arc::make_mut(&mut self.asset)
            .set_tip_layers(tips)
            .map_err(|source| EditorError::Edit { source })?;
        self.push_change(change);
        Ok(())
    }

    fn apply_style(&mut self, style: Style) {
        let change = Arc::make_mut(&mut self.asset).set_style(style);
        self.push_change(change);
    }

    fn apply_moves(&mut self, moves: &[VertexMove]) -> Result<(), EditorError> {
        let change = Arc::make_mut(&mut self.asset)
            .move_vertices(moves)
            .map_err(|source| EditorError::Edit { source })?;
        self.push_change(change);
        Ok(())
    }

    fn push_change(&mut self, change: AssetChange) {
        if self.changes.len() >= MAX_PENDING_CHANGES {
            self.changes.clear();
            self.generation = next_generation();
            return;
        }
        self.changes.push(change);
    }
}

/// Merges `edit` into `last` (the same gesture's earlier frames); gives it back when the two
/// are of different kinds.
fn merge_into(last: &mut Edit, edit: Edit) -> Option<Edit> {
    match (last, edit) {
        (Edit::Style { after, .. }, Edit::Style { after: new, .. }) => *after = new,
        (Edit::Color { after, .. }, Edit::Color { after: new, .. }) => *after = new,
        (
            Edit::Vertices { before, after, made_by },
            Edit::Vertices { before: new_before, after: new_after, made_by: new_made_by },
        ) => {
            // The latest frame's recipe makes the whole gesture (it starts from the same rest).
            *made_by = new_made_by;
            // Each vertex keeps its first "before"; vertices the drag reached later are added.
            for (b, a) in new_before.into_iter().zip(new_after) {
                match after.iter().position(|m| m.layer == a.layer && m.vertex == a.vertex) {
                    Some(i) => after[i] = a,
                    None => {
                        before.push(b);
                        after.push(a);
                    }
                }
            }
        }
        (_, edit) => return Some(edit),
    }
    None
}

/// The frame of the head an occluder shows.
fn estimate_frame(o: &OccluderGeometry) -> Option<HeadFrame> {
    HeadFrame::estimate(&occluder_mesh(o))
}

/// An occluder's triangles as a mesh in the file's (f64) coordinates, for the head's surface and
/// frame.
fn occluder_mesh(o: &OccluderGeometry) -> hairmesh::ScalpMesh {
    hairmesh::ScalpMesh {
        positions: o
            .positions
            .iter()
            .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
            .collect(),
        faces: o.indices.chunks_exact(3).map(<[u32]>::to_vec).collect(),
        ..hairmesh::ScalpMesh::default()
    }
}

/// Reads a mesh to draw with the hair, refusing what the renderer cannot use.
pub fn load_occluder(path: &Path) -> Result<Arc<OccluderGeometry>, EditorError> {
    OccluderGeometry::load(path)
        .map(Arc::new)
        .map_err(|e| EditorError::Mesh { path: path.to_owned(), message: e.to_string() })
}
