//! Sessions: how a hairstyle was made, as a list of commands that replays to the same asset.
//!
//! A session starts from a head converted with given settings (or from an asset folder), then
//! lists the document's edits in order, each as the command that made it: a style, a colour,
//! a sculpt (the columns, soft selection and transform of a drag or a G/R/S:
//! [`crate::sculpt::Sculpt`]) or, for edits no tool describes, the vertices' new positions.
//! `File ▸ Save session` writes one; `hair-editor --replay SESSION.json -o ASSET` replays it
//! without a window and saves the asset, which equals the one the editor saves.
//!
//! Head paths are relative to the session's folder, or `data:PATH` for a file of the
//! third-party data set (found by [`data_set::locate`] wherever it is on this machine).

use std::path::{Path, PathBuf};

use hairmesh::asset::VertexMove;
use hairmesh::convert::ConvertSettings;
use hairmesh::head_frame::HeadFrame;
use hairmesh::style::Style;
use serde::{Deserialize, Serialize};

use crate::EditorError;
use crate::camera::OrbitCamera;
use crate::document::{Document, Edit, HairColor, Source};
use crate::sculpt::Sculpt;

/// The `format` field of a session file.
pub const FORMAT: &str = "hairkit.editor-session";
/// The version this build writes and reads.
pub const VERSION: u32 = 1;
/// What a session file is, for the output checks (an earlier session may be replaced).
pub const SESSION_FILE: hairmesh::output::FileKind =
    hairmesh::output::FileKind::Json { what: "an editor session", keys: &["format", "start", "commands"] };
/// Most bytes a session file may have.
pub const MAX_SESSION_BYTES: u64 = 256 << 20;

/// A session file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Session {
    pub format: String,
    pub version: u32,
    pub start: Start,
    /// The view when it was saved (what `--screenshot` renders).
    pub camera: OrbitCamera,
    pub commands: Vec<Command>,
}

/// Where a session starts.
#[expect(clippy::large_enum_variant, reason = "one per session")]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Start {
    /// A head converted with these settings, gravity and presets in this frame.
    Convert { head: String, settings: ConvertSettings, frame: Option<HeadFrame> },
    /// An asset folder as saved.
    Asset { path: String },
}

/// One edit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Command {
    Style(Style),
    Color(HairColor),
    Sculpt(Sculpt),
    /// Vertices moved to these positions.
    Vertices(Vec<VertexMove>),
    /// Bundles ended at these tip layers (`[bundle, layer]` pairs).
    TipLayers(Vec<(u32, u32)>),
    /// A layer inserted, removed or extruded.
    Layers(crate::document::LayerOp),
}

impl Session {
    /// The session that makes `doc` (viewed through `camera`, with the head's `frame`), to be
    /// written at `path` (head paths are written relative to its folder, or to the data set).
    pub fn record(doc: &Document, frame: Option<HeadFrame>, camera: OrbitCamera, path: &Path) -> Self {
        let base = path.parent().unwrap_or(Path::new("."));
        let start = match &doc.source {
            Source::Scalp { file, settings } => {
                Start::Convert { head: portable_path(file, base), settings: settings.clone(), frame }
            }
            Source::Asset { path } => Start::Asset { path: portable_path(path, base) },
        };
        let commands = doc
            .history()
            .map(|edit| match edit {
                Edit::Style { after, .. } => Command::Style(*after),
                Edit::Color { after, .. } => Command::Color(*after),
                Edit::Vertices { made_by: Some(s), .. } => Command::Sculpt(s.clone()),
                Edit::Vertices { after, made_by: None, .. } => Command::Vertices(after.clone()),
                Edit::TipLayers { after, .. } => Command::TipLayers(after.clone()),
                Edit::Layers { op, .. } => Command::Layers(op.clone()),
            })
            .collect();
        Self { format: FORMAT.into(), version: VERSION, start, camera, commands }
    }

    /// Whether `path` names a session file (by its contents: a JSON object with this `format`).
    pub fn is_session(path: &Path) -> bool {
        let Ok(bytes) = hairmesh::input::read_regular(path, MAX_SESSION_BYTES) else { return false };
        serde_json::from_slice::<serde_json::Value>(&bytes)
            .is_ok_and(|v| v.get("format").and_then(serde_json::Value::as_str) == Some(FORMAT))
    }

    /// Reads a session file; errors name it.
    pub fn read(path: &Path) -> Result<Self, EditorError> {
        let bad = |message: String| EditorError::Io { path: path.to_owned(), message };
        let bytes = hairmesh::input::read_regular(path, MAX_SESSION_BYTES).map_err(|e| bad(e.to_string()))?;
        let session: Self =
            serde_json::from_slice(&bytes).map_err(|e| bad(format!("not a session file: {e}")))?;
        if session.format != FORMAT || session.version != VERSION {
            return Err(bad(format!(
                "format `{}` version {} (this build reads `{FORMAT}` version {VERSION})",
                session.format, session.version
            )));
        }
        Ok(session)
    }

    /// Writes the session atomically.
    pub fn write(&self, path: &Path) -> Result<(), EditorError> {
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| EditorError::Io { path: path.to_owned(), message: e.to_string() })?;
        hairmesh::atomic::write_file_atomic(path, |w| w.write_all(text.as_bytes()))
            .map_err(|e| EditorError::Io { path: path.to_owned(), message: e.to_string() })
    }

    /// Replays the session read from `path`: converts (or opens) where it starts and makes
    /// every edit again. `progress` hears each step.
    pub fn replay(&self, path: &Path, progress: &mut dyn FnMut(&str)) -> Result<Document, EditorError> {
        let base = path.parent().unwrap_or(Path::new("."));
        let mut doc = match &self.start {
            Start::Convert { head, settings, frame } => {
                let head = resolve(head, base, path)?;
                Document::convert_scalp(&head, settings, *frame, progress)?
            }
            Start::Asset { path: asset } => Document::open_asset(&resolve(asset, base, path)?)?,
        };
        for (i, command) in self.commands.iter().enumerate() {
            progress(&format!("command {} of {}", i + 1, self.commands.len()));
            match command {
                Command::Style(style) => doc.set_style(*style, None),
                Command::Color(color) => doc.set_color(*color, None),
                Command::Sculpt(sculpt) => {
                    let moves = sculpt.moves(doc.asset().mesh(), doc.head_surface());
                    doc.sculpt(&moves, Some(sculpt.clone()), None)?;
                }
                Command::Vertices(moves) => doc.move_vertices(moves, None)?,
                Command::TipLayers(tips) => doc.set_tip_layers(tips)?,
                Command::Layers(op) => doc.edit_layers(op)?,
            }
        }
        Ok(doc)
    }
}

/// `doc` rendered as the editor's preview shows it (full quality, the default scene with the
/// document's colour) through `camera` at `size` pixels, on a preview worker of its own.
pub fn snapshot(
    doc: &Document,
    camera: OrbitCamera,
    size: [u32; 2],
    timeout: std::time::Duration,
) -> Result<gen_gpu::RgbaImage, EditorError> {
    use crate::preview::{PreviewEvent, PreviewRequest, PreviewScene, PreviewWorker};
    let failed = |message: String| EditorError::Preview { message };
    let mut worker = PreviewWorker::start(|| {});
    let scene = PreviewScene { color: doc.color(), ..PreviewScene::default() };
    let id = worker.request(PreviewRequest::for_document(doc, scene, camera, size, false));
    let deadline = std::time::Instant::now() + timeout;
    loop {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        match worker.wait(left) {
            Some(PreviewEvent::Frame(frame)) if frame.id == id => return Ok(frame.image),
            Some(PreviewEvent::Failed { message, .. } | PreviewEvent::Unavailable { message }) => {
                return Err(failed(message));
            }
            Some(_) => {}
            None => return Err(failed(format!("no frame after {} s", timeout.as_secs()))),
        }
    }
}

/// `file` as a session names it: `data:PATH` inside the data set, else relative to `base` when
/// it is inside it, else as it is.
fn portable_path(file: &Path, base: &Path) -> String {
    if let Some(name) = data_set::portable_name(file) {
        return name;
    }
    let canonical = |p: &Path| p.canonicalize().unwrap_or_else(|_| p.to_owned());
    let file = canonical(file);
    match file.strip_prefix(canonical(base)) {
        Ok(rel) => rel.display().to_string(),
        Err(_) => file.display().to_string(),
    }
}

/// A head or asset path of the session at `session` (relative paths against its folder
/// `base`), spelled as [`spelled_from_here`] spells it.
fn resolve(name: &str, base: &Path, session: &Path) -> Result<PathBuf, EditorError> {
    let path = if name.starts_with(data_set::NAME_PREFIX) {
        data_set::resolve_name(name)
            .map_err(|e| EditorError::Io { path: session.to_owned(), message: e.to_string() })?
    } else {
        base.join(name)
    };
    Ok(spelled_from_here(&path))
}

/// Most `..` steps a path spelled from the current folder may take.
const MAX_UP_STEPS: usize = 3;

/// One spelling per file, whoever names it (the editor opening it, a replay resolving it):
/// relative to the current folder when it is near (at most [`MAX_UP_STEPS`] `..`), else
/// absolute; symbolic links and `.`/`..` resolved. The asset records its head by this path,
/// so a session replayed from the same folder saves the same bytes.
pub fn spelled_from_here(path: &Path) -> PathBuf {
    let Ok(file) = path.canonicalize() else { return path.to_owned() };
    let Some(here) = std::env::current_dir().ok().and_then(|d| d.canonicalize().ok()) else { return file };
    let common = file.components().zip(here.components()).take_while(|(a, b)| a == b).count();
    let up = here.components().count() - common;
    if common <= 1 || up > MAX_UP_STEPS {
        return file;
    }
    let mut relative: PathBuf = std::iter::repeat_n("..", up).collect();
    relative.extend(file.components().skip(common));
    relative
}
