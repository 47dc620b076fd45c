//! The editor's UI: menu bar, conversion / style / scene panels, the viewport with the live
//! preview and the hair-mesh overlay, the status bar, dialogs and prompts.
//!
//! [`EditorApp::ui`] draws one frame from the app's state and applies what the user did; it
//! never blocks: conversions run in a thread ([`ConversionJob`]), preview frames come from the
//! [`PreviewWorker`], file dialogs are egui windows (`egui_file`). Tests drive it through
//! `egui_kittest`; `src/main.rs` through `eframe`.
//!
//! **Dragging hair-mesh vertices**: the overlay shows the outer layer (the tips' layer).
//! Dragging one of its vertices moves it in the view plane through it; the layers of the same
//! column follow by their share of the column's length (layer `k` of `L` of a straight column
//! by `k / L`), so the root stays on the scalp and the column keeps its shape, and the inner
//! vertices of the hair mesh follow its surface ([`crate::sculpt`], [`hairmesh::inner`]). With
//! *Mirror* the vertex whose root mirrors this one's across the head's plane of symmetry (x = 0
//! without a head) moves with it, mirrored;
//! with *Soft selection* the tips around it follow, less the further they are.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use egui::{Color32, Pos2, Rect, Sense, Stroke, Vec2};
use glam::{DVec3, Vec3};
use hairmesh::convert::{ConvertSettings, LayerShape};
use hairmesh::head_frame::HeadFrame;
use hairmesh::style::Style;
use render::scene::Transparency;

use crate::EditorError;

mod brushing;
mod modelling;
use crate::camera::{DepthGrid, OrbitCamera, Projection, pick};
use crate::document::{Document, Gesture, Source};
use crate::presets::{PRESETS, Preset};
use crate::preview::{PreviewEvent, PreviewRequest, PreviewScene, PreviewWorker};

/// Pixels within which the pointer picks a hair-mesh vertex.
const PICK_RADIUS: f32 = 8.0;
/// Most recent files remembered.
const MAX_RECENT: usize = 8;

/// What a file dialog is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum DialogPurpose {
    Open,
    SaveAs,
    ExportPng,
    ExportScene,
    SaveSession,
}

/// What waits for the unsaved-changes prompt.
#[derive(Clone, Debug, PartialEq)]
pub enum PendingAction {
    Open(PathBuf),
    Quit,
}

/// A conversion running in a thread.
#[derive(Debug)]
pub struct ConversionJob {
    pub file: PathBuf,
    pub step: String,
    started: Instant,
    progress: Receiver<String>,
    result: Receiver<Result<Document, EditorError>>,
}

/// What the preview is asked to draw: a new one means a new request.
#[derive(Clone, Debug, PartialEq)]
struct RequestKey {
    generation: u64,
    revision: u64,
    camera: OrbitCamera,
    size: [u32; 2],
    scene: PreviewScene,
}

/// The last frame shown.
#[derive(Clone, Debug)]
pub struct ShownFrame {
    pub id: u64,
    pub draft: bool,
    pub ms: f64,
    pub strands: u64,
    pub vertices: u64,
    pub raster: String,
    pub size: [u32; 2],
    image: Arc<gen_gpu::RgbaImage>,
}

/// A vertex drag in progress: the vertices it moves and where they were when it began.
#[derive(Clone, Debug)]
struct VertexDrag {
    /// Outer-layer vertex under the pointer, and its mirror (with *Mirror*).
    vertex: u32,
    mirror: Option<u32>,
    /// Its tip where the drag started.
    tip_start: DVec3,
    /// The columns that move, and the inner vertices that follow them.
    sculpt: crate::sculpt::TipDrag,
    pointer_start: Pos2,
}

/// `--screenshot`: save the window once the first full-quality preview is shown.
#[derive(Debug)]
pub struct ScreenshotRequest {
    pub out: PathBuf,
    title: String,
    asked: bool,
    /// Frames drawn since the final preview was first shown.
    ready_frames: u32,
    /// Set by the capture thread.
    pub result: Arc<Mutex<Option<Result<(), String>>>>,
}

/// The editor's state.
pub struct EditorApp {
    pub doc: Option<Document>,
    pub camera: OrbitCamera,
    pub scene: PreviewScene,
    /// Conversion settings shown in the panel (those of the open scalp, or the next one).
    pub convert: ConvertSettings,
    /// The open head's frame (centre, up, front, size): estimated when a head is converted
    /// for the first time, then the artist's to correct; presets, the drape and gravity follow
    /// it.
    pub head_frame: Option<HeadFrame>,
    /// The head the conversion settings' selector, length and drape centre were made for.
    head_file: Option<PathBuf>,
    pub conversion: Option<ConversionJob>,
    preview: Option<PreviewWorker>,
    texture: Option<egui::TextureHandle>,
    pub shown: Option<ShownFrame>,
    /// Request keys sent, draft and full.
    requested: Option<(RequestKey, bool)>,
    last_request_id: Option<u64>,
    /// A preset button pressed this frame (applied after the panel is drawn).
    pending_preset: Option<&'static Preset>,
    pub device: Option<String>,
    pub preview_error: Option<String>,
    /// The error shown in the error window (file and problem).
    pub error: Option<String>,
    /// One-line notes in the status bar (saved, exported, …).
    pub note: Option<String>,
    pub pending: Option<PendingAction>,
    dialog: Option<(DialogPurpose, egui_file::FileDialog)>,
    pub recent: Vec<PathBuf>,
    /// Where the recent-file list is kept (`None`: memory only).
    recent_file: Option<PathBuf>,
    pub show_overlay: bool,
    pub mirror_x: bool,
    /// Soft-selection radius as a fraction of the hair's length (0: off).
    pub soft_radius: f64,
    /// Painting the scalp: the head's faces and the selection (while the mode is on).
    pub scalp_paint: Option<crate::scalp_paint::ScalpPaint>,
    /// The scalp brush's radius in viewport pixels.
    pub brush_radius: f32,
    /// Where the suggested hairline is (skull radii; [`hairmesh::head_frame::HAIRLINE_OFFSET`]).
    pub hairline_offset: f64,
    pub hovered_vertex: Option<u32>,
    /// The occluder's depth as the viewport sees it, and the view it was made for: the overlay
    /// hides and does not pick vertices behind the head.
    overlay_depth: Option<(OverlayView, Arc<DepthGrid>)>,
    /// The selected columns (outer-layer tips), sorted: what G/R/S transform and F frames.
    pub selection: Vec<u32>,
    /// A grab, rotation or scale of the selection in progress.
    modal: Option<modelling::Modal>,
    /// A selection box being dragged out.
    box_select: Option<modelling::BoxSelect>,
    /// The hair brush in use (`None`: select and transform).
    pub hair_brush: Option<crate::brush::BrushKind>,
    /// The hair brush's radius in viewport pixels, and its strength (0..=1).
    pub hair_brush_radius: f32,
    pub brush_strength: f64,
    /// A brush stroke in progress.
    stroke: Option<brushing::BrushStroke>,
    /// The view a session being replayed was saved with.
    session_camera: Option<OrbitCamera>,
    drag: Option<VertexDrag>,
    /// The vertex under the pointer when the primary button went down.
    press_vertex: Option<u32>,
    /// A slider or a drag is active this frame: previews are drafts.
    interacting: bool,
    viewport_size: [u32; 2],
    /// Where the viewport was drawn last frame (points), for tests and tools.
    pub viewport_rect: Rect,
    pub screenshot: Option<ScreenshotRequest>,
    /// The window should close (eframe's glue acts on it).
    pub quit: bool,
    /// Requests sent to the preview.
    pub preview_requests: u64,
}

/// What the overlay's occluder depth was made for.
#[derive(Clone, Debug)]
struct OverlayView {
    camera: OrbitCamera,
    size: [f32; 2],
    /// A new document or scalp brings a new occluder (compared by identity).
    occluder: Arc<render::occluder::OccluderGeometry>,
}

impl PartialEq for OverlayView {
    fn eq(&self, other: &Self) -> bool {
        self.camera == other.camera && self.size == other.size && Arc::ptr_eq(&self.occluder, &other.occluder)
    }
}

/// How far (a fraction of the depth) the head must lie in front of a vertex to hide it: hair
/// tips sit a layer's thickness above the scalp, and the depth image is coarse.
const OVERLAY_DEPTH_TOLERANCE: f32 = 0.01;

impl std::fmt::Debug for EditorApp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EditorApp").field("doc", &self.doc.as_ref().map(Document::title)).finish()
    }
}

impl EditorApp {
    /// An editor with the preview worker started (it wakes `ctx` when a frame is ready).
    /// `recent_file` keeps the recent-file list across sessions.
    pub fn new(ctx: &egui::Context, recent_file: Option<PathBuf>) -> Self {
        let waker = ctx.clone();
        let preview = PreviewWorker::start(move || waker.request_repaint());
        let recent = recent_file
            .as_deref()
            .and_then(|f| std::fs::read_to_string(f).ok())
            .and_then(|t| serde_json::from_str::<Vec<PathBuf>>(&t).ok())
            .unwrap_or_default();
        Self {
            doc: None,
            camera: OrbitCamera::default(),
            scene: PreviewScene::default(),
            convert: ConvertSettings::default(),
            head_frame: None,
            head_file: None,
            conversion: None,
            preview: Some(preview),
            texture: None,
            shown: None,
            requested: None,
            last_request_id: None,
            pending_preset: None,
            device: None,
            preview_error: None,
            error: None,
            note: None,
            pending: None,
            dialog: None,
            recent,
            recent_file,
            show_overlay: true,
            mirror_x: false,
            soft_radius: 0.0,
            scalp_paint: None,
            brush_radius: 30.0,
            hairline_offset: hairmesh::head_frame::HAIRLINE_OFFSET,
            hovered_vertex: None,
            overlay_depth: None,
            selection: Vec::new(),
            modal: None,
            box_select: None,
            session_camera: None,
            hair_brush: None,
            hair_brush_radius: 60.0,
            brush_strength: 0.5,
            stroke: None,
            drag: None,
            press_vertex: None,
            interacting: false,
            viewport_size: [0, 0],
            viewport_rect: Rect::NOTHING,
            screenshot: None,
            quit: false,
            preview_requests: 0,
        }
    }

    /// Opens a scalp mesh (converted in the background with [`Self::convert`]) or an asset,
    /// asking first when the open document has unsaved changes.
    pub fn open(&mut self, path: &Path) {
        if self.doc.as_ref().is_some_and(Document::is_dirty) {
            self.pending = Some(PendingAction::Open(path.to_owned()));
            return;
        }
        self.open_now(path);
    }

    fn open_now(&mut self, path: &Path) {
        // One spelling per file, so the asset names its head as a replayed session does.
        let path = &crate::session::spelled_from_here(path);
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
        if matches!(ext.as_str(), "glb" | "gltf" | "obj") {
            self.settings_for_head(path);
            self.start_conversion(path.to_owned());
        } else if ext == "json" && crate::session::Session::is_session(path) {
            self.open_session(path);
        } else if path.is_dir() || path.file_name().is_some_and(|n| n == "hair.json") {
            match Document::open_asset(path) {
                Ok(doc) => {
                    if let Some(s) = ConvertSettings::from_asset(doc.asset()) {
                        self.convert = s;
                        self.head_file = doc.scalp_file();
                    }
                    self.head_frame = doc.frame();
                    self.set_document(doc);
                    self.remember(path);
                }
                Err(e) => self.error = Some(e.to_string()),
            }
        } else {
            self.error = Some(EditorError::UnknownFile { path: path.to_owned() }.to_string());
        }
    }

    /// Another head than the settings were made for gets the defaults of what depends on the
    /// head — the scalp (the hairline suggested by its frame, `auto`), the length, the frame
    /// (estimated again) and the drape (another head's centre would put the hair in the wrong
    /// place) — and keeps the rest (layers, strands, style).
    fn settings_for_head(&mut self, head: &Path) {
        let same = |a: &Path, b: &Path| {
            a.canonicalize().ok().zip(b.canonicalize().ok()).is_some_and(|(a, b)| a == b)
        };
        if self.head_file.as_deref().is_some_and(|h| same(h, head)) {
            return;
        }
        let defaults = ConvertSettings::default();
        self.convert.scalp = hairmesh::ScalpSelector::Auto.to_string();
        self.convert.length = defaults.length;
        self.convert.up = defaults.up;
        if matches!(self.convert.shape, LayerShape::Drape { .. }) {
            self.convert.shape = defaults.shape;
        }
        self.head_frame = None;
        self.head_file = Some(head.to_owned());
    }

    /// Opens the sample head (from the third-party data set, wherever the resolver finds it)
    /// with its scalp selection and the drape settings of its skull; where the data set is
    /// missing, the error says how to get it.
    pub fn open_sample_head(&mut self) {
        use hairmesh::convert::sample_head;
        let head = match sample_head::locate() {
            Ok(head) => head,
            Err(missing) => {
                self.error = Some(missing.to_string());
                return;
            }
        };
        self.convert.scalp = sample_head::SCALP.into();
        self.convert.length = None;
        self.convert.up = DVec3::Y;
        if matches!(self.convert.shape, LayerShape::Drape { .. }) {
            self.convert.shape = ConvertSettings::default().shape;
        }
        self.head_frame = None;
        // These settings are the sample head's own.
        self.head_file = Some(head.clone());
        self.open(&head);
    }

    /// Converts `file` with the panel's settings (and the open document's style) in a thread.
    pub fn start_conversion(&mut self, file: PathBuf) {
        let mut settings = self.convert.clone();
        if let Some(doc) = &self.doc {
            settings.style = doc.style();
        }
        let (progress_send, progress) = channel();
        let (result_send, result) = channel();
        let thread_file = file.clone();
        let frame = self.head_frame;
        let spawned = std::thread::Builder::new().name("hair conversion".into()).spawn(move || {
            let doc = Document::convert_scalp(&thread_file, &settings, frame, &mut |step| {
                let _ = progress_send.send(step.to_owned());
            });
            let _ = result_send.send(doc);
        });
        match spawned {
            Ok(_) => {
                self.conversion = Some(ConversionJob {
                    file,
                    step: "starting".into(),
                    started: Instant::now(),
                    progress,
                    result,
                });
            }
            Err(e) => self.error = Some(format!("cannot start the conversion: {e}")),
        }
    }

    /// Waits for a running conversion (tests and `--screenshot`); `false` on timeout.
    pub fn wait_for_conversion(&mut self, timeout: std::time::Duration) -> bool {
        let Some(job) = &self.conversion else { return true };
        match job.result.recv_timeout(timeout) {
            Ok(result) => {
                self.finish_conversion(result);
                true
            }
            Err(_) => false,
        }
    }

    fn finish_conversion(&mut self, result: Result<Document, EditorError>) {
        let Some(job) = self.conversion.take() else { return };
        match result {
            Ok(doc) => {
                self.note = Some(format!(
                    "converted {} in {:.1} s: {} strands",
                    job.file.display(),
                    job.started.elapsed().as_secs_f64(),
                    doc.asset().total_strands()
                ));
                if self.head_frame.is_none() {
                    self.head_frame = doc.frame();
                }
                if let Some(f) = &self.head_frame {
                    self.convert.up = f.up;
                }
                self.set_document(doc);
                if let Some(camera) = self.session_camera.take() {
                    self.camera = camera;
                }
                self.remember(&job.file);
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    fn set_document(&mut self, doc: Document) {
        let (lo, hi) = doc.asset().bounds();
        let (mut lo, mut hi) = (lo.as_vec3(), hi.as_vec3());
        if let Some(o) = &doc.occluder
            && let Some((olo, ohi)) = occluder_bounds(o)
        {
            lo = lo.min(olo);
            hi = hi.max(ohi);
        }
        self.camera.frame(lo, hi);
        self.doc = Some(doc);
        self.drag = None;
        self.hovered_vertex = None;
        self.selection.clear();
        self.modal = None;
        self.box_select = None;
    }

    fn remember(&mut self, path: &Path) {
        let path = path.canonicalize().unwrap_or_else(|_| path.to_owned());
        self.recent.retain(|p| *p != path);
        self.recent.insert(0, path);
        self.recent.truncate(MAX_RECENT);
        if let Some(file) = &self.recent_file
            && let Ok(text) = serde_json::to_string_pretty(&self.recent)
        {
            // Losing the list is harmless; the UI keeps working.
            let _ = hairmesh::atomic::write_file_atomic(file, |w| w.write_all(text.as_bytes()));
        }
    }

    /// Saves to the document's folder; without one, opens the Save As dialog.
    pub fn save(&mut self) {
        let Some(doc) = &mut self.doc else { return };
        if doc.save_path.is_none() {
            self.open_dialog(DialogPurpose::SaveAs);
            return;
        }
        match doc.save() {
            Ok(()) => {
                self.note =
                    Some(format!("saved {}", doc.save_path.as_deref().unwrap_or(Path::new("")).display()));
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    pub fn save_as(&mut self, dir: &Path) {
        let Some(doc) = &mut self.doc else { return };
        match doc.save_as(dir) {
            Ok(()) => {
                self.note = Some(format!("saved {}", dir.display()));
                self.remember(dir);
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// The files the document was made from: an export must not replace them.
    fn inputs(&self) -> Vec<PathBuf> {
        let Some(doc) = &self.doc else { return Vec::new() };
        doc.scalp_file().into_iter().chain(doc.save_path.clone()).collect()
    }

    /// May an export of `kind` replace `path`? Only a new path or an earlier export of its kind
    /// (the editor has no --force: choose another name, or remove the file first).
    fn check_export(&self, path: &Path, kind: hairmesh::output::FileKind) -> Result<(), String> {
        let inputs = self.inputs();
        let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        hairmesh::output::check_file(path, kind, &inputs, hairmesh::output::Replace::OwnOutput)
            .map_err(|e| e.to_string().replace(", or pass --force to replace it", ""))
    }

    /// Writes the last preview frame as PNG (atomically).
    pub fn export_png(&mut self, path: &Path) {
        if let Err(e) = self.check_export(path, hairmesh::output::FileKind::Png) {
            self.error = Some(e);
            return;
        }
        let result = match &self.shown {
            Some(f) => render::output::write_png(path, &f.image).map_err(|e| e.to_string()),
            None => Err(EditorError::NoFrame.to_string()),
        };
        match result {
            Ok(()) => self.note = Some(format!("exported {}", path.display())),
            Err(e) => self.error = Some(e),
        }
    }

    /// Writes the session that made the document (its start and every edit,
    /// [`crate::session`]) to `path`, atomically.
    pub fn save_session(&mut self, path: &Path) {
        let Some(doc) = &self.doc else { return };
        if let Err(e) = self.check_export(path, crate::session::SESSION_FILE) {
            self.error = Some(e);
            return;
        }
        let session = crate::session::Session::record(doc, self.head_frame, self.camera, path);
        match session.write(path) {
            Ok(()) => {
                self.note = Some(format!(
                    "saved the session ({} commands) to {}",
                    session.commands.len(),
                    path.display()
                ));
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// Replays a session file in the background (like a conversion); the document it makes
    /// opens with the session's view and head frame.
    pub fn open_session(&mut self, path: &Path) {
        let session = match crate::session::Session::read(path) {
            Ok(s) => s,
            Err(e) => {
                self.error = Some(e.to_string());
                return;
            }
        };
        if let crate::session::Start::Convert { settings, frame, .. } = &session.start {
            self.convert = settings.clone();
            self.head_frame = *frame;
        }
        let camera = session.camera;
        self.head_file = None;
        let (progress_send, progress) = channel();
        let (result_send, result) = channel();
        let file = path.to_owned();
        let spawned = std::thread::Builder::new().name("session replay".into()).spawn(move || {
            let doc = session.replay(&file, &mut |step| {
                let _ = progress_send.send(step.to_owned());
            });
            let _ = result_send.send(doc);
        });
        match spawned {
            Ok(_) => {
                self.conversion = Some(ConversionJob {
                    file: path.to_owned(),
                    step: "replaying".into(),
                    started: Instant::now(),
                    progress,
                    result,
                });
                self.session_camera = Some(camera);
            }
            Err(e) => self.error = Some(format!("cannot start the replay: {e}")),
        }
    }

    /// Writes a scene file that renders this view with `hair-render` (the document must be
    /// saved: the scene names its folder).
    pub fn export_scene(&mut self, path: &Path) {
        if let Err(e) = self.check_export(path, render::scene::SCENE_FILE) {
            self.error = Some(e);
            return;
        }
        match self.scene_file(path) {
            Ok(text) => match hairmesh::atomic::write_file_atomic(path, |w| w.write_all(text.as_bytes())) {
                Ok(()) => {
                    self.note = Some(format!("exported {} (render it with hair-render)", path.display()));
                }
                Err(e) => self.error = Some(format!("{}: {e}", path.display())),
            },
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// The scene file of the current view, with paths relative to `scene_path`'s folder when
    /// they can be.
    pub fn scene_file(&self, scene_path: &Path) -> Result<String, EditorError> {
        let Some(doc) = &self.doc else { return Err(EditorError::NoSavePath) };
        let Some(asset_dir) = &doc.save_path else { return Err(EditorError::NoSavePath) };
        let base = scene_path.parent().unwrap_or(Path::new("."));
        let base = base.canonicalize().unwrap_or_else(|_| base.to_owned());
        let relative = |p: &Path| -> PathBuf {
            let abs = p.canonicalize().unwrap_or_else(|_| p.to_owned());
            abs.strip_prefix(&base).map(Path::to_owned).unwrap_or(abs)
        };
        let occluder = doc.scalp_file().filter(|f| doc.occluder.is_some() && f.is_file()).map(|f| {
            render::scene::OccluderDesc {
                mesh: relative(&f),
                transform: Default::default(),
                color: self.scene.occluder_color,
            }
        });
        let color = doc.color();
        let [w, h] = self.shown.as_ref().map_or([960, 540], |s| s.size);
        let mut scene = self.scene.scene(&self.camera, w, h);
        scene.characters.push(render::scene::CharacterDesc {
            hair: relative(asset_dir),
            transform: Default::default(),
            color: color.rgb,
            color_variation: color.variation,
            style: None,
            strand_width: None,
            occluder,
            motion: None,
            dynamics: None,
        });
        serde_json::to_string_pretty(&scene)
            .map_err(|e| EditorError::Io { path: scene_path.to_owned(), message: e.to_string() })
    }

    /// Applies a preset: the style always; with a scalp document, also its layers (converted
    /// again in the background).
    pub fn apply_preset(&mut self, preset: &Preset) {
        let Some(doc) = &mut self.doc else { return };
        // The head's frame (estimated, perhaps corrected); a scalp without a head is guessed
        // to be a cap facing +Z.
        let frame = self.head_frame.unwrap_or_else(|| {
            let (lo, hi) = point_bounds(&doc.asset().mesh().layers[0]);
            crate::presets::scalp_frame(lo, hi)
        });
        let (length, shape) = preset.layers_on(&frame);
        let rescale = if let Source::Scalp { file, .. } = &doc.source { Some(file.clone()) } else { None };
        let style_length = if rescale.is_some() { length } else { doc.hair_length() };
        doc.set_style(preset.style_for(style_length), None);
        if let Some(file) = rescale {
            self.convert.length = Some(length);
            self.convert.layers = preset.layers;
            self.convert.shape = shape;
            self.convert.up = frame.up;
            self.start_conversion(file);
        }
    }

    /// Undo / redo with errors shown.
    pub fn undo(&mut self) {
        if let Some(doc) = &mut self.doc
            && let Err(e) = doc.undo()
        {
            self.error = Some(e.to_string());
        }
    }

    pub fn redo(&mut self) {
        if let Some(doc) = &mut self.doc
            && let Err(e) = doc.redo()
        {
            self.error = Some(e.to_string());
        }
    }

    /// Quits, asking first about unsaved changes.
    pub fn request_quit(&mut self) {
        if self.doc.as_ref().is_some_and(Document::is_dirty) {
            self.pending = Some(PendingAction::Quit);
        } else {
            self.quit = true;
        }
    }

    fn open_dialog(&mut self, purpose: DialogPurpose) {
        let start = self
            .doc
            .as_ref()
            .and_then(|d| d.save_path.clone())
            .or_else(|| self.recent.first().cloned())
            .and_then(|p| p.parent().map(Path::to_owned))
            .unwrap_or_else(|| PathBuf::from("."));
        let mut dialog = match purpose {
            DialogPurpose::Open => egui_file::FileDialog::open_file()
                .title("Open a head or scalp mesh, a hair asset (its hair.json) or a session")
                .show_files_filter(Box::new(|p: &Path| {
                    let ext = p.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
                    matches!(ext.as_str(), "glb" | "gltf" | "obj" | "json")
                })),
            DialogPurpose::SaveAs => {
                egui_file::FileDialog::select_folder().title("Save the asset as a folder")
            }
            DialogPurpose::ExportPng => {
                egui_file::FileDialog::save_file().title("Export the viewport as PNG")
            }
            DialogPurpose::ExportScene => egui_file::FileDialog::save_file().title("Export a scene file"),
            DialogPurpose::SaveSession => {
                egui_file::FileDialog::save_file().title("Save the session (the commands that made the hair)")
            }
        }
        .initial_path(start);
        dialog.open();
        self.dialog = Some((purpose, dialog));
    }

    /// The request the preview should be drawing now.
    fn request_key(&self) -> Option<RequestKey> {
        let doc = self.doc.as_ref()?;
        if self.viewport_size[0] < 8 || self.viewport_size[1] < 8 {
            return None;
        }
        let mut scene = self.scene.clone();
        scene.color = doc.color();
        Some(RequestKey {
            generation: doc.generation,
            revision: doc.asset().revision(),
            camera: self.camera,
            size: self.viewport_size,
            scene,
        })
    }

    /// Sends a draft while interacting and the full frame after, once per state.
    fn update_preview(&mut self) {
        let (Some(key), Some(doc)) = (self.request_key(), self.doc.as_ref()) else { return };
        let draft = self.interacting;
        let key_changed = self.requested.as_ref().is_none_or(|(k, _)| *k != key);
        let refine = self.requested.as_ref().is_some_and(|(k, d)| *k == key && *d && !draft);
        if !(key_changed || refine) {
            return;
        }
        let Some(worker) = self.preview.as_mut() else { return };
        let id =
            worker.request(PreviewRequest::for_document(doc, key.scene.clone(), key.camera, key.size, draft));
        self.preview_requests += 1;
        self.last_request_id = Some(id);
        self.requested = Some((key, draft));
    }

    fn poll_preview(&mut self, ctx: &egui::Context) {
        let events = self.preview.as_ref().map(PreviewWorker::poll).unwrap_or_default();
        for event in events {
            self.apply_preview_event(ctx, event);
        }
    }

    /// Waits up to `timeout` for the next preview event and applies it (tests and
    /// `--screenshot`); `false` on timeout.
    pub fn wait_for_preview(&mut self, ctx: &egui::Context, timeout: std::time::Duration) -> bool {
        let Some(event) = self.preview.as_ref().and_then(|w| w.wait(timeout)) else { return false };
        self.apply_preview_event(ctx, event);
        true
    }

    /// Applies one event of the preview worker (frames become the viewport texture).
    fn apply_preview_event(&mut self, ctx: &egui::Context, event: PreviewEvent) {
        match event {
            PreviewEvent::Ready { device, path } => {
                self.device = Some(format!("{device} · {path} generation"));
            }
            PreviewEvent::Unavailable { message } | PreviewEvent::Failed { message, .. } => {
                self.preview_error = Some(message);
            }
            PreviewEvent::Frame(frame) => {
                self.preview_error = None;
                let image = egui::ColorImage::from_rgba_unmultiplied(
                    [frame.image.width as usize, frame.image.height as usize],
                    &frame.image.pixels,
                );
                let options = egui::TextureOptions::LINEAR;
                match &mut self.texture {
                    Some(t) => t.set(image, options),
                    None => self.texture = Some(ctx.load_texture("hair preview", image, options)),
                }
                self.shown = Some(ShownFrame {
                    id: frame.id,
                    draft: frame.draft,
                    ms: frame.ms,
                    strands: frame.strands,
                    vertices: frame.vertices,
                    raster: frame.raster,
                    size: [frame.image.width, frame.image.height],
                    image: Arc::new(frame.image),
                });
            }
        }
    }

    /// The preview frame shown (sRGB RGBA).
    pub fn shown_image(&self) -> Option<&gen_gpu::RgbaImage> {
        self.shown.as_ref().map(|s| &*s.image)
    }

    /// Whether the preview shows a full-quality frame of the current state.
    pub fn preview_is_final(&self) -> bool {
        // The frame answers the latest request, which was for the current state.
        self.shown.as_ref().is_some_and(|s| !s.draft && Some(s.id) == self.last_request_id)
            && self.requested.as_ref().is_some_and(|(k, _)| Some(k) == self.request_key().as_ref())
    }

    /// Draws one frame and applies its input.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        self.poll_preview(&ctx);
        if let Some(job) = &mut self.conversion {
            if let Some(step) = job.progress.try_iter().last() {
                job.step = step;
            }
            if let Ok(result) = job.result.try_recv() {
                self.finish_conversion(result);
            } else {
                ctx.request_repaint_after(std::time::Duration::from_millis(100));
            }
        }
        self.interacting = false;
        self.shortcuts(&ctx);
        if ctx.input(|i| i.viewport().close_requested()) && !self.quit {
            self.request_quit();
            if !self.quit {
                ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            }
        }

        egui::Panel::top("menu").show(ui, |ui| self.menu_bar(ui));
        egui::Panel::bottom("status").show(ui, |ui| self.status_bar(ui));
        egui::Panel::left("panels").resizable(true).default_size(300.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.side_panel(ui));
        });
        egui::CentralPanel::no_frame().show(ui, |ui| self.viewport(ui));

        self.dialogs(&ctx);
        self.update_preview();
        self.screenshot_step(&ctx);
        if self.quit {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }

    fn shortcuts(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        let undo = KeyboardShortcut::new(Modifiers::COMMAND, Key::Z);
        let redo = KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
        let redo_y = KeyboardShortcut::new(Modifiers::COMMAND, Key::Y);
        let save = KeyboardShortcut::new(Modifiers::COMMAND, Key::S);
        let open = KeyboardShortcut::new(Modifiers::COMMAND, Key::O);
        // The longer shortcut first: Ctrl+Shift+Z also matches Ctrl+Z.
        if ctx.input_mut(|i| i.consume_shortcut(&redo) || i.consume_shortcut(&redo_y)) {
            self.redo();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&undo)) {
            self.undo();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&save)) {
            self.save();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&open)) {
            self.open_dialog(DialogPurpose::Open);
        }
    }

    fn menu_bar(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…").clicked() {
                    self.open_dialog(DialogPurpose::Open);
                }
                if ui.button("Open sample head").on_hover_text(hairmesh::convert::sample_head::PATH).clicked()
                {
                    self.open_sample_head();
                }
                ui.menu_button("Open recent", |ui| {
                    if self.recent.is_empty() {
                        ui.label("(none)");
                    }
                    for p in self.recent.clone() {
                        if ui.button(p.display().to_string()).clicked() {
                            self.open(&p);
                        }
                    }
                });
                ui.separator();
                let has_doc = self.doc.is_some();
                if ui.add_enabled(has_doc, egui::Button::new("Save")).clicked() {
                    self.save();
                }
                if ui.add_enabled(has_doc, egui::Button::new("Save As…")).clicked() {
                    self.open_dialog(DialogPurpose::SaveAs);
                }
                ui.separator();
                if ui.add_enabled(self.shown.is_some(), egui::Button::new("Export PNG…")).clicked() {
                    self.open_dialog(DialogPurpose::ExportPng);
                }
                let saved = self.doc.as_ref().is_some_and(|d| d.save_path.is_some());
                if ui
                    .add_enabled(saved, egui::Button::new("Export scene…"))
                    .on_disabled_hover_text("save the asset first: the scene names its folder")
                    .clicked()
                {
                    self.open_dialog(DialogPurpose::ExportScene);
                }
                if ui
                    .add_enabled(has_doc, egui::Button::new("Save session…"))
                    .on_hover_text("The commands that made this hairstyle (replay: hair-editor --replay SESSION.json -o ASSET)")
                    .clicked()
                {
                    self.open_dialog(DialogPurpose::SaveSession);
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    self.request_quit();
                }
            });
            ui.menu_button("Edit", |ui| {
                let (u, r) = self.doc.as_ref().map_or((false, false), |d| (d.can_undo(), d.can_redo()));
                if ui.add_enabled(u, egui::Button::new("Undo")).clicked() {
                    self.undo();
                }
                if ui.add_enabled(r, egui::Button::new("Redo")).clicked() {
                    self.redo();
                }
            });
            ui.menu_button("View", |ui| {
                ui.checkbox(&mut self.show_overlay, "Hair-mesh overlay");
                if ui.button("Frame selected (F)").clicked() {
                    self.frame_hair();
                }
            });
        });
    }

    /// Frames the selected hair-mesh columns, or the whole hair without a selection.
    fn frame_hair(&mut self) {
        let Some(doc) = &self.doc else { return };
        let (lo, hi) = match self.selection_bounds(doc) {
            Some((lo, hi)) => {
                // A column is thin: frame at least a tenth of the hair around it.
                let (alo, ahi) = doc.asset().bounds();
                let pad = DVec3::splat(0.05 * alo.distance(ahi));
                (lo - pad, hi + pad)
            }
            None => doc.asset().bounds(),
        };
        self.camera.frame(lo.as_vec3(), hi.as_vec3());
    }

    fn status_bar(&mut self, ui: &mut egui::Ui) {
        // The document's title is laid out first, from the right, so it keeps its place; the
        // rest fills what is left and is cut short ("…") rather than run under it.
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            if let Some(doc) = &self.doc {
                ui.label(format!("{}{}", doc.title(), if doc.is_dirty() { " •" } else { "" }));
                ui.separator();
            }
            ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                let text = |ui: &mut egui::Ui, text: String| ui.add(egui::Label::new(text).truncate());
                // A running transform's numbers and keys come first: they are what one reads.
                if let Some(m) = &self.modal {
                    text(ui, m.status.clone());
                    return;
                }
                text(ui, self.device.clone().unwrap_or_else(|| "starting the preview device…".into()));
                ui.separator();
                match &self.shown {
                    Some(s) => text(
                        ui,
                        format!(
                            "{} raster · {} strands · {} vertices · {}×{} {} · {:.0} ms",
                            s.raster,
                            s.strands,
                            s.vertices,
                            s.size[0],
                            s.size[1],
                            if s.draft { "draft" } else { "full" },
                            s.ms
                        ),
                    ),
                    None => text(ui, "no preview yet".into()),
                };
                if let Some(e) = &self.preview_error {
                    ui.separator();
                    ui.add(
                        egui::Label::new(
                            egui::RichText::new(format!("preview: {e}"))
                                .color(Color32::from_rgb(230, 120, 90)),
                        )
                        .truncate(),
                    );
                }
                if let Some(job) = &self.conversion {
                    ui.separator();
                    ui.add(egui::Spinner::new());
                    text(ui, format!("converting {}: {}…", job.file.display(), job.step));
                }
                if let Some(n) = &self.note {
                    ui.separator();
                    text(ui, n.clone());
                }
            });
        });
    }

    fn side_panel(&mut self, ui: &mut egui::Ui) {
        egui::CollapsingHeader::new("Conversion").default_open(true).show(ui, |ui| self.conversion_panel(ui));
        egui::CollapsingHeader::new("Sculpt").default_open(true).show(ui, |ui| self.sculpt_panel(ui));
        egui::CollapsingHeader::new("Style").default_open(true).show(ui, |ui| self.style_panel(ui));
        egui::CollapsingHeader::new("Scene").default_open(true).show(ui, |ui| self.scene_panel(ui));
    }

    fn conversion_panel(&mut self, ui: &mut egui::Ui) {
        // Scalp painting: the way to choose a scalp without typing a selector.
        ui.horizontal(|ui| match &self.scalp_paint {
            None => {
                let can = self.doc.as_ref().and_then(Document::scalp_file).is_some();
                if ui
                    .add_enabled(can, egui::Button::new("Paint scalp"))
                    .on_hover_text(
                        "Paint the faces that grow hair with a brush; the hair is converted again from them",
                    )
                    .clicked()
                {
                    self.start_scalp_paint();
                }
            }
            Some(paint) => {
                ui.label(format!("{} faces painted", paint.count()));
                if ui.button("Apply").clicked() {
                    self.apply_scalp_paint();
                } else if ui.button("Cancel").clicked() {
                    self.scalp_paint = None;
                }
            }
        });
        if let Some(paint) = &mut self.scalp_paint {
            ui.horizontal(|ui| {
                let label = ui.label("Brush");
                ui.add(egui::Slider::new(&mut self.brush_radius, 4.0..=200.0).suffix(" px"))
                    .labelled_by(label.id);
            });
            if let Some(frame) = &self.head_frame {
                ui.horizontal(|ui| {
                    let label = ui.label("Hairline");
                    let slider = egui::Slider::new(&mut self.hairline_offset, -0.8..=0.6)
                        .suffix(" radii")
                        .custom_formatter(|v, _| format!("{v:+.2}"));
                    let moved = ui.add(slider).labelled_by(label.id).on_hover_text(
                        "Height of the suggested hairline over the skull's centre (tilted: high on the forehead, low at the nape)",
                    );
                    let suggest = ui.button("Suggest").on_hover_text(
                        "Select the faces above the hairline suggested by the head's frame (replaces the painting)",
                    );
                    if moved.changed() || suggest.clicked() {
                        paint.suggest_hairline(frame, self.hairline_offset);
                    }
                });
            }
            ui.label("Drag to paint, Shift-drag to erase, Alt-drag to orbit.");
        }
        self.head_frame_row(ui);
        let c = &mut self.convert;
        egui::Grid::new("conversion").num_columns(2).show(ui, |ui| {
            let l = ui.label("Scalp faces");
            ui.text_edit_singleline(&mut c.scalp)
                .labelled_by(l.id)
                .on_hover_text("auto (the suggested hairline), all, name:NAME, above:NX,NY,NZ,OFFSET, sphere:CX,CY,CZ,R, faces:LIST (Paint scalp writes it)");
            ui.end_row();
            let l = ui.label("Layers");
            ui.add(egui::DragValue::new(&mut c.layers).range(1..=hairmesh::hair_mesh::MAX_LAYERS))
                .labelled_by(l.id);
            ui.end_row();
            let l = ui.label("Length");
            let mut auto = c.length.is_none();
            ui.horizontal(|ui| {
                if ui.checkbox(&mut auto, "auto").changed() {
                    c.length = if auto { None } else { Some(1.0) };
                }
                if let Some(length) = &mut c.length {
                    ui.add(egui::DragValue::new(length).speed(0.01).range(1e-4..=1e4)).labelled_by(l.id);
                }
            });
            ui.end_row();
            ui.label("Shape");
            ui.horizontal(|ui| {
                let extrude = matches!(c.shape, LayerShape::Extrude { .. });
                if ui.selectable_label(extrude, "extrude").clicked() && !extrude {
                    c.shape = LayerShape::Extrude { droop: 0.3 };
                }
                let drape = matches!(c.shape, LayerShape::Drape { .. });
                if ui.selectable_label(drape, "drape").clicked() && !drape {
                    c.shape = LayerShape::Drape {
                        centre: DVec3::ZERO,
                        comb: DVec3::new(0.0, 0.0, -2.5),
                        lift: 0.05,
                    };
                }
            });
            ui.end_row();
            match &mut c.shape {
                LayerShape::Extrude { droop } => {
                    let l = ui.label("Droop");
                    ui.add(egui::Slider::new(droop, 0.0..=1.0)).labelled_by(l.id);
                    ui.end_row();
                }
                LayerShape::Drape { centre, comb, lift } => {
                    let l = ui.label("Head centre");
                    vec3_edit(ui, centre, l.id);
                    ui.end_row();
                    let l = ui.label("Comb");
                    vec3_edit(ui, comb, l.id);
                    ui.end_row();
                    let l = ui.label("Lift");
                    ui.add(egui::Slider::new(lift, 0.0..=0.5)).labelled_by(l.id);
                    ui.end_row();
                }
                LayerShape::MorphTargets => {
                    ui.label("Layers from");
                    ui.label("the file's morph targets");
                    ui.end_row();
                }
            }
            let l = ui.label("Strands");
            ui.horizontal(|ui| {
                let mut by_density = c.density.is_some();
                let toggle = ui
                    .checkbox(&mut by_density, "by density")
                    .on_hover_text("strands per unit of scalp area instead of a total");
                if toggle.changed() {
                    c.density = by_density.then_some(1000.0);
                }
                match &mut c.density {
                    Some(d) => {
                        ui.add(egui::DragValue::new(d).range(1e-3..=1e9).speed(10.0)).labelled_by(l.id)
                    }
                    None => ui
                        .add(
                            egui::DragValue::new(&mut c.strands)
                                .range(1..=hairmesh::asset::MAX_TOTAL_STRANDS)
                                .speed(100.0),
                        )
                        .labelled_by(l.id),
                };
            });
            ui.end_row();
            let l = ui.label("Root seed");
            ui.add(egui::DragValue::new(&mut c.seed)).labelled_by(l.id);
            ui.end_row();
        });
        let scalp = self.doc.as_ref().and_then(Document::scalp_file).filter(|f| f.is_file());
        ui.horizontal(|ui| {
            let busy = self.conversion.is_some();
            let button = ui.add_enabled(!busy && scalp.is_some(), egui::Button::new("Convert again"));
            if button.on_disabled_hover_text("open a scalp mesh first (File > Open)").clicked()
                && let Some(f) = scalp
            {
                self.start_conversion(f);
            }
            if busy {
                ui.add(egui::Spinner::new());
            }
        });
    }

    /// What *Mirror* mirrors across: the head's plane of symmetry, or x = 0 without a head.
    fn mirror_plane(&self) -> crate::sculpt::MirrorPlane {
        self.head_frame.as_ref().map(crate::sculpt::MirrorPlane::of_head).unwrap_or_default()
    }

    /// The head's frame in words, and the corrections an artist may need: a scan whose back
    /// was taken for its face, or one turned on its side.
    fn head_frame_row(&mut self, ui: &mut egui::Ui) {
        let Some(frame) = &mut self.head_frame else { return };
        let axis = |d: DVec3| -> String {
            let names = [(DVec3::X, "+X"), (DVec3::NEG_X, "−X"), (DVec3::Y, "+Y"), (DVec3::NEG_Y, "−Y")];
            let names = names.into_iter().chain([(DVec3::Z, "+Z"), (DVec3::NEG_Z, "−Z")]);
            names
                .into_iter()
                .find(|(a, _)| a.dot(d) > 0.9999)
                .map_or_else(|| format!("({:.2}, {:.2}, {:.2})", d.x, d.y, d.z), |(_, n)| n.to_owned())
        };
        ui.horizontal_wrapped(|ui| {
            ui.label(format!(
                "Head: up {}, face {}, skull radius {:.3}",
                axis(frame.up),
                axis(frame.front),
                frame.radius
            ))
            .on_hover_text("Estimated from the head mesh; presets, the drape and gravity follow it");
            let mut changed = None;
            if ui.small_button("Turn face").on_hover_text("Turn the face direction 90° about up").clicked() {
                changed = Some(frame.turned(90.0));
            }
            if ui.small_button("Flip face").on_hover_text("The face is on the other side").clicked() {
                changed = Some(frame.flipped());
            }
            let up_axes = [DVec3::Y, DVec3::Z, DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z, DVec3::NEG_X];
            if ui.small_button("Next up").on_hover_text("Take the file's next axis as up").clicked() {
                let i = up_axes.iter().position(|a| a.dot(frame.up) > 0.9999).map_or(0, |i| i + 1);
                changed = frame.with_up(up_axes[i % up_axes.len()]);
            }
            if let Some(f) = changed {
                *frame = f;
                self.convert.up = f.up;
                self.note = Some("head frame changed: apply a preset or convert again to use it".into());
            }
        });
    }

    fn style_panel(&mut self, ui: &mut egui::Ui) {
        let Some(doc) = &mut self.doc else {
            ui.label("Open a scalp mesh or a hair asset (File > Open).");
            return;
        };
        ui.horizontal_wrapped(|ui| {
            ui.label("Presets:");
            for p in PRESETS {
                if ui.button(p.name).clicked() {
                    self.pending_preset = Some(p);
                }
            }
        });
        // Slider ranges follow the hair's length, so one panel fits any head's units.
        let h = doc.hair_length().max(1e-6);
        let mut style = doc.style();
        let mut gesture: Option<String> = None;
        let mut released = false;
        egui::Grid::new("style").num_columns(2).striped(true).show(ui, |ui| {
            // The slider spans what is useful for this hair; a typed value may go further, up to
            // the field's range (`Style::fields`), which the hover text states.
            let mut slider = |ui: &mut egui::Ui, name: &str, value: &mut f64, max: f64| {
                let label = ui.label(name);
                let field = style_field(name);
                let range = Style::range(&field)
                    .map_or(String::new(), |r| format!("{}: {}..={}", field, r.start(), r.end()));
                let r = ui
                    .add(egui::Slider::new(value, 0.0..=max).clamping(egui::SliderClamping::Never))
                    .labelled_by(label.id)
                    .on_hover_text(range);
                if r.changed() {
                    gesture = Some(name.to_owned());
                }
                released |= r.drag_stopped() || r.lost_focus();
                ui.end_row();
            };
            slider(ui, "Width", &mut style.width, 0.02 * h);
            slider(ui, "Tip width", &mut style.tip_width, 1.0);
            slider(ui, "Root fade", &mut style.root_fade, 1.0);
            slider(ui, "Length variation", &mut style.length_variation, 1.0);
            slider(ui, "Curl radius", &mut style.curl.radius, 0.2 * h);
            slider(ui, "Curl frequency", &mut style.curl.frequency, 20.0 / h);
            slider(ui, "Curl phase", &mut style.curl.phase, 1.0);
            slider(ui, "Wave amplitude", &mut style.wave.amplitude, 0.1 * h);
            slider(ui, "Wave frequency", &mut style.wave.frequency, 20.0 / h);
            slider(ui, "Wave coherence", &mut style.wave.coherence, 1.0);
            slider(ui, "Frizz amplitude", &mut style.frizz.amplitude, 0.1 * h);
            slider(ui, "Frizz frequency", &mut style.frizz.frequency, 40.0 / h);
            slider(ui, "Frizz exponent", &mut style.frizz.exponent, 4.0);
            slider(ui, "Clump strength", &mut style.clump.strength, 1.0);
            slider(ui, "Clump exponent", &mut style.clump.exponent, 4.0);
            slider(ui, "Twist", &mut style.twist, 4.0);
            slider(ui, "Stray fraction", &mut style.stray.fraction, 1.0);
            slider(ui, "Stray amplitude", &mut style.stray.amplitude, 0.1 * h);
            let label = ui.label("Seed");
            let r = ui.add(egui::DragValue::new(&mut style.seed)).labelled_by(label.id);
            if r.changed() {
                gesture = Some("Seed".into());
            }
            ui.end_row();
        });
        let mut color = doc.color();
        let mut color_changed = false;
        ui.horizontal(|ui| {
            let label = ui.label("Colour");
            let r = egui::color_picker::color_edit_button_rgb(ui, &mut color.rgb).labelled_by(label.id);
            color_changed |= r.changed();
            let label = ui.label("variation");
            let r = ui.add(egui::Slider::new(&mut color.variation, 0.0..=1.0)).labelled_by(label.id);
            color_changed |= r.changed();
            released |= r.drag_stopped();
        });
        if let Some(name) = gesture {
            let style = sanitized(style);
            doc.set_style(style.clamped(), Some(Gesture::Style(name)));
            self.interacting = true;
        }
        if color_changed {
            doc.set_color(color, Some(Gesture::Color));
            self.interacting = true;
        }
        if released {
            doc.end_gesture();
        }
        // A slider is being dragged (the viewport's drags set this themselves).
        self.interacting |= ui.ctx().dragged_id().is_some();
        if let Some(p) = self.pending_preset.take() {
            self.apply_preset(p);
        }
    }

    fn scene_panel(&mut self, ui: &mut egui::Ui) {
        let e = &mut self.scene.effects;
        ui.horizontal(|ui| {
            ui.label("Transparency");
            for (t, name) in [
                (Transparency::Opaque, "opaque"),
                (Transparency::Blended, "blended"),
                (Transparency::Oit, "OIT"),
            ] {
                ui.selectable_value(&mut e.transparency, t, name);
            }
        });
        ui.checkbox(&mut e.shadows, "Self-shadowing (deep opacity maps)");
        ui.checkbox(&mut e.ao, "Ambient occlusion");
        ui.checkbox(&mut self.show_overlay, "Hair-mesh overlay");
        ui.checkbox(&mut self.mirror_x, "Mirror (symmetric edits)").on_hover_text(
            "Edits move the columns mirrored across the head's plane of symmetry too (x = 0 without a head)",
        );
        ui.horizontal(|ui| {
            let label = ui.label("Soft selection");
            ui.add(egui::Slider::new(&mut self.soft_radius, 0.0..=1.0))
                .labelled_by(label.id)
                .on_hover_text("Tips within this fraction of the hair's length of the dragged one follow it, less the further they are (0: only the dragged column)");
        });
        ui.separator();
        // LOD preview: the distance the hair is seen from, and what the generator drew there.
        ui.horizontal(|ui| {
            let label = ui.label("Distance");
            let r = ui
                .add(egui::Slider::new(&mut self.camera.distance, 0.05..=200.0).logarithmic(true))
                .labelled_by(label.id);
            if r.dragged() {
                self.interacting = true;
            }
        });
        if let (Some(s), Some(doc)) = (&self.shown, &self.doc) {
            ui.label(format!(
                "LOD: {} of {} strands, {} vertices drawn",
                s.strands,
                doc.asset().total_strands(),
                s.vertices
            ));
        }
    }

    fn viewport(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        self.viewport_rect = rect;
        let ppp = ui.ctx().pixels_per_point();
        self.viewport_size = [(rect.width() * ppp).round() as u32, (rect.height() * ppp).round() as u32];
        let response = ui.allocate_rect(rect, Sense::click_and_drag());
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, srgb(self.scene.background));
        if let Some(t) = &self.texture {
            painter.image(t.id(), rect, Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)), Color32::WHITE);
        }
        let Some(doc) = self.doc.as_ref() else {
            let text = match &self.conversion {
                Some(job) => format!("converting {}…", job.file.display()),
                None => "File > Open a scalp mesh (.glb, .gltf, .obj) or a hair asset folder".into(),
            };
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(16.0),
                Color32::GRAY,
            );
            return;
        };
        let projection = Projection::new(&self.camera, glam::Vec2::new(rect.width(), rect.height()));
        let to_screen =
            |p: DVec3| projection.project(p.as_vec3()).map(|(px, _)| rect.min + Vec2::new(px.x, px.y));
        let mesh = doc.asset().mesh();
        let outer = mesh.layers.len() - 1;
        let pointer = response.hover_pos().map(|p| p - rect.min);
        // Drawn faint and not pickable: a tip on the far side of the hair (seen from its
        // middle, it lies away from the camera: long hair hangs away from the view as much as
        // toward it, so the column's own direction says little), and an outer vertex the head hides (tested
        // against a coarse depth image of the occluder, made again when the view changes).
        let depth = doc.occluder.as_ref().map(|o| {
            let view =
                OverlayView { camera: self.camera, size: [rect.width(), rect.height()], occluder: o.clone() };
            match &self.overlay_depth {
                Some((v, grid)) if *v == view => grid.clone(),
                _ => {
                    let positions: Vec<Vec3> =
                        o.positions.iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
                    let grid = Arc::new(DepthGrid::rasterize(&projection, &positions, &o.indices));
                    self.overlay_depth = Some((view, grid.clone()));
                    grid
                }
            }
        });
        let eye = self.camera.eye().as_dvec3();
        let middle = crate::transform::median_point(mesh.layers[outer].iter().copied()).unwrap_or_default();
        let facing: Vec<bool> = (0..mesh.vertex_count())
            .map(|v| {
                let tip = mesh.layers[outer][v];
                let hidden = depth.as_ref().is_some_and(|grid| {
                    projection
                        .project(tip.as_vec3())
                        .is_some_and(|(pixel, w)| grid.hides(pixel, w, OVERLAY_DEPTH_TOLERANCE))
                });
                (tip - middle).dot(eye - tip) >= 0.0 && !hidden
            })
            .collect();
        let pick_at = |pointer: Vec2| -> Option<u32> {
            pick(
                &projection,
                mesh.layers[outer].iter().zip(&facing).map(|(p, &f)| if f { p.as_vec3() } else { Vec3::NAN }),
                glam::Vec2::new(pointer.x, pointer.y),
                PICK_RADIUS,
            )
            .map(|i| i as u32)
        };
        self.hovered_vertex = if self.show_overlay && self.drag.is_none() && self.modal.is_none() {
            pointer.and_then(pick_at)
        } else {
            None
        };
        let tips: Vec<Vec3> = mesh.layers[outer]
            .iter()
            .zip(&facing)
            .map(|(p, &f)| if f { p.as_vec3() } else { Vec3::NAN })
            .collect();

        // Input: drag a vertex, orbit, pan, zoom.
        // The vertex is the one under the pointer when the button went down (a drag starts
        // only after the pointer has moved a few pixels from there).
        if response.hovered() && ui.input(|i| i.pointer.primary_pressed()) {
            self.press_vertex = self.hovered_vertex;
        }
        let modelling = self.brush_input(ui, &response, rect, &tips, &painter)
            || self.hair_brush.is_none() && self.modelling_input(ui, &response, rect, &tips, &painter);
        let Some(doc) = self.doc.as_ref() else { return };
        let mesh = doc.asset().mesh();
        let primary = response.drag_started_by(egui::PointerButton::Primary);
        if primary
            && !modelling
            && self.hair_brush.is_none()
            && self.scalp_paint.is_none()
            && self.show_overlay
            && let Some(v) = self.press_vertex.take()
        {
            let plane = self.mirror_plane();
            let mirror = if self.mirror_x { crate::sculpt::mirror_vertex(mesh, v, &plane) } else { None };
            let soft_radius = self.soft_radius * doc.hair_length();
            // A dragged tip of a selection carries the whole selection along.
            let mut sculpt = if self.selection.len() > 1 && self.selection.contains(&v) {
                let mirror_x = self.mirror_x;
                crate::sculpt::TipDrag::selection(
                    mesh,
                    &self.selection,
                    |w| if mirror_x { crate::sculpt::mirror_vertex(mesh, w, &plane) } else { None },
                    soft_radius,
                )
                .across(plane)
            } else {
                self.selection = vec![v];
                crate::sculpt::TipDrag::new(mesh, v, mirror, soft_radius).across(plane)
            };
            if let Some(head) = doc.head_surface() {
                sculpt = sculpt.outside(head);
            }
            self.drag = Some(VertexDrag {
                vertex: v,
                mirror,
                tip_start: mesh.layers[outer][v as usize],
                sculpt,
                pointer_start: ui
                    .input(|i| i.pointer.press_origin())
                    .or(response.interact_pointer_pos())
                    .unwrap_or(rect.center()),
            });
        }
        let mut moves = Vec::new();
        let mut recipe = None;
        if let Some(drag) = &mut self.drag {
            if let Some(pos) = response.interact_pointer_pos() {
                let delta = pos - drag.pointer_start;
                let tip = drag.tip_start;
                let moved =
                    self.camera.drag_point(tip.as_vec3(), glam::Vec2::new(delta.x, delta.y), rect.height());
                let translation = glam::DAffine3::from_translation(moved.as_dvec3() - tip);
                moves = drag.sculpt.moves_with(&translation);
                recipe = Some(drag.sculpt.recipe(translation));
            }
            self.interacting = true;
        } else if modelling {
        } else if response.dragged_by(egui::PointerButton::Primary)
            && (self.scalp_paint.is_none() || ui.input(|i| i.modifiers.alt))
        {
            let d = response.drag_delta();
            self.camera.orbit(glam::Vec2::new(d.x, d.y));
            self.interacting = true;
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            let d = response.drag_delta();
            self.camera.pan(glam::Vec2::new(d.x, d.y), rect.height());
            self.interacting = true;
        }
        // F frames the selection (unless a text field has the keyboard).
        let frame_requested =
            ui.ctx().input(|i| i.key_pressed(egui::Key::F)) && !ui.ctx().text_edit_focused();
        if response.hovered() {
            let scroll = ui.ctx().input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.camera.zoom(scroll / 50.0);
                self.interacting = true;
            }
        }
        let drag_ended = response.drag_stopped() && self.drag.is_some();

        // Overlay: the outer layer's edges and vertices, the hovered or dragged column.
        if self.show_overlay && self.scalp_paint.is_none() {
            let edge = Stroke::new(1.0, Color32::from_rgba_unmultiplied(120, 200, 255, 90));
            let far_edge = Stroke::new(1.0, Color32::from_rgba_unmultiplied(120, 200, 255, 22));
            for face in &mesh.faces {
                let vs = face.vertices();
                for k in 0..vs.len() {
                    let (a, b) = (vs[k] as usize, vs[(k + 1) % vs.len()] as usize);
                    if let (Some(pa), Some(pb)) =
                        (to_screen(mesh.layers[outer][a]), to_screen(mesh.layers[outer][b]))
                    {
                        painter.line_segment([pa, pb], if facing[a] && facing[b] { edge } else { far_edge });
                    }
                }
            }
            let dot = Color32::from_rgba_unmultiplied(160, 220, 255, 160);
            for (p, &f) in mesh.layers[outer].iter().zip(&facing) {
                if let (Some(s), true) = (to_screen(*p), f) {
                    painter.circle_filled(s, 1.5, dot);
                }
            }
            for v in self.highlighted_columns() {
                let column: Vec<Pos2> = mesh.column(v).into_iter().filter_map(to_screen).collect();
                painter.add(egui::Shape::line(
                    column.clone(),
                    Stroke::new(2.0, Color32::from_rgb(255, 200, 80)),
                ));
                if let Some(tip) = column.last() {
                    painter.circle_stroke(*tip, 5.0, Stroke::new(2.0, Color32::from_rgb(255, 200, 80)));
                }
            }
        }
        if self.scalp_paint.is_some() {
            self.paint_scalp(ui, &response, &painter, rect, &projection, depth.as_deref());
        }
        if !moves.is_empty()
            && let Some(doc) = self.doc.as_mut()
            && let Err(e) = doc.sculpt(&moves, recipe, Some(Gesture::Drag))
        {
            self.error = Some(e.to_string());
        }
        if drag_ended {
            self.drag = None;
            if let Some(doc) = self.doc.as_mut() {
                doc.end_gesture();
            }
        }
        if frame_requested {
            self.frame_hair();
        }
    }

    /// Scalp painting in the viewport: drag to add faces under the brush, Shift-drag to remove
    /// them, Alt-drag to orbit; the painted faces are drawn over the head.
    fn paint_scalp(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        painter: &egui::Painter,
        rect: Rect,
        projection: &Projection,
        depth: Option<&DepthGrid>,
    ) {
        let eye = self.camera.eye();
        let radius = self.brush_radius;
        let (alt, shift) = ui.input(|i| (i.modifiers.alt, i.modifiers.shift));
        let Some(paint) = &mut self.scalp_paint else { return };
        if response.dragged_by(egui::PointerButton::Primary)
            && !alt
            && let Some(pos) = response.interact_pointer_pos()
        {
            let centre = glam::Vec2::new(pos.x - rect.min.x, pos.y - rect.min.y);
            paint.dab(projection, depth, eye, centre, radius, !shift);
            self.interacting = true;
        }
        let fill = Color32::from_rgba_unmultiplied(255, 170, 60, 70);
        let mut mesh = egui::Mesh::default();
        for tri in paint.selected_triangles() {
            let corners: Vec<Pos2> = tri
                .iter()
                .filter_map(|p| {
                    projection.project(p.as_vec3()).map(|(px, _)| rect.min + Vec2::new(px.x, px.y))
                })
                .collect();
            if let [a, b, c] = corners[..] {
                let base = mesh.vertices.len() as u32;
                for p in [a, b, c] {
                    mesh.colored_vertex(p, fill);
                }
                mesh.add_triangle(base, base + 1, base + 2);
            }
        }
        painter.add(egui::Shape::mesh(mesh));
        if let Some(pos) = response.hover_pos() {
            let colour =
                if shift { Color32::from_rgb(255, 110, 90) } else { Color32::from_rgb(255, 200, 80) };
            painter.circle_stroke(pos, radius, Stroke::new(1.5, colour));
        }
    }

    /// Starts painting the scalp of the open scalp document (its file's faces, the current
    /// selection to start from).
    pub fn start_scalp_paint(&mut self) {
        let Some(file) = self.doc.as_ref().and_then(Document::scalp_file) else {
            self.error = Some("open a scalp mesh (.glb, .gltf, .obj) to paint its scalp".into());
            return;
        };
        let selector = hairmesh::ScalpSelector::parse(&self.convert.scalp).unwrap_or_default();
        match hairmesh::import::load_faces(&file, self.convert.references) {
            Ok(mesh) => {
                let paint = crate::scalp_paint::ScalpPaint::new(mesh, &selector, self.head_frame.as_ref());
                self.scalp_paint = Some(paint);
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// Ends painting: the painted faces become the scalp selection and the head is converted
    /// again with it.
    pub fn apply_scalp_paint(&mut self) {
        let Some(paint) = self.scalp_paint.take() else { return };
        if paint.count() == 0 {
            self.error = Some("no face is painted: paint the scalp first".into());
            self.scalp_paint = Some(paint);
            return;
        }
        self.convert.scalp = paint.selector().to_string();
        if let Some(file) = self.doc.as_ref().and_then(Document::scalp_file) {
            self.start_conversion(file);
        }
    }

    fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some((purpose, dialog)) = &mut self.dialog {
            let purpose = *purpose;
            dialog.show(ctx);
            if dialog.selected() {
                let path = dialog.path().map(Path::to_owned);
                self.dialog = None;
                if let Some(path) = path {
                    match purpose {
                        DialogPurpose::Open => self.open(&path),
                        DialogPurpose::SaveAs => self.save_as(&path),
                        DialogPurpose::ExportPng => self.export_png(&with_extension(&path, "png")),
                        DialogPurpose::ExportScene => self.export_scene(&with_extension(&path, "json")),
                        DialogPurpose::SaveSession => self.save_session(&with_extension(&path, "json")),
                    }
                }
            } else if !dialog.visible() {
                self.dialog = None;
            }
        }
        if let Some(message) = self.error.clone() {
            let modal = egui::Modal::new(egui::Id::unique("error")).show(ctx, |ui| {
                ui.heading("Error");
                ui.label(message);
                ui.button("OK").clicked()
            });
            if modal.inner || modal.should_close() {
                self.error = None;
            }
        }
        if let Some(action) = self.pending.clone() {
            let title = self.doc.as_ref().map(Document::title).unwrap_or_default();
            let modal = egui::Modal::new(egui::Id::unique("unsaved")).show(ctx, |ui| {
                ui.heading("Unsaved changes");
                ui.label(format!("{title} has changes that are not saved."));
                ui.horizontal(|ui| {
                    if ui.button("Save").clicked() {
                        return Some(true);
                    }
                    if ui.button("Discard").clicked() {
                        return Some(false);
                    }
                    if ui.button("Cancel").clicked() {
                        self.pending = None;
                    }
                    None
                })
                .inner
            });
            if modal.should_close() {
                self.pending = None;
            }
            if let Some(save) = modal.inner {
                self.pending = None;
                if save {
                    self.save();
                }
                let saved = self.doc.as_ref().is_none_or(|d| !d.is_dirty());
                if !save || saved {
                    match action {
                        PendingAction::Open(path) => {
                            self.doc = None;
                            self.open_now(&path);
                        }
                        PendingAction::Quit => self.quit = true,
                    }
                }
            }
        }
    }

    /// `--screenshot`: once the final preview has been shown for a frame, capture the window
    /// from outside ([`crate::xwd`]) in a thread and report through [`ScreenshotRequest::result`].
    fn screenshot_step(&mut self, ctx: &egui::Context) {
        let ready = self.preview_is_final() && self.conversion.is_none();
        let Some(shot) = &mut self.screenshot else { return };
        if shot.asked || !ready {
            shot.ready_frames = 0;
            return;
        }
        // This frame draws the final preview; capture after it has been presented.
        shot.ready_frames += 1;
        if shot.ready_frames < 3 {
            ctx.request_repaint_after(std::time::Duration::from_millis(300));
            return;
        }
        shot.asked = true;
        let (out, result, title, waker) =
            (shot.out.clone(), shot.result.clone(), shot.title.clone(), ctx.clone());
        std::thread::spawn(move || {
            let r = crate::xwd::screenshot(&title, &out);
            *result.lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
            waker.request_repaint();
        });
    }
}

impl ScreenshotRequest {
    /// A screenshot of the window titled `title`, to `out`.
    pub fn new(out: PathBuf, title: &str) -> Self {
        Self { out, title: title.to_owned(), asked: false, ready_frames: 0, result: Arc::default() }
    }
}

/// NaN and negative values from typed entries are refused: the style keeps its last valid
/// value for them.
fn sanitized(mut s: Style) -> Style {
    let d = Style::default();
    for (v, fallback) in [
        (&mut s.width, d.width),
        (&mut s.tip_width, d.tip_width),
        (&mut s.root_fade, d.root_fade),
        (&mut s.length_variation, d.length_variation),
        (&mut s.curl.radius, 0.0),
        (&mut s.curl.frequency, d.curl.frequency),
        (&mut s.wave.amplitude, 0.0),
        (&mut s.wave.frequency, d.wave.frequency),
        (&mut s.wave.coherence, 0.0),
        (&mut s.frizz.amplitude, 0.0),
        (&mut s.frizz.frequency, d.frizz.frequency),
        (&mut s.frizz.exponent, d.frizz.exponent),
        (&mut s.clump.strength, 0.0),
        (&mut s.clump.exponent, d.clump.exponent),
        (&mut s.stray.fraction, 0.0),
        (&mut s.stray.amplitude, 0.0),
    ] {
        if !v.is_finite() || *v < 0.0 {
            *v = fallback;
        }
    }
    s.tip_width = s.tip_width.min(1.0);
    s.root_fade = s.root_fade.min(1.0);
    s.length_variation = s.length_variation.min(1.0);
    s.clump.strength = s.clump.strength.min(1.0);
    s.wave.coherence = s.wave.coherence.min(1.0);
    s.stray.fraction = s.stray.fraction.min(1.0);
    if !s.twist.is_finite() {
        s.twist = 0.0;
    }
    s
}

/// The axis-aligned bounds of `points` (inverted, infinite ones for none).
fn point_bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
}

fn with_extension(path: &Path, ext: &str) -> PathBuf {
    if path.extension().is_some() { path.to_owned() } else { path.with_extension(ext) }
}

fn vec3_edit(ui: &mut egui::Ui, v: &mut DVec3, label: egui::Id) {
    ui.horizontal(|ui| {
        for (c, axis) in [(&mut v.x, "x "), (&mut v.y, "y "), (&mut v.z, "z ")] {
            ui.add(egui::DragValue::new(c).speed(0.01).prefix(axis)).labelled_by(label);
        }
    });
}

/// Linear RGB → an egui colour (sRGB).
fn srgb(c: [f32; 3]) -> Color32 {
    let e = |v: f32| {
        let v = v.clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
        (s * 255.0).round() as u8
    };
    Color32::from_rgb(e(c[0]), e(c[1]), e(c[2]))
}

fn occluder_bounds(o: &render::occluder::OccluderGeometry) -> Option<(Vec3, Vec3)> {
    let (lo, hi) = o.bounds;
    (lo.is_finite() && hi.is_finite() && hi.cmpge(lo).all()).then_some((lo, hi))
}

/// A style slider's label → its field in [`Style::fields`] ("Curl radius" → "curl.radius").
fn style_field(label: &str) -> String {
    let lower = label.to_lowercase();
    match lower.split_once(' ') {
        Some((group @ ("curl" | "wave" | "frizz" | "clump" | "stray"), rest)) => {
            format!("{group}.{}", rest.replace(' ', "_"))
        }
        _ => lower.replace(' ', "_"),
    }
}

#[cfg(test)]
mod style_field_tests {
    /// Every style slider's hover text names a real field and its range.
    #[test]
    fn slider_labels_name_style_fields() {
        for label in [
            "Width",
            "Tip width",
            "Curl radius",
            "Wave coherence",
            "Frizz exponent",
            "Stray amplitude",
            "Twist",
        ] {
            let field = super::style_field(label);
            assert!(hairmesh::style::Style::range(&field).is_some(), "{label} → {field}");
        }
    }
}
