//! Rendering a scene: hair uploaded once per asset and style, then per frame a [`FrameGraph`]
//! planned from the scene's effects ([`SceneRenderer::plan`]) and run pass by pass
//! ([`crate::passes`]): shadow maps (cached while the casters do not change), LOD and
//! generation per character, occluders, the hair raster in the scene's transparency mode, the
//! copy out. The graph's declarations give the barriers, the timing scopes and `--print-graph`.
//!
//! [`SceneRenderer`] is defined here; its methods live by job: `setup` (pipelines and uploads),
//! `options` (choices after set-up), `edits` (moves and hair edits between frames), `plan` (a
//! frame's graph for a view), `volumes` (hair volumes and raymarching), `lights` (lights and
//! shading constants), `raster_state` (what the compute rasterizer reads of the renderer) and
//! `run` (executing a planned frame); `ids` holds the frame's resource names and per-submission
//! state the passes read.

mod edits;
mod ids;
mod lights;
mod options;
mod plan;
mod raster_state;
mod run;
mod setup;
mod volumes;

use std::collections::HashMap;
use std::sync::Mutex;

use gen_gpu::{
    Buffer, BufferDesc, Context, FragmentStage, FrameBuffers, FrameInputs, FrameTimings, GenerationPath,
    GenerationStats, Generator, GeneratorOptions, GpuHair, Image, MemoryLocation, Pipeline, TexturePrecision,
    vk,
};
use glam::{Mat4, Vec3, Vec4};
use hairmesh::reference::LodParams;

use crate::RgbaImage;
use crate::camera::FrameView;
use crate::camera::{Camera, Character, character_inputs};
use crate::contract::{OIT_BINDINGS, OIT_FILL_BINDINGS, binding};
use crate::graph::{Access, FrameGraph, GraphRun, Res, TransientPool};
use crate::instance::{CharacterHair, SceneInstance};
use crate::occluder::{OccluderMesh, OccluderPipelines};
use crate::passes::ScenePass;
use crate::raster::{
    ComputeRaster, DepthClipping, FusedStrands, LoadPath, MAX_MATERIALS, RasterBuffers, RasterMaterial,
    RasterPath, resolve_raster,
};
use crate::scene::{Light, LoadedScene, Transparency};
use crate::shadow::{ShadowAtlas, ShadowPipelines};
use crate::target::{LinearFrame, SCENE_COLOR_FORMAT, SceneTarget};
use crate::volume::{VolumeGrid, VolumePipelines, VolumeStore};

pub use crate::error::RenderError;
pub use crate::shaders;

pub use ids::FramePlan;
pub(crate) use ids::{FrameIds, FrameState, OitBuffers};
pub(crate) use lights::Shading;
pub(crate) use volumes::{SceneVolumes, VolumeFrame, VolumeIds, VoxelSource};

pub(crate) const OIT_NODE_BYTES: u64 = 16;

/// The most bytes an OIT node pool takes where the shaders reach it through its device address
/// (67 M nodes; elsewhere the storage-buffer range bounds it: 8 M nodes on lavapipe).
pub const OIT_POOL_BYTES: u64 = 1 << 30;

/// Words per pixel of the OIT heads buffer: the list's head and the overflow tail's six sums
/// (`oit.glsl`; 1, the head alone, when the output is too large for them).
pub(crate) const OIT_PIXEL_WORDS: u64 = 7;

/// Strand-buffer bytes one submission of a frame may hold (characters beyond it go to the next
/// batch): a 100-character crowd with LOD off needs gigabytes otherwise.
pub const BATCH_BYTES: u64 = 1 << 30;

/// Order-independent transparency: the fill generator (hair_oit.frag) and the resolve pass.
pub(crate) struct Oit {
    pub(crate) fill: Generator,
    pub(crate) resolve: Pipeline,
    pub(crate) k: u32,
    pub(crate) nodes_per_pixel: f32,
}

pub(crate) struct SceneCharacter {
    pub(crate) hair: usize,
    pub(crate) transform: Mat4,
    pub(crate) color: [f32; 3],
    pub(crate) variation: f32,
}

/// An occluder mesh placed in the world.
pub(crate) struct SceneOccluder {
    pub(crate) mesh: usize,
    pub(crate) transform: Mat4,
    pub(crate) color: [f32; 3],
    /// Its character's hair: the volume source ([`SceneRenderer::volume_sources`]) and placement
    /// whose AO darkens it.
    pub(crate) hair_volume: usize,
    pub(crate) hair_transform: Mat4,
}

/// Everything a scene needs on the GPU, built once and rendered many times.
pub struct SceneRenderer {
    pub(crate) generator: Generator,
    /// Blended mode: the solid-fragment depth prepass (`hair_depth.frag`).
    pub(crate) depth_prepass: Option<Generator>,
    pub(crate) oit: Option<Oit>,
    /// Shadow pipelines, when some light casts shadows.
    pub(crate) shadow: Option<ShadowPipelines>,
    /// The last shadow maps rendered, the content they were rendered from and the LOD of the
    /// view they were planned with (the lights' views follow it): reused while
    /// [`Self::content_version`] and the LOD are unchanged (hair edits bump their asset's
    /// revision, moved characters the placement count), or whatever changed while
    /// [`Self::reuse_stale_shadow_maps`] is on.
    shadow_cache: Mutex<Option<(ContentVersion, LodParams, ShadowAtlas)>>,
    /// [`Self::reuse_stale_shadow_maps`].
    stale_shadows_ok: std::sync::atomic::AtomicBool,
    /// The frames' transient resources, reused from frame to frame.
    pool: Mutex<TransientPool>,
    /// Compute rasterizer: what the next frame's slot order is made from
    /// ([`crate::raster::SlotOrderHistory`]).
    slot_history: Mutex<crate::raster::SlotOrderHistory>,
    /// Bound at the shadow bindings when the scene has no shadows (never read then).
    no_shadow: [Buffer; 3],
    /// Occluder pipelines (only when some character has an occluder), meshes and placements.
    pub(crate) occluder_pipes: Option<OccluderPipelines>,
    pub(crate) meshes: Vec<OccluderMesh>,
    pub(crate) occluders: Vec<SceneOccluder>,
    pub(crate) hairs: Vec<GpuHair>,
    /// The upload of each character key ([`crate::instance::CharacterInstance::key`]).
    hair_keys: HashMap<String, usize>,
    /// Characters whose hair is generated.
    pub(crate) characters: Vec<SceneCharacter>,
    /// Explicit strands uploaded once, and the characters drawing them.
    pub(crate) stored: Vec<gen_gpu::StoredStrands>,
    pub(crate) stored_characters: Vec<SceneCharacter>,
    /// The scene as loaded; never changed after set-up (what the renderer chose is in
    /// [`Self::effects`] and [`Self::raster`]).
    pub(crate) scene: LoadedScene,
    /// The effects this renderer draws: the scene's, with what set-up decided for this device
    /// (`"lod": "auto"` on the compute rasterizer turns the volume LOD path on). Passes read
    /// these, never the scene's.
    pub(crate) effects: crate::scene::Effects,
    pub(crate) path: GenerationPath,
    /// The compute rasterizer's pipelines when the scene's `effects.raster` resolved to it on
    /// this device (the one record of that choice: [`Self::raster`]); `None`: triangles.
    pub(crate) compute_raster: Option<ComputeRaster>,
    /// Compute rasterizer: the distinct hair materials, and each character's index into them
    /// (generated characters, then stored ones).
    raster_materials: Vec<RasterMaterial>,
    character_materials: Vec<u32>,
    /// Compute rasterizer: draw in two phases around the occlusion tiles (the default) or every
    /// strand in one ([`Self::with_occlusion_tiles`]).
    pub(crate) occlusion_tiles: bool,
    /// Compute rasterizer with OIT: the front phase draws each character's strand segments that
    /// reached the last frame's image (with no history, every eighth slot) instead of every
    /// eighth slot ([`Self::with_slot_order`]).
    pub(crate) slot_order: bool,
    /// Compute rasterizer: clip every character's segments to the view volume's depth, also
    /// where its bounds lie wholly inside it ([`Self::with_depth_clipping_everywhere`]).
    pub(crate) depth_clipping_everywhere: bool,
    /// The compute rasterizer's plain loads and the triangle OIT's node pool go through buffer
    /// references where the device has them ([`Self::with_buffer_references`]).
    pub(crate) buffer_references: bool,
    /// Compute rasterizer: what its fused-generation kernel draws of each strand
    /// ([`Self::with_fused_strands`]).
    fused_strands: FusedStrands,
    /// Hair volumes (with `"ao"`, `"volume_shadows"` or `"volume_lod"`).
    pub(crate) volumes: Option<SceneVolumes>,
    /// `"volume_lod"`: every character raymarched whatever its size ([`Self::with_volumes_everywhere`]).
    volumes_everywhere: bool,
    /// See [`BATCH_BYTES`].
    batch_bytes: u64,
    /// Hair updates staged since the last frame, in order: (hair, update). The next frame's
    /// first passes copy them ([`crate::passes::upload`]).
    staged: Mutex<Vec<(usize, gen_gpu::StagedHairUpdate)>>,
    /// Per scene character: where it lives (generated or stored, its index) and its occluder's
    /// index with the occluder's own placement under the character.
    slots: Vec<CharacterSlot>,
    /// Bumped by every [`Self::set_character_transform`]: placements are part of what shadow
    /// maps are made from.
    placements: u64,
}

/// Where a scene character's parts live in a [`SceneRenderer`].
#[derive(Clone, Copy, Debug)]
struct CharacterSlot {
    stored: bool,
    index: usize,
    occluder: Option<(usize, Mat4)>,
}

impl std::fmt::Debug for SceneRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SceneRenderer")
            .field("scene", &self.scene.path)
            .field("hairs", &self.hairs.len())
            .finish()
    }
}

/// The content a scene's caches were made from ([`SceneRenderer::content_version`]); a cache
/// whose version differs from the scene's is stale.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ContentVersion(Vec<u64>);

/// A rendered frame.
#[derive(Debug)]
pub struct RenderedFrame {
    /// 8-bit sRGB (what PNG output writes).
    pub image: RgbaImage,
    /// Linear colour, coverage and depth (what EXR output writes).
    pub linear: LinearFrame,
    pub timings: FrameTimings,
    pub stats: GenerationStats,
    /// The passes recorded, by name, in order.
    pub passes: Vec<String>,
    /// The graph this frame ran (its runnable passes are [`Self::passes`]).
    pub graph: FrameGraph<()>,
    /// OIT: fragments that found the node pool full (`None` in opaque mode): blended into their
    /// pixel's overflow tail, order-independently behind its nearest ones (dropped only when the
    /// output is too large for the tail's words in one storage buffer).
    pub oit_overflow: Option<u64>,
    /// OIT: nodes in the pool.
    pub oit_pool: Option<u64>,
    /// Compute rasterizer: pixels with more fragments than their visibility slots (the rest are
    /// blended behind the K nearest with the K-th's colour; `None` on the triangle raster).
    pub raster_overflow: Option<u64>,
    /// Compute rasterizer: visibility slots per pixel this frame had.
    pub raster_slots: Option<u32>,
    /// Characters drawn as volumes (the volume LOD path) this frame, wholly or in the transition
    /// band.
    pub volume_characters: usize,
    /// Per character, generated ones first, then those drawing stored strands (each in scene
    /// order): the share of its pixels its volume drew (0: strands only, 1: volume only,
    /// between: the transition band).
    pub volume_fractions: Vec<f32>,
    /// Hairs voxelized this frame (the others' volumes were cached).
    pub volumes_voxelized: usize,
    /// Shadow maps were reused from an earlier frame.
    pub shadow_cached: bool,
    /// GPU time of the shadow maps when this frame computed them.
    pub shadow_ms: Option<f64>,
}

/// The axis-aligned box around `bounds` (a box) transformed by `m`.
pub(crate) fn transformed_box(m: Mat4, (a, b): (Vec3, Vec3)) -> (Vec3, Vec3) {
    crate::camera::box_corners(a, b).into_iter().fold(
        (Vec3::INFINITY, Vec3::NEG_INFINITY),
        |(lo, hi), corner| {
            let p = m.transform_point3(corner);
            (lo.min(p), hi.max(p))
        },
    )
}
