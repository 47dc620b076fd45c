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
mod chrome;
mod files;
mod inner_edit;
mod modelling;
mod panels;
mod preview_link;
mod screenshot;
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
    /// The layer the *Layer* row inserts before or removes (1 = the first above the roots).
    pub layer_pick: u32,
    /// The layer G, R and S take hold of (0: the tips): the layers above it follow the
    /// transform, the ones below bend under it.
    pub held_layer: u32,
    /// Painting the scalp: the head's faces and the selection (while the mode is on).
    pub scalp_paint: Option<crate::scalp_paint::ScalpPaint>,
    /// The scalp brush's radius in viewport pixels.
    pub brush_radius: f32,
    /// Where the suggested hairline is (skull radii; [`hairmesh::head_frame::HAIRLINE_OFFSET`]).
    pub hairline_offset: f64,
    pub hovered_vertex: Option<u32>,
    /// *Inner vertices*: every hair-mesh vertex is drawn and dragged by hand
    /// ([`inner_edit`]), instead of the tips.
    pub show_inner: bool,
    /// The vertex (layer, vertex) under the pointer in that mode.
    pub hovered_inner: Option<(u32, u32)>,
    inner_drag: Option<inner_edit::InnerDrag>,
    /// The vertex under the pointer when the primary button went down in that mode.
    press_inner: Option<(u32, u32)>,
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
            layer_pick: 1,
            held_layer: 0,
            scalp_paint: None,
            brush_radius: 30.0,
            hairline_offset: hairmesh::head_frame::HAIRLINE_OFFSET,
            hovered_vertex: None,
            show_inner: false,
            hovered_inner: None,
            inner_drag: None,
            press_inner: None,
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
