//! The live preview: hairkit's own renderer on its own Vulkan device, in a worker thread.
//!
//! Lavapipe has one queue per device, so sharing the UI's device would stall the window behind
//! every hair frame; the worker owns a [`gen_gpu::Context`] and a
//! [`render::frame::SceneRenderer`] and returns read-back RGBA frames that the UI shows as a
//! texture. Requests replace each other: the worker always renders the latest one it has
//! when it finishes a frame (**latest request wins**), so a fast slider never queues work.
//!
//! The renderer is built again only when the document's asset is replaced whole, the scene
//! settings change (effects, lights, colour, head mesh) or the viewport outgrows the
//! renderer's output; edits of the hair mesh and the style are uploaded incrementally
//! ([`render::frame::SceneRenderer::update_hair`]) from the document's change list.
//!
//! A **draft** request (sent while a slider or a drag is active) renders at half the
//! viewport's resolution with [`DRAFT_STRAND_ALPHA`] times the strand LOD (fewer, wider
//! strands of the same look) over the last shadow maps (stale while the hair changes); the UI
//! asks for the full frame, which makes the maps again, when the interaction ends.

use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use gen_gpu::{Context, ContextDesc, GenerationPath, PathChoice, RgbaImage, Validation};
use glam::Mat4;
use hairmesh::asset::{AssetChange, HairAsset};
use render::frame::SceneRenderer;
use render::instance::{CharacterHair, CharacterInstance, OccluderInstance, SceneInstance};
use render::occluder::OccluderGeometry;
use render::scene::{CameraDesc, Effects, Light, LoadedScene, LodDesc, Output, Scene};

use crate::camera::OrbitCamera;
use crate::document::HairColor;

/// Strand-LOD factor of draft frames: bundles keep about 1/α of their strands where LOD can
/// drop them, widened to keep the hair's coverage.
pub const DRAFT_STRAND_ALPHA: f64 = 8.0;

/// The scene around the hair: a change of any of these builds the renderer again.
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewScene {
    pub effects: Effects,
    pub lights: Vec<Light>,
    pub color: HairColor,
    /// Linear RGB.
    pub background: [f32; 3],
    pub occluder_color: [f32; 3],
}

impl Default for PreviewScene {
    fn default() -> Self {
        Self {
            // Self-shadowing on: with the maps made by the compute rasterizer and drafts over
            // the last maps, the preview keeps its latency targets with it (README).
            effects: Effects { shadows: true, ..Effects::default() },
            lights: vec![
                Light::Directional {
                    direction: [0.5, 0.8, 0.6],
                    color: [1.6, 1.55, 1.5],
                    cast_shadows: true,
                },
                Light::Directional {
                    direction: [-0.6, 0.2, -0.5],
                    color: [0.5, 0.55, 0.7],
                    cast_shadows: false,
                },
            ],
            color: HairColor::default(),
            background: [0.035, 0.038, 0.045],
            occluder_color: [0.42, 0.28, 0.22],
        }
    }
}

impl PreviewScene {
    /// These settings as a scene seen through `camera` into a `width`×`height` output, without
    /// characters: what the preview renders, and what the editor's scene export writes.
    pub fn scene(&self, camera: &OrbitCamera, width: u32, height: u32) -> Scene {
        let c = camera.camera();
        Scene {
            output: Output { width, height, background: self.background },
            camera: CameraDesc {
                eye: c.eye.to_array(),
                target: c.target.to_array(),
                fov_y_degrees: camera.fov_y_degrees,
            },
            camera_path: Vec::new(),
            lights: self.lights.clone(),
            characters: Vec::new(),
            effects: self.effects,
            lod: LodDesc::default(),
            animation: None,
        }
    }
}

/// One frame to render.
#[derive(Clone, Debug)]
pub struct PreviewRequest {
    /// Increasing; the frame that answers carries it.
    pub id: u64,
    /// [`crate::document::Document::generation`]: a new one uploads the asset whole.
    pub generation: u64,
    pub asset: Arc<HairAsset>,
    /// The document's changes since `generation` began (the worker uploads the ones it has
    /// not seen).
    pub changes: Vec<AssetChange>,
    pub occluder: Option<Arc<OccluderGeometry>>,
    pub scene: PreviewScene,
    pub camera: OrbitCamera,
    /// The viewport in pixels (draft frames are half of it).
    pub width: u32,
    pub height: u32,
    pub draft: bool,
}

impl PreviewRequest {
    /// A request for `doc` as it is now (the worker sets the id).
    pub fn for_document(
        doc: &crate::document::Document,
        scene: PreviewScene,
        camera: OrbitCamera,
        [width, height]: [u32; 2],
        draft: bool,
    ) -> Self {
        Self {
            id: 0,
            generation: doc.generation,
            asset: doc.asset().clone(),
            changes: doc.changes().to_vec(),
            occluder: doc.occluder.clone(),
            scene,
            camera,
            width,
            height,
            draft,
        }
    }
}

/// A rendered preview frame.
#[derive(Debug)]
pub struct PreviewFrame {
    pub id: u64,
    pub draft: bool,
    pub image: RgbaImage,
    /// Wall time from taking the request to the read-back image (uploads and a rebuild, if
    /// any, included).
    pub ms: f64,
    pub strands: u64,
    pub vertices: u64,
    /// The renderer was built for this frame (pays for pipeline creation).
    pub rebuilt: bool,
    /// The rasterizer that drew the hair (`compute` or `triangles`).
    pub raster: String,
}

/// What the worker reports.
#[derive(Debug)]
pub enum PreviewEvent {
    /// The device is up: its name, the generation path and the rasterizer.
    Ready {
        device: String,
        path: String,
    },
    Frame(PreviewFrame),
    /// A request failed (the message names what); the worker goes on with the next one.
    Failed {
        id: u64,
        message: String,
    },
    /// No device: the preview is unavailable for this session.
    Unavailable {
        message: String,
    },
}

#[derive(Default)]
struct Slot {
    pending: Option<PreviewRequest>,
    quit: bool,
}

/// The worker thread and its mailbox.
pub struct PreviewWorker {
    slot: Arc<(Mutex<Slot>, Condvar)>,
    events: Receiver<PreviewEvent>,
    thread: Option<JoinHandle<()>>,
    next_id: u64,
}

impl std::fmt::Debug for PreviewWorker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PreviewWorker").field("next_id", &self.next_id).finish()
    }
}

impl PreviewWorker {
    /// Starts the worker; `wake` is called after every event (e.g. to repaint the UI).
    pub fn start(wake: impl Fn() + Send + 'static) -> Self {
        let slot: Arc<(Mutex<Slot>, Condvar)> = Arc::default();
        let (send, events) = channel();
        let thread_slot = slot.clone();
        let thread = std::thread::Builder::new()
            .name("hair preview".into())
            .spawn(move || run(&thread_slot, &send, &wake))
            .ok();
        Self { slot, events, thread, next_id: 1 }
    }

    /// Replaces any request not started yet with `request` (its id is set here and returned).
    pub fn request(&mut self, mut request: PreviewRequest) -> u64 {
        request.id = self.next_id;
        self.next_id += 1;
        let (lock, wake) = &*self.slot;
        lock.lock().unwrap_or_else(|e| e.into_inner()).pending = Some(request);
        wake.notify_one();
        self.next_id - 1
    }

    /// Events since the last call.
    pub fn poll(&self) -> Vec<PreviewEvent> {
        self.events.try_iter().collect()
    }

    /// Waits up to `timeout` for the next event (for tests and `--screenshot`).
    pub fn wait(&self, timeout: std::time::Duration) -> Option<PreviewEvent> {
        self.events.recv_timeout(timeout).ok()
    }
}

impl Drop for PreviewWorker {
    fn drop(&mut self) {
        let (lock, wake) = &*self.slot;
        lock.lock().unwrap_or_else(|e| e.into_inner()).quit = true;
        wake.notify_one();
        if let Some(t) = self.thread.take() {
            // A frame in flight finishes first (at most one preview frame's time).
            let _ = t.join();
        }
    }
}

/// The renderer and what it was built from.
struct Built {
    generation: u64,
    scene: PreviewScene,
    occluder: Option<Arc<OccluderGeometry>>,
    output: (u32, u32),
    revision: u64,
    renderer: SceneRenderer,
}

const HAIR_KEY: &str = "hair";

fn run(slot: &(Mutex<Slot>, Condvar), events: &Sender<PreviewEvent>, wake: &dyn Fn()) {
    let send = |e: PreviewEvent| {
        let _ = events.send(e);
        wake();
    };
    let ctx = match Context::new(&ContextDesc { validation: Validation::FromEnv, device: None }) {
        Ok(c) => c,
        Err(e) => {
            send(PreviewEvent::Unavailable { message: format!("no Vulkan device for the preview: {e}") });
            return;
        }
    };
    let path = match PathChoice::from_env().and_then(|c| c.resolve_with_env(ctx.capabilities())) {
        Ok(p) => p,
        Err(e) => {
            send(PreviewEvent::Unavailable { message: e.to_string() });
            return;
        }
    };
    send(PreviewEvent::Ready { device: ctx.capabilities().device_name.clone(), path: path.to_string() });
    let mut built: Option<Built> = None;
    loop {
        let request = {
            let (lock, cond) = slot;
            let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                if s.quit {
                    return;
                }
                if let Some(r) = s.pending.take() {
                    break r;
                }
                s = cond.wait(s).unwrap_or_else(|e| e.into_inner());
            }
        };
        let id = request.id;
        let result = render_request(&ctx, path, &mut built, &request);
        // Validation messages are errors of this frame (the tests run with the layer on).
        let validation: Vec<String> = ctx.take_validation_errors().into_iter().map(|m| m.text).collect();
        match result {
            Ok(frame) if validation.is_empty() => send(PreviewEvent::Frame(frame)),
            Ok(_) => {
                send(PreviewEvent::Failed { id, message: format!("validation: {}", validation.join("; ")) });
            }
            Err(message) => {
                // A failed renderer may hold a half-applied update: build it again next time.
                built = None;
                send(PreviewEvent::Failed { id, message });
            }
        }
    }
}

fn same_occluder(a: &Option<Arc<OccluderGeometry>>, b: &Option<Arc<OccluderGeometry>>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => Arc::ptr_eq(a, b),
        (None, None) => true,
        _ => false,
    }
}

/// The renderer's output for a viewport: rounded up to multiples of 256 pixels, so resizing
/// the window rebuilds rarely.
fn output_for(width: u32, height: u32) -> (u32, u32) {
    let up = |v: u32| v.max(1).div_ceil(256) * 256;
    (up(width), up(height))
}

fn render_request(
    ctx: &Context,
    path: GenerationPath,
    built: &mut Option<Built>,
    r: &PreviewRequest,
) -> Result<PreviewFrame, String> {
    let start = Instant::now();
    let output = output_for(r.width, r.height);
    let reusable = built.as_ref().is_some_and(|b| {
        b.generation == r.generation
            && b.scene == r.scene
            && same_occluder(&b.occluder, &r.occluder)
            && output.0 <= b.output.0
            && output.1 <= b.output.1
    });
    let mut rebuilt = false;
    if reusable && let Some(b) = built.as_mut() {
        if b.revision != r.asset.revision() && update(ctx, b, r).is_err() {
            // Changes the worker missed (the document dropped its list): upload again.
            *built = None;
        }
    } else {
        *built = None;
    }
    let b = match built {
        Some(b) => b,
        None => {
            rebuilt = true;
            built.insert(build(ctx, path, r, output)?)
        }
    };
    let camera = r.camera.camera();
    let mut view = b.renderer.frame_view(camera.eye, camera.target);
    view.camera.fov_y = camera.fov_y;
    let (w, h) = if r.draft { (r.width.div_ceil(2), r.height.div_ceil(2)) } else { (r.width, r.height) };
    view.width = w.max(1);
    view.height = h.max(1);
    if r.draft {
        view.lod.strand_alpha *= DRAFT_STRAND_ALPHA;
    }
    // Drafts show the last shadow maps (made again by the refined frame): with self-shadowing
    // the maps would cost more than the rest of a draft.
    b.renderer.reuse_stale_shadow_maps(r.draft);
    let frame = b.renderer.render_view(ctx, view).map_err(|e| e.to_string())?;
    Ok(PreviewFrame {
        id: r.id,
        draft: r.draft,
        image: frame.image,
        ms: start.elapsed().as_secs_f64() * 1e3,
        strands: frame.stats.strands,
        vertices: frame.stats.vertices,
        rebuilt,
        raster: b.renderer.raster().to_string(),
    })
}

/// Uploads the changes between the renderer's revision and the request's.
fn update(ctx: &Context, b: &mut Built, r: &PreviewRequest) -> Result<(), String> {
    let first =
        r.changes.iter().position(|c| c.since == b.revision).ok_or("the change list does not reach back")?;
    let mut merged = r.changes[first].clone();
    for c in &r.changes[first + 1..] {
        merged = merged.then(c).map_err(|e| e.to_string())?;
    }
    if merged.revision != r.asset.revision() {
        return Err("the change list does not reach the asset's revision".into());
    }
    b.renderer.update_hair(ctx, HAIR_KEY, &r.asset, &merged).map_err(|e| e.to_string())?;
    b.revision = r.asset.revision();
    Ok(())
}

fn build(
    ctx: &Context,
    path: GenerationPath,
    r: &PreviewRequest,
    output: (u32, u32),
) -> Result<Built, String> {
    let settings =
        LoadedScene { path: "editor preview".into(), scene: r.scene.scene(&r.camera, output.0, output.1) };
    settings.validate_settings().map_err(|e| e.to_string())?;
    let mut instance = SceneInstance::new(settings);
    instance.characters.push(CharacterInstance {
        key: HAIR_KEY.into(),
        hair: CharacterHair::Generated(r.asset.clone()),
        transform: Mat4::IDENTITY,
        color: r.scene.color.rgb,
        color_variation: r.scene.color.variation,
        occluder: r.occluder.as_ref().map(|geometry| OccluderInstance {
            key: "head".into(),
            geometry: geometry.clone(),
            transform: Mat4::IDENTITY,
            color: r.scene.occluder_color,
        }),
    });
    let renderer = SceneRenderer::from_instance(ctx, &instance, path).map_err(|e| e.to_string())?;
    Ok(Built {
        generation: r.generation,
        scene: r.scene.clone(),
        occluder: r.occluder.clone(),
        output,
        revision: r.asset.revision(),
        renderer,
    })
}
