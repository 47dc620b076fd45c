//! The editor's UI: menu bar, side panels, the viewport with the live preview and the
//! hair-mesh overlay, the status bar, dialogs and prompts.
//!
//! [`EditorApp::ui`] draws one frame from the app's state and applies what the user did; it
//! never blocks: conversions and session replays run in a thread ([`ConversionJob`]), preview
//! frames come from the [`PreviewWorker`], file dialogs are egui windows (`egui_file`). Tests
//! drive it through `egui_kittest`; `src/main.rs` through `eframe`.
//!
//! The state lives here; each part of the UI is a module of its own: `files` (open, convert,
//! save, export, sessions), `panels` (conversion, head frame, sculpt, style, scene),
//! `viewport` (camera, overlay, tip dragging, scalp painting), `modelling` (selection and
//! G/R/S) and `brushing` (hair brushes). Every edit of the hair mesh goes through
//! [`crate::sculpt`]: the columns bend under their tips, the inner vertices follow
//! ([`hairmesh::inner`]), mirror and soft selection apply and the head pushes the hair out.

use std::path::{Path, PathBuf};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use egui::{Color32, Pos2, Rect};
use glam::{DVec3, Vec3};
use hairmesh::convert::{ConvertSettings, LayerShape};
use hairmesh::head_frame::HeadFrame;
use hairmesh::style::Style;
use render::scene::Transparency;

use crate::EditorError;

mod brushing;
mod files;
mod modelling;
mod panels;
mod viewport;
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

    /// Applies a preset: the style always; with a scalp document, also its layers (converted
    /// again in the background).
    pub fn apply_preset(&mut self, preset: &Preset) {
        let Some(doc) = &mut self.doc else { return };
        // The head's frame (estimated, perhaps corrected); a scalp without a head is guessed
        // to be a cap facing +Z.
        let frame = self.head_frame.unwrap_or_else(|| {
            let (lo, hi) = crate::sculpt::point_bounds(&doc.asset().mesh().layers[0]);
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
