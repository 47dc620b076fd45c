//! The document's files: opening heads, assets and sessions (conversions and replays run in
//! a thread), saving, exporting pictures, scenes and sessions.

use std::path::{Path, PathBuf};
use std::sync::mpsc::channel;
use std::time::Instant;

use super::*;

impl EditorApp {
    /// Opens a scalp mesh (converted in the background with [`Self::convert`]) or an asset,
    /// asking first when the open document has unsaved changes.
    pub fn open(&mut self, path: &Path) {
        if self.doc.as_ref().is_some_and(Document::is_dirty) {
            self.pending = Some(PendingAction::Open(path.to_owned()));
            return;
        }
        self.open_now(path);
    }

    pub(super) fn open_now(&mut self, path: &Path) {
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
    pub(super) fn settings_for_head(&mut self, head: &Path) {
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

    pub(super) fn finish_conversion(&mut self, result: Result<Document, EditorError>) {
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

    pub(super) fn set_document(&mut self, doc: Document) {
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

    pub(super) fn remember(&mut self, path: &Path) {
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
    pub(super) fn inputs(&self) -> Vec<PathBuf> {
        let Some(doc) = &self.doc else { return Vec::new() };
        doc.scalp_file().into_iter().chain(doc.save_path.clone()).collect()
    }

    /// May an export of `kind` replace `path`? Only a new path or an earlier export of its kind
    /// (the editor has no --force: choose another name, or remove the file first).
    pub(super) fn check_export(&self, path: &Path, kind: hairmesh::output::FileKind) -> Result<(), String> {
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
}
