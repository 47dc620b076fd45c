//! Rendering a scene: hair uploaded once per asset and style, then per frame a [`FrameGraph`]
//! planned from the scene's effects ([`SceneRenderer::plan`]) and run pass by pass
//! ([`crate::passes`]): shadow maps (cached while the casters do not change), LOD and
//! generation per character, occluders, the hair raster in the scene's transparency mode, the
//! copy out. The graph's declarations give the barriers, the timing scopes and `--print-graph`.

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

/// `Shading` push constants of the hair fragment stages (after the pre-raster bytes; see
/// `shading_constants.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Shading {
    model: [f32; 16],
    eye: [f32; 4],
    hair_color: [f32; 4],
    specular_shift: [f32; 4],
    specular_strength: [f32; 4],
    hair_opacity: [f32; 4],
    /// The character's hair volume: object → voxel is `(p − xyz) · w`; its grid (dims, first
    /// voxel); (first brick, bit 0 AO, bit 1 volume shadows). Zero without volumes.
    volume_box: [f32; 4],
    volume_grid: [u32; 4],
    volume_info: [u32; 4],
}

/// `SceneLight` of `lighting.glsl` (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuLight {
    vector: [f32; 4],
    color: [f32; 4],
    view_proj: [f32; 16],
    layer_ends: [f32; 4],
    map: [f32; 4],
    depth: [f32; 4],
}

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

/// The hair volumes of a scene with `"ao"`, `"volume_shadows"` or `"volume_lod"` ([`crate::volume`]).
pub(crate) struct SceneVolumes {
    pub(crate) pipelines: VolumePipelines,
    pub(crate) store: VolumeStore,
    /// Per hair: the grid its region holds and the hair revision it was voxelized from.
    cache: Mutex<Vec<Option<(VolumeGrid, u64)>>>,
    /// Strand opacity of the scene's hair (the AO's and the raymarch's).
    pub(crate) opacity: f32,
}

/// A hair's volume in a frame: its grid, and whether its region already holds it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct HairVolumePlan {
    pub(crate) grid: VolumeGrid,
    pub(crate) cached: bool,
}

/// The graph's names of the volume resources, and each hair's volume this frame.
#[derive(Clone, Debug)]
pub(crate) struct VolumeIds {
    pub(crate) volume: Res,
    pub(crate) ao: Res,
    pub(crate) bricks: Res,
    pub(crate) lod: Vec<Res>,
    pub(crate) sums: Vec<Res>,
    pub(crate) hairs: Vec<Option<HairVolumePlan>>,
    /// Characters raymarched this frame ([`SceneRenderer::volume_character`]'s numbers).
    pub(crate) marched: Vec<usize>,
    /// Per character (the same numbers): the share of its pixels its volume draws (1: all, in
    /// no strand batch; between 0 and 1: the transition band, drawn by both).
    pub(crate) fractions: Vec<f32>,
}

/// A voxelization recorded this frame.
pub(crate) struct HairVolumeFrame {
    pub(crate) grid: VolumeGrid,
    pub(crate) address: crate::volume::VolumeAddress,
    pub(crate) source: VoxelSource,
    pub(crate) sums: Buffer,
}

/// Where a voxelization's strands come from.
pub(crate) enum VoxelSource {
    /// A generated hair: its LOD pass's buffers (`volume::voxelization_inputs`).
    Generated(Box<FrameBuffers>),
    /// Stored strands `s`: their parameters.
    Stored(usize, Buffer),
}

/// A character raymarched this frame.
pub(crate) struct MarchJob {
    pub(crate) character: usize,
    pub(crate) push: crate::volume::MarchPush,
}

/// The volume work of one frame.
#[derive(Default)]
pub(crate) struct VolumeFrame {
    pub(crate) hairs: Vec<Option<HairVolumeFrame>>,
    pub(crate) marches: Vec<MarchJob>,
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
    pub(crate) scene: LoadedScene,
    pub(crate) path: GenerationPath,
    /// The rasterizer the scene's `effects.raster` resolved to on this device.
    pub(crate) raster: RasterPath,
    /// The compute rasterizer's pipelines (when `raster` is compute).
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

/// The resources of a planned frame, as the graph names them.
#[derive(Clone, Debug)]
pub(crate) struct FrameIds {
    pub(crate) color: Res,
    pub(crate) depth: Res,
    pub(crate) resolve: Option<(Res, Res)>,
    pub(crate) readback: Res,
    pub(crate) lights: Res,
    pub(crate) oit_lists: Res,
    pub(crate) occluder_meshes: Res,
    /// Compute rasterizer: visibility + coverage, the occluders' depth copy, the resolve's
    /// camera and materials.
    pub(crate) visibility: Res,
    pub(crate) scene_depth: Res,
    pub(crate) raster_frame: Res,
    pub(crate) shaded: Res,
    pub(crate) raster_tiles: Res,
    /// Compute rasterizer: the characters' slot orders, their strand marks, the last frame's
    /// depths ([`crate::raster::SlotOrderHistory`]).
    pub(crate) slot_orders: Res,
    pub(crate) strand_marks: Res,
    pub(crate) final_depth: Res,
    /// Per uploaded hair: its asset.
    pub(crate) hair_uploads: Vec<Res>,
    /// Per generated character: whether its strands get a second front eighth in the compute
    /// rasterizer ([`crate::raster::second_front_pays`]).
    pub(crate) second_front: Vec<bool>,
    /// Hair volumes (with `"ao"`, `"volume_shadows"` or `"volume_lod"`).
    pub(crate) volumes: Option<VolumeIds>,
    /// Per generated character: its hair asset, LOD result and strands.
    pub(crate) hair: Vec<Res>,
    pub(crate) lod: Vec<Res>,
    pub(crate) strands: Vec<Res>,
    pub(crate) stored: Vec<Res>,
    pub(crate) shadow: Option<crate::passes::shadow::ShadowIds>,
}

impl FrameIds {
    /// Whether generated character `i` gets a second front eighth this frame.
    pub(crate) fn second_front(&self, i: usize) -> bool {
        self.second_front.get(i).copied().unwrap_or(false)
    }

    /// What a pass that shades with the scene's lights reads: the light table, and the shadow
    /// maps when the scene has them.
    pub(crate) fn shading_reads(&self) -> Vec<(Res, Access)> {
        self.shading_reads_as(Access::FragmentRead)
    }

    /// What a pass that shades hair reads: [`Self::shading_reads`] and the hair volumes (AO and
    /// volume shadows) when the scene has them.
    pub(crate) fn hair_shading_reads(&self) -> Vec<(Res, Access)> {
        let mut r = self.shading_reads();
        r.extend(self.volume_reads(Access::FragmentRead));
        r
    }

    /// [`Self::hair_shading_reads`] by a compute pass.
    pub(crate) fn compute_hair_shading_reads(&self) -> Vec<(Res, Access)> {
        let mut r = self.shading_reads_as(Access::ComputeRead);
        r.extend(self.volume_reads(Access::ComputeRead));
        r
    }

    fn volume_reads(&self, access: Access) -> Vec<(Res, Access)> {
        self.volumes.iter().flat_map(|v| [(v.volume, access), (v.ao, access), (v.bricks, access)]).collect()
    }

    fn shading_reads_as(&self, access: Access) -> Vec<(Res, Access)> {
        let mut r = vec![(self.lights, access)];
        r.extend(self.shadow.as_ref().map(|s| (s.maps, access)));
        r
    }

    /// The attachments a pass rendering into the scene target writes.
    pub(crate) fn target_writes(&self) -> Vec<(Res, Access)> {
        let mut w = vec![(self.color, Access::ColorAttachment), (self.depth, Access::DepthAttachment)];
        if let Some((c, d)) = self.resolve {
            w.push((c, Access::ColorAttachment));
            w.push((d, Access::DepthAttachment));
        }
        w
    }
}

/// A frame planned for one camera: its graph, the resource names, the batches of characters
/// (one submission each) and the generation inputs.
#[derive(Debug)]
pub struct FramePlan {
    pub graph: FrameGraph<ScenePass>,
    pub(crate) ids: FrameIds,
    /// Generated characters per batch submission, and the submission of the first batch.
    pub(crate) batches: Vec<Vec<usize>>,
    pub(crate) first_batch_submission: usize,
    pub(crate) view: FrameView,
    pub(crate) inputs: Vec<FrameInputs>,
    pub(crate) shadow_cached: bool,
    /// Characters drawn as volumes (in no batch).
    pub(crate) volume_characters: Vec<usize>,
}

impl FramePlan {
    /// The share of character `i`'s pixels its volume draws this frame (0 without one).
    pub(crate) fn volume_fraction(&self, i: usize) -> f32 {
        self.ids.volumes.as_ref().and_then(|v| v.fractions.get(i).copied()).unwrap_or(0.0)
    }
}

/// What the passes of one submission read: the frame's resources and the current batch's
/// generated strands.
pub(crate) struct FrameState<'a> {
    pub(crate) plan: &'a FramePlan,
    pub(crate) target: &'a SceneTarget,
    pub(crate) lighting: [(u32, &'a Buffer); 4],
    pub(crate) oit: Option<&'a OitBuffers>,
    /// The compute rasterizer's buffers.
    pub(crate) raster: Option<&'a RasterBuffers>,
    /// Material index per character (generated, then stored).
    pub(crate) materials: &'a [u32],
    /// This batch's characters and their frame buffers.
    pub(crate) frames: &'a [(usize, FrameBuffers)],
    /// Compute rasterizer: the last frame's depths, each character's marks and slot order.
    pub(crate) slot_history: Option<&'a crate::raster::SlotOrderHistory>,
    /// Parameters of the stored-strand characters (drawn with the last batch).
    pub(crate) stored_params: &'a [Buffer],
    /// The frame's voxelizations and raymarches (first batch).
    pub(crate) volumes: Option<&'a VolumeFrame>,
    /// The hair volumes at the fragment stages' bindings (`FRAGMENT_VOLUME_BINDINGS`; unread
    /// stand-ins without volumes).
    pub(crate) volume_buffers: [(u32, &'a Buffer); 3],
}

/// The OIT lists of one frame.
#[derive(Debug)]
pub(crate) struct OitBuffers {
    pub(crate) heads: Buffer,
    pub(crate) nodes: Buffer,
    pub(crate) counters: Buffer,
    pub(crate) pool: u64,
    /// Words per pixel of `heads`: [`OIT_PIXEL_WORDS`] with the overflow tail, 1 without.
    pub(crate) pixel_words: u32,
    /// The device address the shaders reach `nodes` through (it may exceed the storage-buffer
    /// range); 0: through its binding.
    pub(crate) nodes_address: u64,
}

impl SceneRenderer {
    /// Loads every file `scene` names ([`SceneInstance::load`]) and sets the scene up on the GPU.
    pub fn new(ctx: &Context, scene: &LoadedScene, path: GenerationPath) -> Result<Self, RenderError> {
        Self::from_instance(ctx, &SceneInstance::load(scene)?, path)
    }

    /// Sets up a scene whose characters are in memory (no file is read): pipelines for its
    /// effects, one upload per distinct hair and occluder mesh.
    pub fn from_instance(
        ctx: &Context,
        instance: &SceneInstance,
        path: GenerationPath,
    ) -> Result<Self, RenderError> {
        let scene = &instance.settings;
        let effects = scene.scene.effects;
        // The fragment stages shade the scene's lights by constant index (lighting.glsl).
        let scene_lights = crate::contract::scene_lights_constant(scene.lights().len());
        let generator = Generator::with_options(
            ctx,
            GeneratorOptions {
                fragment: Some(FragmentStage {
                    shader: &shaders::HAIR_FRAG,
                    push_constant_bytes: size_of::<Shading>() as u32,
                    blend: gen_gpu::Blend::Over,
                    // Blended mode: only the depth prepass writes hair depth; this pass shades
                    // what lies in front of (or is) the nearest solid fragment.
                    depth_write: effects.transparency != Transparency::Blended,
                    depth_compare: if effects.transparency == Transparency::Blended {
                        vk::CompareOp::LESS_OR_EQUAL
                    } else {
                        vk::CompareOp::LESS
                    },
                    color_write: true,
                    extra_bindings: &crate::contract::HAIR_FRAGMENT_BINDINGS,
                    specialization: Some(scene_lights),
                }),
                color_format: Some(SCENE_COLOR_FORMAT),
                samples: effects.msaa,
                ..GeneratorOptions::default()
            },
        )?;
        // Blended mode's depth prepass: fragments a strand covers fully write depth, thinner
        // ones do not, so a sub-pixel strand (alpha = coverage) never hides the strands behind it.
        let depth_prepass = if effects.transparency != Transparency::Blended {
            None
        } else {
            Some(Generator::with_options(
                ctx,
                GeneratorOptions {
                    fragment: Some(FragmentStage {
                        shader: &shaders::HAIR_DEPTH_FRAG,
                        push_constant_bytes: size_of::<Shading>() as u32,
                        blend: gen_gpu::Blend::Replace,
                        depth_write: true,
                        depth_compare: vk::CompareOp::LESS,
                        color_write: false,
                        extra_bindings: &[],
                        specialization: None,
                    }),
                    color_format: Some(SCENE_COLOR_FORMAT),
                    samples: effects.msaa,
                    ..GeneratorOptions::default()
                },
            )?)
        };
        let oit = if effects.transparency == Transparency::Oit {
            let fill = Generator::with_options(
                ctx,
                GeneratorOptions {
                    fragment: Some(FragmentStage {
                        shader: &shaders::HAIR_OIT_FRAG,
                        push_constant_bytes: size_of::<Shading>() as u32,
                        blend: gen_gpu::Blend::Replace,
                        depth_write: false,
                        depth_compare: vk::CompareOp::LESS,
                        color_write: false,
                        extra_bindings: &OIT_FILL_BINDINGS,
                        specialization: Some(scene_lights),
                    }),
                    color_format: Some(SCENE_COLOR_FORMAT),
                    ..GeneratorOptions::default()
                },
            )?;
            // The nearest hair's depth is written (gl_FragDepth) for depth output.
            let resolve = crate::target::composite_pipeline(
                ctx,
                "OIT resolve",
                &shaders::FULLSCREEN_VERT,
                &shaders::OIT_RESOLVE_FRAG,
                &OIT_BINDINGS,
                4,
            )?;
            Some(Oit { fill, resolve, k: effects.oit_k, nodes_per_pixel: effects.oit_nodes_per_pixel })
        } else {
            None
        };
        // One upload per key (asset and style): characters sharing both share the GPU hair.
        let mut keys: HashMap<&str, usize> = HashMap::new();
        let mut hairs = Vec::new();
        let mut characters = Vec::new();
        let mut stored = Vec::new();
        let mut stored_characters = Vec::new();
        let mut mesh_keys: HashMap<&str, usize> = HashMap::new();
        let mut meshes = Vec::new();
        let mut occluders = Vec::new();
        let mut occluder_sources = Vec::new();
        let mut slots = Vec::new();
        for c in &instance.characters {
            let occluder_slot =
                c.occluder.as_ref().map(|o| (occluders.len(), c.transform.inverse() * o.transform));
            if let Some(o) = &c.occluder {
                let mesh = match mesh_keys.get(o.key.as_str()) {
                    Some(&m) => m,
                    None => {
                        meshes.push(OccluderMesh::upload(ctx, &o.geometry)?);
                        mesh_keys.insert(&o.key, meshes.len() - 1);
                        meshes.len() - 1
                    }
                };
                // The hair's volume source is set below, once the uploads are counted.
                occluders.push(SceneOccluder {
                    mesh,
                    transform: o.transform,
                    color: o.color,
                    hair_volume: usize::MAX,
                    hair_transform: c.transform,
                });
            }
            // (Whether this character's hair is stored, and its index among its kind.)
            let source = match &c.hair {
                CharacterHair::Stored { strands, width } => {
                    stored.push(gen_gpu::StoredStrands::upload(
                        ctx,
                        &strands.points,
                        &strands.strand_points,
                        *width,
                        0.3,
                    )?);
                    stored_characters.push(SceneCharacter {
                        hair: stored.len() - 1,
                        transform: c.transform,
                        color: c.color,
                        variation: c.color_variation,
                    });
                    (true, stored.len() - 1)
                }
                CharacterHair::Generated(asset) => {
                    let hair = match keys.get(c.key.as_str()) {
                        Some(&h) => h,
                        None => {
                            hairs.push(GpuHair::upload(ctx, asset, TexturePrecision::Auto)?);
                            keys.insert(&c.key, hairs.len() - 1);
                            hairs.len() - 1
                        }
                    };
                    characters.push(SceneCharacter {
                        hair,
                        transform: c.transform,
                        color: c.color,
                        variation: c.color_variation,
                    });
                    (false, hair)
                }
            };
            if c.occluder.is_some() {
                occluder_sources.push(source);
            }
            let index = if source.0 { stored_characters.len() - 1 } else { characters.len() - 1 };
            slots.push(CharacterSlot { stored: source.0, index, occluder: occluder_slot });
        }
        // Volume sources: the uploaded hairs, then the stored strands.
        for (o, (is_stored, index)) in occluders.iter_mut().zip(occluder_sources) {
            o.hair_volume = if is_stored { hairs.len() + index } else { index };
        }
        let shadow = if scene.shadow_lights().is_empty() { None } else { Some(ShadowPipelines::new(ctx)?) };
        let no_shadow = [
            Buffer::new(ctx, "no shadow depth", BufferDesc::storage(16))?,
            Buffer::new(ctx, "no shadow opacity", BufferDesc::storage(16))?,
            Buffer::new(ctx, "no occluder depth", BufferDesc::storage(16))?,
        ];
        let occluder_pipes = if meshes.is_empty() {
            None
        } else {
            Some(OccluderPipelines::new(ctx, SCENE_COLOR_FORMAT, effects.msaa, scene.lights().len())?)
        };
        let mut renderer = Self {
            generator,
            depth_prepass,
            oit,
            shadow,
            shadow_cache: Mutex::new(None),
            stale_shadows_ok: std::sync::atomic::AtomicBool::new(false),
            pool: Mutex::new(TransientPool::default()),
            slot_history: Mutex::default(),
            no_shadow,
            occluder_pipes,
            meshes,
            occluders,
            hairs,
            hair_keys: keys.into_iter().map(|(k, h)| (k.to_owned(), h)).collect(),
            characters,
            stored,
            stored_characters,
            scene: scene.clone(),
            path,
            raster: RasterPath::Triangles,
            compute_raster: None,
            raster_materials: Vec::new(),
            character_materials: Vec::new(),
            occlusion_tiles: true,
            slot_order: true,
            depth_clipping_everywhere: false,
            buffer_references: true,
            fused_strands: FusedStrands::Styled,
            volumes: None,
            volumes_everywhere: false,
            batch_bytes: BATCH_BYTES,
            staged: Mutex::new(Vec::new()),
            slots,
            placements: 0,
        };
        renderer.set_up_raster(ctx)?;
        Ok(renderer)
    }

    /// Resolves the scene's rasterizer choice and, for the compute rasterizer, builds its
    /// pipelines and the material table (`auto` keeps triangles when the scene has more
    /// distinct hair materials than the visibility word can name).
    fn set_up_raster(&mut self, ctx: &Context) -> Result<(), RenderError> {
        let effects = self.scene.scene.effects;
        let mut raster = resolve_raster(effects.raster, &effects, ctx.capabilities())?;
        let eye = Vec3::from_array(self.scene.scene.camera.eye);
        let mut table: Vec<RasterMaterial> = Vec::new();
        let mut indices = Vec::new();
        for c in self.characters.iter().chain(&self.stored_characters) {
            let s = self.shading(c, eye);
            let m = RasterMaterial {
                hair_color: s.hair_color,
                specular_shift: s.specular_shift,
                specular_strength: s.specular_strength,
                opacity: s.hair_opacity,
                world_to_voxel: Mat4::IDENTITY.to_cols_array(),
                volume: [0; 4],
                volume_info: [0; 4],
            };
            // With AO or volume shadows a material names its character's volume: one per
            // character.
            let per_character = effects.ao || effects.volume_shadows;
            let shared = if per_character { None } else { table.iter().position(|t| *t == m) };
            let index = match shared {
                Some(i) => i,
                None => {
                    table.push(m);
                    table.len() - 1
                }
            };
            indices.push(index as u32);
        }
        // Two words per pixel at least (one slot and the coverage) in one storage buffer.
        let output = self.scene.scene.output;
        let pixels = u64::from(output.width) * u64::from(output.height);
        let range = u64::from(ctx.capabilities().max_storage_buffer_range);
        let why_not = if table.len() > MAX_MATERIALS {
            Some(format!("{} distinct hair materials (at most {MAX_MATERIALS})", table.len()))
        } else if pixels * 16 > range {
            Some(format!(
                "{}×{} needs {} bytes of per-pixel words, over the device's {range}-byte storage-buffer range",
                output.width,
                output.height,
                pixels * 16
            ))
        } else {
            None
        };
        if let (RasterPath::Compute, Some(why)) = (raster, why_not) {
            if effects.raster == crate::scene::Raster::Compute || effects.volume_lod {
                return Err(RenderError::RasterUnavailable { why });
            }
            raster = RasterPath::Triangles;
        }
        if raster == RasterPath::Compute {
            self.compute_raster = Some(ComputeRaster::new(
                ctx,
                self.scene.lights().len(),
                table.len(),
                self.compute_raster_loads(),
                Some(self.frame_slots(ctx)),
                self.fused_strands,
            )?);
            self.raster_materials = table;
            self.character_materials = indices;
            // The deep opacity maps go through the same segment walker.
            if let Some(shadow) = &mut self.shadow {
                shadow.compute = Some(crate::shadow::ComputeShadow::new(ctx)?);
            }
        }
        // `"lod": "auto"` draws characters small enough that the volume keeps the image within
        // its FLIP (crate::scene::AUTO_VOLUME_PIXELS) as volumes wherever the compute rasterizer
        // draws the hair (the volume LOD path writes into its visibility buffer); a scene that
        // asks for `volume_lod` itself keeps its own threshold.
        let mut effects = effects;
        if raster == RasterPath::Compute && self.scene.scene.lod.auto && !effects.volume_lod {
            effects.volume_lod = true;
            effects.volume_lod_pixels = crate::scene::AUTO_VOLUME_PIXELS;
            self.scene.scene.effects = effects;
        }
        // AO and volume shadows work on either rasterizer; the volume LOD path needs the
        // compute rasterizer (the scene is refused otherwise).
        if effects.uses_volumes() {
            let bounds: Vec<(Vec3, Vec3)> =
                (0..self.volume_sources()).map(|v| self.volume_bounds(v)).collect();
            self.volumes = Some(SceneVolumes {
                pipelines: VolumePipelines::new(ctx)?,
                store: VolumeStore::new(ctx, &bounds, effects.volume_resolution)?,
                cache: Mutex::new(vec![None; bounds.len()]),
                opacity: if self.oit.is_some() { 0.7 } else { 1.0 },
            });
        }
        self.raster = raster;
        Ok(())
    }

    /// Whether the deep opacity maps are rasterized by the compute rasterizer's kernels (with
    /// the compute rasterizer and shadows) rather than the triangle pipeline.
    pub fn compute_shadows(&self) -> bool {
        self.shadow.as_ref().is_some_and(|s| s.compute.is_some())
    }

    /// Renders the deep opacity maps through the triangle pipeline from now on, whatever the
    /// rasterizer (the reference the compute maps are tested and benchmarked against); maps
    /// already cached are made again on the next frame.
    pub fn use_triangle_shadows(&mut self) {
        if let Some(s) = &mut self.shadow {
            s.compute = None;
        }
        self.forget_shadow_maps();
    }

    /// Drops the cached shadow maps: the next frame makes them again (benchmarks time them so).
    pub fn forget_shadow_maps(&self) {
        *self.shadow_cache.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }

    /// The rasterizer this renderer draws hair with.
    pub fn raster(&self) -> RasterPath {
        self.raster
    }

    /// Compute rasterizer with a slot order (OIT scenes): generated character `character`'s
    /// marks after the last frame — per strand slot the mask of its segments that reached the
    /// image, which the next frame draws first — or `None` without a slot order or before the
    /// first frame.
    pub fn strand_marks(&self, ctx: &Context, character: usize) -> Result<Option<Vec<u32>>, RenderError> {
        let history = self.slot_history.lock().unwrap_or_else(|e| e.into_inner());
        let Some(Some(c)) = history.characters.get(character) else { return Ok(None) };
        let bytes = ctx.read_buffer(&c.marks, c.capacity * 4)?;
        Ok(Some(bytemuck::pod_collect_to_vec(&bytes)))
    }

    /// Compute rasterizer with a slot order: the order generated character `character`'s
    /// strands were drawn in the last frame ([`crate::raster::StrandOrder`]), or `None`.
    pub fn strand_order(
        &self,
        ctx: &Context,
        character: usize,
    ) -> Result<Option<crate::raster::StrandOrder>, RenderError> {
        let history = self.slot_history.lock().unwrap_or_else(|e| e.into_inner());
        let Some(Some(c)) = history.characters.get(character) else { return Ok(None) };
        let header: Vec<u32> =
            bytemuck::pod_collect_to_vec(&ctx.read_buffer(&c.order, crate::raster::SLOT_ORDER_HEADER)?);
        let (front, rest) = (u64::from(header[6]), u64::from(header[7]));
        // The counts come from the GPU: never past the buffer (2 × capacity entries).
        if front + rest > 2 * c.capacity {
            return Err(RenderError::Gpu(gen_gpu::GpuError::OutOfRange {
                name: "strand slot order".into(),
                size: c.order.size(),
                requested: crate::raster::SLOT_ORDER_HEADER
                    + (front + rest) * crate::raster::SLOT_ORDER_ENTRY_BYTES,
            }));
        }
        let bytes = ctx.read_buffer(
            &c.order,
            crate::raster::SLOT_ORDER_HEADER + (front + rest) * crate::raster::SLOT_ORDER_ENTRY_BYTES,
        )?;
        let entries: Vec<[u32; 2]> =
            bytemuck::pod_collect_to_vec(&bytes[crate::raster::SLOT_ORDER_HEADER as usize..]);
        let (front, rest) = entries.split_at(front as usize);
        Ok(Some(crate::raster::StrandOrder { front: front.to_vec(), rest: rest.to_vec() }))
    }

    /// The strand opacity of compute-raster material `material`.
    pub(crate) fn raster_opacity(&self, material: u32) -> f32 {
        self.raster_materials.get(material as usize).map_or(1.0, |m| m.opacity[0])
    }

    /// Compute rasterizer: visibility slots per pixel the scene asks for (the K nearest
    /// fragments: `oit_k` with OIT, else 1).
    fn raster_slots(&self) -> u32 {
        let effects = self.scene.scene.effects;
        if effects.transparency == Transparency::Oit { effects.oit_k } else { 1 }
    }

    /// The compute rasterizer's visibility slots per pixel in every frame: the scene's
    /// ([`Self::raster_slots`]) as many as one storage buffer holds at its output size
    /// ([`crate::raster::slots_within`]). Views are at most the output ([`Self::render_view`]),
    /// so each frame's buffers hold exactly these, and the kernels are specialized for them.
    fn frame_slots(&self, ctx: &Context) -> u32 {
        let output = self.scene.scene.output;
        let pixels = u64::from(output.width) * u64::from(output.height);
        crate::raster::slots_within(self.raster_slots(), pixels, ctx.capabilities().max_storage_buffer_range)
    }

    fn view(&self) -> FrameView {
        let c = &self.scene.scene.camera;
        self.view_from(Vec3::from_array(c.eye), Vec3::from_array(c.target))
    }

    /// The scene's view (its output size, field of view and LOD settings) with the camera at
    /// `eye` looking at `target`: what [`Self::render_camera`] draws. Change its size (at most
    /// the scene's output) or LOD and pass it to [`Self::render_view`], e.g. for an editor's
    /// quick previews.
    pub fn frame_view(&self, eye: Vec3, target: Vec3) -> FrameView {
        self.view_from(eye, target)
    }

    pub(crate) fn view_from(&self, eye: Vec3, target: Vec3) -> FrameView {
        let s = &self.scene.scene;
        FrameView {
            camera: Camera { eye, target, fov_y: s.camera.fov_y_degrees.to_radians() },
            width: s.output.width,
            height: s.output.height,
            path: self.path,
            lod: s.lod.params(),
        }
    }

    /// Whether the compute rasterizer's front phase draws each character's strand segments
    /// that reached the last frame's image ([`Self::with_slot_order`]): with occlusion tiles
    /// and more than one visibility slot per pixel (OIT). With one slot (opaque and blended
    /// scenes) it measured no faster than every eighth strand: their front phase closes the
    /// tiles already, and the rest then generates the marked strands a second time.
    pub(crate) fn raster_slot_order(&self) -> bool {
        let several_slots =
            self.compute_raster.as_ref().and_then(ComputeRaster::slots).is_some_and(|k| k > 1);
        several_slots && self.occlusion_tiles && self.slot_order
    }

    /// Compute rasterizer: `false` draws every strand in one dispatch instead of the front
    /// strands, the occlusion tiles and the rest (the image is the same; tests compare them).
    pub fn with_occlusion_tiles(mut self, on: bool) -> Self {
        self.occlusion_tiles = on;
        self
    }

    /// Compute rasterizer with occlusion tiles and OIT: `false` makes the front phase every
    /// eighth strand slot of each character in every frame, instead of the strand segments that
    /// reached the last frame's image (the image is the same; tests compare them).
    pub fn with_slot_order(mut self, on: bool) -> Self {
        self.slot_order = on;
        self
    }

    /// Compute rasterizer: `true` draws every character with the raster kernels' variant that
    /// clips segments to the view volume's depth, where by default a character whose bounds lie
    /// wholly inside it goes through the one without ([`crate::raster::DepthClipping`]; the
    /// image is the same: tests compare them).
    pub fn with_depth_clipping_everywhere(mut self, on: bool) -> Self {
        self.depth_clipping_everywhere = on;
        self
    }

    /// The compute rasterizer's kernel variant for each character seen through `view`: the
    /// generated characters in scene order, then the stored ones. The raster pass binds these.
    pub fn raster_depth_clipping(&self, view: &FrameView) -> Vec<DepthClipping> {
        let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
        self.volume_characters()
            .map(|(c, source)| {
                if self.depth_clipping_everywhere {
                    DepthClipping::Clip
                } else {
                    // The matrix the kernels multiply positions by (camera::character_inputs).
                    DepthClipping::for_bounds(view_proj * c.transform, self.volume_bounds(source))
                }
            })
            .collect()
    }

    /// Compute rasterizer: `false` has its raster and shade kernels read the pixel words,
    /// occlusion tiles and shadow maps through their bindings instead of buffer references (the
    /// image is the same; tests compare them). References are the default where the device has
    /// buffer device addresses: CPU devices gather loads through them with vector instructions.
    /// The kernels are specialized for one or the other ([`crate::raster::LoadPath`]), so a
    /// change makes the compute rasterizer's pipelines again.
    pub fn with_buffer_references(mut self, ctx: &Context, on: bool) -> Result<Self, RenderError> {
        self.buffer_references = on;
        self.remake_compute_raster(ctx)?;
        Ok(self)
    }

    /// Compute rasterizer: what its fused-generation kernel draws of each strand. The default,
    /// [`FusedStrands::Styled`], is the frames' strands; [`FusedStrands::Straight`] draws each
    /// as a straight line from its root to its tip through the same walk — a different image,
    /// for benchmarks that measure what generation costs inside the kernel (`hair-bench --only
    /// raster`); its raster passes say so in their names. The kernels are specialized for one
    /// or the other, so a change makes the compute rasterizer's pipelines again.
    pub fn with_fused_strands(mut self, ctx: &Context, strands: FusedStrands) -> Result<Self, RenderError> {
        self.fused_strands = strands;
        self.remake_compute_raster(ctx)?;
        Ok(self)
    }

    /// The compute rasterizer's pipelines made again for the renderer's settings (when it has
    /// them).
    fn remake_compute_raster(&mut self, ctx: &Context) -> Result<(), RenderError> {
        if self.compute_raster.is_some() {
            let (lights, materials) = (self.scene.lights().len(), self.raster_materials.len());
            self.compute_raster = Some(ComputeRaster::new(
                ctx,
                lights,
                materials,
                self.compute_raster_loads(),
                Some(self.frame_slots(ctx)),
                self.fused_strands,
            )?);
        }
        Ok(())
    }

    /// How the compute rasterizer's kernels are to read ([`Self::with_buffer_references`]).
    fn compute_raster_loads(&self) -> LoadPath {
        if self.buffer_references { LoadPath::BufferReferences } else { LoadPath::Bindings }
    }

    /// The address the triangle OIT's shaders reach `buffer` through: its device address with
    /// buffer references on (0 where the device has none), else 0 (the binding).
    pub(crate) fn load_address(&self, buffer: &Buffer) -> u64 {
        if self.buffer_references { buffer.device_address() } else { 0 }
    }

    /// With `"volume_lod"`: `true` raymarches every character, whatever its projected size (the
    /// camera inside its hair too), for comparisons and benchmarks of the volume path.
    pub fn with_volumes_everywhere(mut self, on: bool) -> Self {
        self.volumes_everywhere = on;
        self
    }

    /// Caps the strand-buffer bytes of one submission (default [`BATCH_BYTES`]); at least one
    /// character goes into each batch.
    pub fn with_batch_bytes(mut self, bytes: u64) -> Self {
        self.batch_bytes = bytes;
        self
    }

    /// The graph the next frame from the scene's camera runs (passes whose results are cached
    /// are marked so).
    pub fn graph(&self) -> FrameGraph<()> {
        self.plan(self.view()).graph.outline()
    }

    /// What every cache of this scene is derived from: the revision of each uploaded hair and
    /// the count of placement changes ([`Self::set_character_transform`]; lights and occluder
    /// meshes are fixed for a renderer's life).
    pub fn content_version(&self) -> ContentVersion {
        ContentVersion(self.hairs.iter().map(GpuHair::revision).chain([self.placements]).collect())
    }

    /// Whether a frame planned with `lod` reuses the cached shadow maps.
    fn shadows_cached(&self, lod: &LodParams) -> bool {
        let cache = self.shadow_cache.lock().unwrap_or_else(|e| e.into_inner());
        let stale_ok = self.stale_shadows_ok.load(std::sync::atomic::Ordering::Relaxed);
        cache.as_ref().is_some_and(|(version, made_with, _)| {
            stale_ok || (*version == self.content_version() && made_with == lod)
        })
    }

    /// While `reuse` is true, frames show the cached shadow maps even when the hair, the
    /// placements or the LOD changed since they were made (an editor's drafts while a slider or
    /// a vertex is dragged: the maps cost more than the rest of such a frame); the first frame
    /// with it false makes them again if they are stale. Without cached maps a frame makes them
    /// either way.
    pub fn reuse_stale_shadow_maps(&self, reuse: bool) {
        self.stale_shadows_ok.store(reuse, std::sync::atomic::Ordering::Relaxed);
    }

    /// Moves scene character `index` (in the scene's order): its hair and its occluder (which
    /// keeps its own placement under the character) are drawn at `transform` (object → world)
    /// from the next frame on. Shadow maps are rendered again; hair volumes, made in the hair's
    /// object space, stay cached.
    pub fn set_character_transform(&mut self, index: usize, transform: Mat4) -> Result<(), RenderError> {
        let Some(slot) = self.slots.get(index).copied() else {
            return Err(RenderError::InvalidView {
                why: format!("character {index} does not exist ({} characters)", self.slots.len()),
            });
        };
        if !transform.is_finite() || transform.determinant().abs() <= f32::EPSILON {
            return Err(RenderError::InvalidView {
                why: format!("character {index}: the transform is not finite and invertible"),
            });
        }
        let list = if slot.stored { &mut self.stored_characters } else { &mut self.characters };
        if list[slot.index].transform == transform {
            return Ok(());
        }
        list[slot.index].transform = transform;
        if let Some((o, local)) = slot.occluder {
            self.occluders[o].transform = transform * local;
            self.occluders[o].hair_transform = transform;
        }
        self.placements += 1;
        Ok(())
    }

    /// The staged hair updates the next frame uploads first: (hair, revision it brings).
    pub(crate) fn staged_hair_updates(&self) -> Vec<(usize, u64)> {
        let staged = self.staged.lock().unwrap_or_else(|e| e.into_inner());
        staged.iter().map(|(h, u)| (*h, u.revision)).collect()
    }

    /// Records the `k`-th staged update's copies (the upload pass).
    pub(crate) fn record_hair_update(&self, rec: &gen_gpu::Recorder<'_>, k: usize) {
        let staged = self.staged.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((h, update)) = staged.get(k) {
            self.hairs[*h].record_update(rec, update);
        }
    }

    /// Brings the hair of the characters with `key` up to date with an edit of its asset
    /// ([`hairmesh::asset::HairAsset::move_vertices`]): only the changed texels and bundle
    /// entries are staged, and the next frame copies them in its first passes (`update hair
    /// …`, in the graph) and renders new shadow maps and volumes for that hair alone. The
    /// asset is the edited one (its style merged as the scene's instance holds it); the report
    /// says what will be sent.
    pub fn update_hair(
        &mut self,
        ctx: &Context,
        key: &str,
        asset: &hairmesh::asset::HairAsset,
        change: &hairmesh::asset::AssetChange,
    ) -> Result<gen_gpu::HairUpdate, RenderError> {
        let Some(&h) = self.hair_keys.get(key) else {
            return Err(RenderError::UnknownHair { key: key.to_owned() });
        };
        let update = self.hairs[h].stage_update(ctx, asset, change)?;
        let report = update.report;
        self.staged.lock().unwrap_or_else(|e| e.into_inner()).push((h, update));
        Ok(report)
    }

    /// Plans a frame seen through `view`: the passes the scene's effects ask for, in order,
    /// with what each reads and writes.
    pub fn plan(&self, view: FrameView) -> FramePlan {
        let mut g: FrameGraph<ScenePass> = FrameGraph::default();
        let effects = self.scene.scene.effects;
        let msaa = self.oit.is_none() && effects.msaa > 1;
        let (color, depth) = if msaa {
            (g.image(format!("colour ×{}", effects.msaa)), g.image(format!("depth ×{}", effects.msaa)))
        } else {
            (g.image("colour"), g.image("depth"))
        };
        let resolve = msaa.then(|| (g.image("colour (resolved)"), g.image("depth (resolved)")));
        let readback = g.buffer("image");
        let lights = g.buffer("lights");
        let oit_lists = g.buffer("OIT lists");
        let occluder_meshes = g.buffer("occluder meshes");
        let visibility = g.buffer("visibility + coverage");
        let scene_depth = g.buffer("occluder depth (copy)");
        let raster_frame = g.buffer("raster camera + materials");
        let shaded = g.buffer("shaded hair");
        let raster_tiles = g.buffer("occlusion tiles");
        let slot_orders = g.buffer("strand slot orders");
        let strand_marks = g.buffer("strand marks");
        let final_depth = g.buffer("hair depth (last frame)");
        let hair: Vec<Res> = (0..self.hairs.len()).map(|h| g.buffer(format!("hair {h}"))).collect();
        let character_hair: Vec<Res> = self.characters.iter().map(|c| hair[c.hair]).collect();
        let lod = (0..self.characters.len()).map(|i| g.buffer(format!("lod {i}"))).collect();
        let strands = (0..self.characters.len()).map(|i| g.buffer(format!("strands {i}"))).collect();
        let stored: Vec<Res> =
            (0..self.stored_characters.len()).map(|i| g.buffer(format!("stored strands {i}"))).collect();
        let shadow_cached = self.shadows_cached(&view.lod);
        let shadow = self
            .shadow
            .as_ref()
            .map(|_| crate::passes::shadow::declare(self, &mut g, &character_hair, &stored));
        let (volumes, volume_characters) = self.plan_volumes(&mut g, &view);
        let inputs: Vec<FrameInputs> = self
            .characters
            .iter()
            .map(|c| {
                let character = Character { hair: c.hair, transform: c.transform };
                character_inputs(&view.camera, &character, view.width, view.height, view.lod)
            })
            .collect();
        let second_front = self
            .characters
            .iter()
            .zip(&inputs)
            .map(|(c, inputs)| crate::raster::second_front_pays(&self.hairs[c.hair].asset, inputs))
            .collect();
        let ids = FrameIds {
            color,
            depth,
            resolve,
            readback,
            lights,
            oit_lists,
            occluder_meshes,
            visibility,
            scene_depth,
            raster_frame,
            shaded,
            raster_tiles,
            slot_orders,
            strand_marks,
            final_depth,
            hair: character_hair,
            lod,
            strands,
            stored,
            shadow,
            hair_uploads: hair,
            second_front,
            volumes,
        };
        // Staged uploads go first in the frame's first submission: the shadow maps' when they
        // are made this frame (they read the new texels), else the first batch's.
        let first_batch_submission = usize::from(ids.shadow.is_some());
        let upload_submission =
            if ids.shadow.is_some() && !shadow_cached { 0 } else { first_batch_submission };
        crate::passes::upload::plan(self, &mut g, &ids, upload_submission);
        if let Some(s) = &ids.shadow {
            crate::passes::shadow::plan(self, &mut g, &ids, s, shadow_cached);
        }
        let volume_only: Vec<usize> = ids
            .volumes
            .as_ref()
            .map(|v| v.marched.iter().copied().filter(|&i| v.fractions[i] >= 1.0).collect())
            .unwrap_or_default();
        let batches = self.batches(&inputs, &volume_only);
        for (k, batch) in batches.iter().enumerate() {
            let submission = first_batch_submission + k;
            crate::passes::frame_batch(self, &mut g, &ids, batch, submission, k == 0, k + 1 == batches.len());
        }
        FramePlan {
            graph: g,
            ids,
            batches,
            first_batch_submission,
            view,
            inputs,
            shadow_cached,
            volume_characters,
        }
    }

    /// Hair volumes a scene can have: one per uploaded hair, then one per stored-strand set
    /// (the index [`Self::read_volume`] takes).
    pub fn volume_sources(&self) -> usize {
        self.hairs.len() + self.stored.len()
    }

    /// The object-space bounds of volume source `v`.
    pub(crate) fn volume_bounds(&self, v: usize) -> (Vec3, Vec3) {
        match v.checked_sub(self.hairs.len()) {
            None => {
                let (lo, hi) = self.hairs[v].asset.bounds();
                (lo.as_vec3(), hi.as_vec3())
            }
            Some(s) => self.stored[s].bounds,
        }
    }

    /// What volume source `v`'s volume is made from (stored strands never change).
    fn volume_revision(&self, v: usize) -> u64 {
        self.hairs.get(v).map_or(0, GpuHair::revision)
    }

    /// Characters the volume planning numbers: the generated ones, then the stored ones (the
    /// order of the compute rasterizer's materials).
    pub(crate) fn volume_character_count(&self) -> usize {
        self.characters.len() + self.stored_characters.len()
    }

    /// Character `i` in that order, with its volume source ([`Self::volume_sources`]: stored
    /// sets follow the uploaded hairs).
    pub(crate) fn volume_character(&self, i: usize) -> Option<(&SceneCharacter, usize)> {
        match i.checked_sub(self.characters.len()) {
            None => self.characters.get(i).map(|c| (c, c.hair)),
            Some(j) => self.stored_characters.get(j).map(|c| (c, self.hairs.len() + c.hair)),
        }
    }

    /// Every character in that order ([`Self::volume_character`]).
    pub(crate) fn volume_characters(&self) -> impl Iterator<Item = (&SceneCharacter, usize)> {
        (0..self.volume_character_count()).filter_map(|i| self.volume_character(i))
    }

    /// The projected size in pixels in `view` of a character placed at `transform` with volume
    /// source `v`'s hair: the larger side of the screen rectangle of its bounds' corners
    /// (unclipped; infinite when a corner lies behind the near plane, the eye inside the bounds
    /// included).
    pub(crate) fn projected_pixels(&self, transform: Mat4, v: usize, view: &FrameView) -> f32 {
        let (lo, hi) = self.volume_bounds(v);
        let m = crate::camera::view_proj(&view.camera, view.width, view.height) * transform;
        match crate::camera::project_box(m, lo, hi, view.width, view.height) {
            crate::camera::BoxOnScreen::InFront { lo, hi } => (hi - lo).max_element(),
            // Unbounded (or invisible behind the camera): never small enough for a volume.
            crate::camera::BoxOnScreen::Straddling | crate::camera::BoxOnScreen::Behind => f32::INFINITY,
        }
    }

    /// Which characters the frame raymarches (`"volume_lod"`: at most `volume_lod_pixels` on
    /// screen; generated and stored alike, numbered as [`Self::volume_character`]) and each
    /// volume source's volume: the resolution its raymarched characters' sizes
    /// ask for, at least [`crate::volume::AO_RESOLUTION`] with AO or volume shadows; cached when
    /// its region holds a grid at least that fine of the source's current revision.
    fn plan_volumes(
        &self,
        g: &mut FrameGraph<ScenePass>,
        view: &FrameView,
    ) -> (Option<VolumeIds>, Vec<usize>) {
        let Some(volumes) = &self.volumes else { return (None, Vec::new()) };
        let effects = self.scene.scene.effects;
        let max = volumes.store.max_resolution;
        let placed: Vec<(Mat4, usize)> = self.volume_characters().map(|(c, v)| (c.transform, v)).collect();
        let pixels: Vec<f32> = placed.iter().map(|&(t, v)| self.projected_pixels(t, v, view)).collect();
        // A volume is drawn only where its voxels are at most about two pixels: never beyond
        // twice the resolution the scene's volumes get (lowered when many hairs share the
        // buffers).
        let threshold = effects.volume_lod_pixels.min(2.0 * max as f32);
        let mut fractions: Vec<f32> = pixels
            .iter()
            .map(|&p| match (effects.volume_lod, self.volumes_everywhere) {
                (false, _) => 0.0,
                (true, true) => 1.0,
                (true, false) => crate::volume::volume_fraction(p, threshold),
            })
            .collect();
        let marched: Vec<usize> = (0..placed.len()).filter(|&i| fractions[i] > 0.0).collect();
        let cache = volumes.cache.lock().unwrap_or_else(|e| e.into_inner());
        let cache_plan = |v: usize, want: Option<u32>| -> Option<HairVolumePlan> {
            let want = want?;
            let revision = self.volume_revision(v);
            // A cached grid at least this fine serves (a character moving away does not
            // re-voxelize its hair; one coming closer does, once per octave).
            if let Some((grid, r)) = cache[v]
                && r == revision
                && grid.resolution >= want
            {
                return Some(HairVolumePlan { grid, cached: true });
            }
            let (lo, hi) = self.volume_bounds(v);
            let grid = VolumeGrid::around(lo, hi, want)?;
            // A grid beyond its region (never, for a resolution within the store's) is skipped.
            if grid.voxels() > volumes.store.regions[v].1 {
                return None;
            }
            Some(HairVolumePlan { grid, cached: false })
        };
        let hairs = (0..self.volume_sources())
            .map(|v| {
                let mut want: Option<u32> = None;
                for (i, _) in placed.iter().enumerate().filter(|(_, p)| p.1 == v) {
                    if marched.contains(&i) {
                        let r = crate::volume::resolution_for_pixels(pixels[i], max);
                        want = Some(want.map_or(r, |w| w.max(r)));
                    }
                    if effects.ao || effects.volume_shadows {
                        let r = crate::volume::AO_RESOLUTION.min(max);
                        want = Some(want.map_or(r, |w| w.max(r)));
                    }
                }
                cache_plan(v, want)
            })
            .collect::<Vec<_>>();
        // Characters whose hair got no volume (an unfinite box) keep their strands.
        let marched: Vec<usize> = marched.into_iter().filter(|&i| hairs[placed[i].1].is_some()).collect();
        for (i, f) in fractions.iter_mut().enumerate() {
            if !marched.contains(&i) {
                *f = 0.0;
            }
        }
        let ids = VolumeIds {
            marched: marched.clone(),
            fractions,
            volume: g.buffer("hair volumes"),
            ao: g.buffer("hair volumes: AO"),
            bricks: g.buffer("hair volumes: bricks"),
            lod: (0..self.hairs.len()).map(|h| g.buffer(format!("voxelize lod {h}"))).collect(),
            sums: (0..self.volume_sources()).map(|v| g.buffer(format!("voxel sums {v}"))).collect(),
            hairs,
        };
        (Some(ids), marched)
    }

    /// Characters in batches whose strand buffers fit `batch_bytes`, so a crowd never holds
    /// every character's strands at once (at least one character per batch; one empty batch
    /// when there are none).
    fn batches(&self, inputs: &[FrameInputs], volume_characters: &[usize]) -> Vec<Vec<usize>> {
        let mut batches: Vec<Vec<usize>> = vec![Vec::new()];
        let mut batch_bytes = 0;
        for (i, (c, inputs)) in self.characters.iter().zip(inputs).enumerate() {
            if volume_characters.contains(&i) {
                continue;
            }
            // Fused generation holds no strand buffer.
            let bytes = if self.compute_raster.is_some() {
                0
            } else {
                Generator::frame_bytes(&self.hairs[c.hair], inputs)
            };
            if batch_bytes + bytes > self.batch_bytes && batches.last().is_some_and(|b| !b.is_empty()) {
                batches.push(Vec::new());
                batch_bytes = 0;
            }
            batch_bytes += bytes;
            if let Some(b) = batches.last_mut() {
                b.push(i);
            }
        }
        batches
    }

    pub(crate) fn shading(&self, c: &SceneCharacter, eye: Vec3) -> Shading {
        Shading {
            model: c.transform.to_cols_array(),
            eye: eye.extend(self.scene.lights().len() as f32).to_array(),
            hair_color: Vec4::new(c.color[0], c.color[1], c.color[2], c.variation).to_array(),
            specular_shift: [-0.08, 0.12, 80.0, 12.0],
            specular_strength: [0.25, 0.35, 0.2, 0.6],
            // Opaque mode draws strands solid (coverage aside); OIT lets a strand transmit.
            hair_opacity: [if self.oit.is_some() { 0.7 } else { 1.0 }, 0.0, 0.0, 0.0],
            volume_box: [0.0; 4],
            volume_grid: [0; 4],
            volume_info: [0; 4],
        }
    }

    /// The triangle raster's part of AO and volume shadows: volume source `v`'s volume this
    /// frame into a character's shading constants.
    pub(crate) fn volume_shading(&self, plan: &FramePlan, v: usize, s: &mut Shading) {
        let flags = self.scene.scene.effects.volume_flags();
        let (Some(volumes), Some(ids)) = (&self.volumes, &plan.ids.volumes) else { return };
        if let (Some(Some(p)), true) = (ids.hairs.get(v), flags != 0) {
            let address = volumes.store.address(v, &p.grid);
            s.volume_box = p.grid.origin.extend(1.0 / p.grid.voxel).to_array();
            s.volume_grid = address.dims;
            s.volume_info = [address.first_brick, flags, 0, 0];
        }
    }

    /// The lights buffer of `lighting.glsl`: every light, with its shadow maps' place.
    fn light_data(&self, atlas: Option<&ShadowAtlas>) -> Vec<GpuLight> {
        let shadow_lights = self.scene.shadow_lights();
        self.scene
            .lights()
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let vector = match *l {
                    Light::Directional { direction, .. } => {
                        Vec3::from_array(direction).normalize().extend(0.0)
                    }
                    Light::Point { position, .. } => Vec3::from_array(position).extend(1.0),
                };
                let shadow = atlas.and_then(|a| {
                    shadow_lights.iter().position(|&s| s == i).and_then(|k| a.lights.get(k)).map(|ls| (a, ls))
                });
                let (view_proj, layer_ends, map, depth) = match shadow {
                    Some((a, ls)) => (
                        ls.light_view_proj,
                        [ls.layer_ends[0], ls.layer_ends[1], ls.layer_ends[2], 0.0],
                        [a.size as f32, ls.first_texel as f32, ls.occluder_bias, 0.0],
                        ls.depth_params,
                    ),
                    None => (Mat4::IDENTITY, [0.0; 4], [0.0; 4], [0.0; 4]),
                };
                let [r, g, b] = l.color();
                let casts = matches!(
                    l,
                    Light::Directional { cast_shadows: true, .. } | Light::Point { cast_shadows: true, .. }
                );
                // w: the hair's volume shadows it from this light (`light_volume_shadows`).
                let volume_shadows = self.scene.scene.effects.volume_shadows && casts;
                let depth = [depth[0], depth[1], depth[2], if volume_shadows { 1.0 } else { 0.0 }];
                GpuLight {
                    vector: vector.to_array(),
                    color: [r, g, b, 0.0],
                    view_proj: view_proj.to_cols_array(),
                    layer_ends,
                    map,
                    depth,
                }
            })
            .collect()
    }

    /// `raster hair (compute, opaque)` / `(…, blended)` on the triangle raster; on the compute
    /// rasterizer `raster hair (compute raster, …)` with what its kernels draw: `fused
    /// generation`, `stored strands` or both, and `straight lines` where the fused kernel draws
    /// them ([`Self::with_fused_strands`]).
    pub(crate) fn raster_pass_name(&self) -> String {
        if self.compute_raster.is_some() {
            let generated = self.slots.iter().any(|s| !s.stored);
            let stored = self.slots.iter().any(|s| s.stored);
            let drawn = match (generated, stored) {
                (true, true) => "fused generation + stored strands",
                (false, true) => "stored strands",
                _ => "fused generation",
            };
            let straight = match self.fused_strands {
                FusedStrands::Straight if generated => ", straight lines",
                _ => "",
            };
            return format!("raster hair (compute raster, {drawn}{straight})");
        }
        let mode = if self.depth_prepass.is_some() { "blended" } else { "opaque" };
        format!("raster hair ({}, {mode})", self.path)
    }

    /// Whether one of `c`'s strands can be a pixel wide in `view`: its widest strand at the
    /// nearest point of its bounds (conservative; strand LOD widening does not count, as the
    /// prepass tests each real strand's coverage). Blended mode's depth prepass draws only
    /// such characters — in a crowd, the far ones have no fragment that could write depth.
    pub(crate) fn may_cover_pixels(&self, c: &SceneCharacter, view: &FrameView) -> bool {
        let asset = &self.hairs[c.hair].asset;
        let (lo, hi) = asset.bounds();
        let (wlo, whi) = transformed_box(c.transform, (lo.as_vec3(), hi.as_vec3()));
        let eye = view.camera.eye;
        let distance = eye.distance(eye.clamp(wlo, whi));
        let scale = (0..3).map(|i| c.transform.col(i).truncate().length()).fold(0.0f32, f32::max);
        let style = &asset.style;
        let width = (style.width * style.tip_width.max(1.0)) as f32 * scale;
        let pixels = width * view.height as f32 / (2.0 * distance * (0.5 * view.camera.fov_y).tan());
        // Half a pixel of margin for the strip's own projection (it is measured per vertex); a
        // NaN (eye on the bounds) keeps the draw.
        pixels.is_nan() || pixels >= 0.5
    }

    /// Renders one frame.
    pub fn render(&self, ctx: &Context) -> Result<RenderedFrame, RenderError> {
        self.render_from(ctx, Vec3::from_array(self.scene.scene.camera.eye))
    }

    /// Renders one frame with the camera at `eye` (looking at the scene's target). Shadow maps
    /// do not depend on the camera and stay cached.
    pub fn render_from(&self, ctx: &Context, eye: Vec3) -> Result<RenderedFrame, RenderError> {
        self.render_camera(ctx, eye, Vec3::from_array(self.scene.scene.camera.target))
    }

    /// Renders one frame from a camera at `eye` looking at `target` (e.g. a point of the
    /// scene's camera path, [`LoadedScene::camera_at`]): plans its graph and runs it.
    pub fn render_camera(
        &self,
        ctx: &Context,
        eye: Vec3,
        target: Vec3,
    ) -> Result<RenderedFrame, RenderError> {
        self.render_view(ctx, self.view_from(eye, target))
    }

    /// Renders one frame seen through `view` ([`Self::frame_view`]): plans its graph and runs it.
    /// A view larger than the scene's output is refused (the renderer's per-pixel buffers and
    /// rasterizer choice were sized for the output).
    pub fn render_view(&self, ctx: &Context, view: FrameView) -> Result<RenderedFrame, RenderError> {
        let output = self.scene.scene.output;
        if view.width == 0 || view.height == 0 || view.width > output.width || view.height > output.height {
            return Err(RenderError::InvalidView {
                why: format!(
                    "{}×{} is empty or larger than the scene's {}×{} output",
                    view.width, view.height, output.width, output.height
                ),
            });
        }
        let plan = self.plan(view);
        let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        let mut run = GraphRun::new(&plan.graph);
        let mut timings = FrameTimings::default();
        // Shadow maps: rendered by their own submission on the first frame, then reused.
        let mut shadow_cache = self.shadow_cache.lock().unwrap_or_else(|e| e.into_inner());
        let mut shadow_ms = None;
        if let (Some(ids), false) = (&plan.ids.shadow, plan.shadow_cached) {
            let shadow = crate::passes::shadow::prepare(self, ctx, &plan)?;
            let images = shadow.images(ids);
            let ((), t) = ctx.submit("shadow maps", |rec| {
                run.record_submission(rec, 0, &|r| images.get(&r).copied(), |rec, pass, run| {
                    match pass.payload {
                        ScenePass::UpdateHair(k) => crate::passes::upload::record(self, rec, k),
                        _ => crate::passes::shadow::record(self, rec, pass, &shadow, run),
                    }
                })
            })?;
            shadow_ms = t.pass_ms("shadow maps");
            timings.passes.extend(t.passes);
            timings.cpu_wait_ms += t.cpu_wait_ms;
            *shadow_cache = Some((self.content_version(), plan.view.lod, shadow.into_atlas()));
        }
        let atlas = shadow_cache.as_ref().map(|(_, _, atlas)| atlas);
        let view = plan.view;
        let light_data = self.light_data(atlas);
        let light_bytes: &[u8] = bytemuck::cast_slice(&light_data);
        let mut lights = pool.buffer(
            ctx,
            "scene lights",
            BufferDesc::storage(light_bytes.len().max(16) as u64).location(MemoryLocation::CpuToGpu),
        )?;
        match lights.mapped_mut() {
            Some(m) => m[..light_bytes.len()].copy_from_slice(light_bytes),
            None => {
                lights = ctx.create_buffer_with_data(
                    "scene lights",
                    BufferDesc::storage(light_bytes.len() as u64),
                    light_bytes,
                )?;
            }
        }
        let lighting: [(u32, &Buffer); 4] = match atlas {
            Some(a) => [
                (binding::SHADOW_DEPTH, &a.depth),
                (binding::SHADOW_OPACITY, &a.opacity),
                (binding::LIGHTS, &lights),
                (binding::OCCLUDER_DEPTH, &a.occluder_depth),
            ],
            None => [
                (binding::SHADOW_DEPTH, &self.no_shadow[0]),
                (binding::SHADOW_OPACITY, &self.no_shadow[1]),
                (binding::LIGHTS, &lights),
                (binding::OCCLUDER_DEPTH, &self.no_shadow[2]),
            ],
        };
        let stored_params = self
            .stored_characters
            .iter()
            .map(|c| {
                let character = Character { hair: c.hair, transform: c.transform };
                let inputs = character_inputs(&view.camera, &character, view.width, view.height, view.lod);
                // Every hair generator shares the parameter layout.
                self.stored[c.hair].frame_params(ctx, &inputs)
            })
            .collect::<gen_gpu::Result<Vec<_>>>()?;
        let samples = if self.oit.is_some() || self.compute_raster.is_some() {
            1
        } else {
            self.scene.scene.effects.msaa
        };
        let scene_target = SceneTarget::new(ctx, &mut pool, view.width, view.height, samples)?;
        // The OIT node pool is bounded by the output size (`oit_nodes_per_pixel`) and by the
        // storage-buffer range, or where the device has buffer device addresses (the kernels
        // then reach the pool through one) by OIT_POOL_BYTES.
        // (The compute rasterizer keeps its own K nearest fragments per pixel.)
        let oit_buffers = match (&self.oit, &self.compute_raster) {
            (Some(oit), None) => {
                let pixels = u64::from(view.width) * u64::from(view.height);
                let referenced = self.buffer_references && ctx.capabilities().buffer_device_address;
                let pool_bytes = if referenced {
                    OIT_POOL_BYTES
                } else {
                    u64::from(ctx.capabilities().max_storage_buffer_range)
                };
                let pool_nodes = ((pixels as f64 * f64::from(oit.nodes_per_pixel)) as u64)
                    .clamp(1, (pool_bytes / OIT_NODE_BYTES).min(u64::from(u32::MAX - 1)));
                // The overflow tail when its words fit one storage buffer (not at 4K on lavapipe's
                // 128 MiB: there a full pool drops fragments, counted).
                let fits =
                    pixels * 4 * OIT_PIXEL_WORDS <= u64::from(ctx.capabilities().max_storage_buffer_range);
                let pixel_words = if fits { OIT_PIXEL_WORDS } else { 1 };
                let nodes =
                    pool.buffer(ctx, "OIT nodes", BufferDesc::storage(pool_nodes * OIT_NODE_BYTES))?;
                Some(OitBuffers {
                    heads: pool.buffer(ctx, "OIT heads", BufferDesc::storage(pixels * 4 * pixel_words))?,
                    nodes_address: self.load_address(&nodes),
                    nodes,
                    counters: pool.buffer(ctx, "OIT counters", BufferDesc::storage(32))?,
                    pool: pool_nodes,
                    pixel_words: pixel_words as u32,
                })
            }
            _ => None,
        };
        let raster_buffers = match &self.compute_raster {
            Some(cr) => {
                let boxes = self
                    .characters
                    .iter()
                    .map(|c| {
                        let (lo, hi) = self.hairs[c.hair].asset.bounds();
                        (c.transform, (lo.as_vec3(), hi.as_vec3()))
                    })
                    .chain(self.stored_characters.iter().map(|c| (c.transform, self.stored[c.hair].bounds)));
                let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
                let rect = crate::raster::screen_rect(view_proj, view.width, view.height, boxes);
                let materials = self.frame_materials(&plan);
                let desc = crate::raster::RasterFrameDesc {
                    view: &view,
                    materials: &materials,
                    light_count: self.scene.lights().len(),
                    occluders: !self.occluders.is_empty(),
                    rect,
                    // What the kernels were specialized for (ComputeRaster::new): one storage
                    // buffer holds that many at the output size, so at any view's.
                    k: cr.slots().unwrap_or_else(|| self.frame_slots(ctx)),
                };
                let buffers = RasterBuffers::new(ctx, &mut pool, &desc)?;
                if let Some(expected) = cr.slots().filter(|&k| k != buffers.k) {
                    let k = buffers.k;
                    buffers.give_back(&mut pool);
                    return Err(RenderError::InvalidView {
                        why: format!(
                            "its pixel buffers hold {k} slots, not the {expected} the kernels expect"
                        ),
                    });
                }
                Some(buffers)
            }
            None => None,
        };
        let volume_frame = self.volume_frame(ctx, &mut pool, &plan, raster_buffers.as_ref())?;
        let stand_in = &self.no_shadow[0];
        let volume_buffers = match &self.volumes {
            Some(v) => [
                (binding::VOLUME, &v.store.volume),
                (binding::VOLUME_AO, &v.store.ao),
                (binding::VOLUME_BRICKS, &v.store.bricks),
            ],
            None => [
                (binding::VOLUME, stand_in),
                (binding::VOLUME_AO, stand_in),
                (binding::VOLUME_BRICKS, stand_in),
            ],
        };
        let mut images: HashMap<Res, &Image> = HashMap::new();
        images.insert(plan.ids.color, &scene_target.color);
        images.insert(plan.ids.depth, &scene_target.depth);
        if let (Some((c, d)), Some((ci, di))) = (plan.ids.resolve, &scene_target.resolve) {
            images.insert(c, ci);
            images.insert(d, di);
        }
        let mut stats = GenerationStats::default();
        // Stored characters drawn by their volume alone rasterize no strand.
        let n = self.characters.len();
        stats.strands += (self.stored_characters.iter().enumerate())
            .filter(|&(j, _)| plan.volume_fraction(n + j) < 1.0)
            .map(|(_, c)| self.stored[c.hair].strands)
            .sum::<u64>();
        // The compute rasterizer's history: the last frame's depths, each character's marks.
        let mut slot_history = self.slot_history.lock().unwrap_or_else(|e| e.into_inner());
        let ordered = self.raster_slot_order();
        if ordered {
            let capacities: Vec<u64> =
                self.characters.iter().map(|c| self.hairs[c.hair].total_strands().max(1)).collect();
            slot_history.prepare(ctx, view.width, view.height, &capacities)?;
        }
        let marking = ordered && slot_history.marking();
        let mut drawn = vec![false; self.characters.len()];
        let batch_count = plan.batches.len();
        for (k, batch) in plan.batches.iter().enumerate() {
            let frames = batch
                .iter()
                .map(|&i| {
                    let hair = &self.hairs[self.characters[i].hair];
                    let frame = if self.compute_raster.is_some() {
                        self.generator.prepare_fused(ctx, hair, &plan.inputs[i])?
                    } else {
                        self.generator.prepare(ctx, hair, &plan.inputs[i])?
                    };
                    Ok((i, frame))
                })
                .collect::<gen_gpu::Result<Vec<_>>>()?;
            let last = k + 1 == batch_count;
            for (i, _) in &frames {
                drawn[*i] = true;
            }
            let state = FrameState {
                plan: &plan,
                target: &scene_target,
                lighting,
                oit: oit_buffers.as_ref(),
                raster: raster_buffers.as_ref(),
                materials: &self.character_materials,
                frames: &frames,
                slot_history: self.compute_raster.as_ref().map(|_| &*slot_history),
                stored_params: if last { &stored_params } else { &[] },
                volumes: if k == 0 { volume_frame.as_ref() } else { None },
                volume_buffers,
            };
            let submission = plan.first_batch_submission + k;
            let ((), t) = ctx.submit("scene frame", |rec| {
                run.record_submission(rec, submission, &|r| images.get(&r).copied(), |rec, pass, run| {
                    crate::passes::record(self, rec, pass, &state, run)
                })
            })?;
            timings.passes.extend(t.passes);
            timings.cpu_wait_ms += t.cpu_wait_ms;
            for (i, frame) in &frames {
                stats += self.generator.stats(ctx, &self.hairs[self.characters[*i].hair], frame)?;
            }
        }
        // What the next frame orders by: this frame's depths (the shade pass wrote them), and
        // the marks of the characters this frame drew with marking on.
        if ordered && raster_buffers.is_some() {
            if let Some((_, _, _, written)) = &mut slot_history.final_depth {
                *written = true;
            }
            for (character, &drawn) in slot_history.characters.iter_mut().zip(&drawn) {
                if let Some(c) = character {
                    c.history = drawn && marking;
                }
            }
        }
        drop(slot_history);
        // Every submission has completed: the staged updates are in the textures.
        self.staged.lock().unwrap_or_else(|e| e.into_inner()).clear();
        let (oit_overflow, oit_pool) = match &oit_buffers {
            Some(b) => {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&b.counters, 16)?);
                (Some(u64::from(c[2])), Some(b.pool))
            }
            None => (None, None),
        };
        let (raster_overflow, raster_slots) = match &raster_buffers {
            Some(b) => {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&b.counters, 16)?);
                (Some(u64::from(c[0])), Some(b.k))
            }
            None => (None, None),
        };
        // Without occluders the compute rasterizer's resolve writes only the hair's rectangle
        // (passes/compute_raster.rs record_resolve).
        let only = match &raster_buffers {
            Some(b) if !crate::passes::compute_raster::resolves_over_occluders(self) => {
                Some((b.rect, self.scene.scene.output.background))
            }
            _ => None,
        };
        let linear = scene_target.read(ctx, only)?;
        let passes = run.ran;
        // Every submission has waited for its fence: the transient resources can be reused.
        scene_target.give_back(&mut pool);
        if let Some(b) = oit_buffers {
            pool.give_back_buffer(b.heads);
            pool.give_back_buffer(b.nodes);
            pool.give_back_buffer(b.counters);
        }
        if lights.mapped().is_some() {
            pool.give_back_buffer(lights);
        }
        if let Some(b) = raster_buffers {
            b.give_back(&mut pool);
        }
        let mut volumes_voxelized = 0;
        if let (Some(volumes), Some(vf)) = (&self.volumes, volume_frame) {
            let mut cache = volumes.cache.lock().unwrap_or_else(|e| e.into_inner());
            for (h, hv) in vf.hairs.into_iter().enumerate() {
                if let Some(hv) = hv {
                    cache[h] = Some((hv.grid, self.volume_revision(h)));
                    pool.give_back_buffer(hv.sums);
                    volumes_voxelized += 1;
                }
            }
        }
        Ok(RenderedFrame {
            image: linear.to_srgb8(),
            linear,
            timings,
            stats,
            passes,
            graph: plan.graph.outline(),
            oit_overflow,
            oit_pool,
            raster_overflow,
            raster_slots,
            volume_characters: plan.volume_characters.len(),
            volume_fractions: (0..self.volume_character_count()).map(|i| plan.volume_fraction(i)).collect(),
            volumes_voxelized,
            shadow_cached: plan.shadow_cached,
            shadow_ms,
        })
    }

    /// The compute rasterizer's materials for a frame: with AO each names its character's volume
    /// (grid and placement).
    fn frame_materials(&self, plan: &FramePlan) -> Vec<RasterMaterial> {
        let mut materials = self.raster_materials.clone();
        let flags = self.scene.scene.effects.volume_flags();
        let (Some(volumes), Some(ids), true) = (&self.volumes, &plan.ids.volumes, flags != 0) else {
            return materials;
        };
        // Generated characters, then stored ones, as the materials are numbered.
        for ((c, v), &m) in self.volume_characters().zip(&self.character_materials) {
            if let (Some(Some(p)), Some(material)) = (ids.hairs.get(v), materials.get_mut(m as usize)) {
                let address = volumes.store.address(v, &p.grid);
                material.world_to_voxel = p.grid.world_to_voxel(c.transform).to_cols_array();
                material.volume = address.dims;
                material.volume_info = [address.first_brick, flags, 0, 0];
            }
        }
        materials
    }

    /// The frame's voxelizations (LOD and generation inputs: `volume::voxelization_inputs`, no
    /// culling; a sums buffer each) and raymarches.
    fn volume_frame(
        &self,
        ctx: &Context,
        pool: &mut TransientPool,
        plan: &FramePlan,
        raster: Option<&RasterBuffers>,
    ) -> Result<Option<VolumeFrame>, RenderError> {
        let (Some(volumes), Some(ids)) = (&self.volumes, &plan.ids.volumes) else {
            return Ok(None);
        };
        let view = &plan.view;
        let mut frame = VolumeFrame::default();
        for (h, p) in ids.hairs.iter().enumerate() {
            let voxelize = match p {
                Some(p) if !p.cached => {
                    let source = match h.checked_sub(self.hairs.len()) {
                        None => {
                            let hair = &self.hairs[h];
                            let inputs = crate::volume::voxelization_inputs(&hair.asset, p.grid.resolution);
                            VoxelSource::Generated(Box::new(
                                self.generator.prepare_fused(ctx, hair, &inputs)?,
                            ))
                        }
                        Some(s) => {
                            // Stored strands have no LOD: the parameters only place the camera.
                            let character = Character { hair: s, transform: Mat4::IDENTITY };
                            let inputs =
                                character_inputs(&view.camera, &character, view.width, view.height, view.lod);
                            VoxelSource::Stored(s, self.stored[s].frame_params(ctx, &inputs)?)
                        }
                    };
                    let sums = pool.buffer(
                        ctx,
                        "voxel sums",
                        BufferDesc::storage(p.grid.voxels() * crate::volume::SUM_VOXEL_BYTES)
                            .usage(vk::BufferUsageFlags::TRANSFER_DST),
                    )?;
                    Some(HairVolumeFrame {
                        grid: p.grid,
                        address: volumes.store.address(h, &p.grid),
                        source,
                        sums,
                    })
                }
                _ => None,
            };
            frame.hairs.push(voxelize);
        }
        // The raymarches write into the compute rasterizer's visibility buffer.
        let Some(raster) = raster else { return Ok(Some(frame)) };
        let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
        for &i in &plan.volume_characters {
            let Some((c, v)) = self.volume_character(i) else { continue };
            let Some(Some(p)) = ids.hairs.get(v) else { continue };
            let address = volumes.store.address(v, &p.grid);
            let material = self.character_materials.get(i).copied().unwrap_or(0);
            let flags = u32::from(!self.occluders.is_empty());
            frame.marches.push(MarchJob {
                character: i,
                push: crate::volume::MarchPush {
                    world_to_voxel: p.grid.world_to_voxel(c.transform).to_cols_array(),
                    dims: address.dims,
                    rect: crate::volume::march_rect(view_proj, view.width, view.height, c.transform, &p.grid),
                    info: [material, raster.k, flags, volumes.opacity.to_bits()],
                    extra: [address.first_brick, plan.volume_fraction(i).to_bits(), 0, 0],
                },
            });
        }
        Ok(Some(frame))
    }

    /// Reads hair `hair`'s volume back (`None` before a frame voxelized it): for tests and
    /// inspection.
    pub fn read_volume(
        &self,
        ctx: &Context,
        hair: usize,
    ) -> Result<Option<crate::volume::VolumeReadback>, RenderError> {
        let Some(volumes) = &self.volumes else { return Ok(None) };
        let cached = volumes.cache.lock().unwrap_or_else(|e| e.into_inner()).get(hair).copied().flatten();
        let Some((grid, _)) = cached else { return Ok(None) };
        let (first, _) = volumes.store.regions[hair];
        let end = first + grid.voxels();
        let all: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(
            &ctx.read_buffer(&volumes.store.volume, end * crate::volume::VOLUME_VOXEL_BYTES)?,
        );
        let ao: Vec<f32> = bytemuck::pod_collect_to_vec(
            &ctx.read_buffer(&volumes.store.ao, end * crate::volume::AO_VOXEL_BYTES)?,
        );
        let (first_brick, _) = volumes.store.brick_regions[hair];
        let brick_end = first_brick + grid.bricks();
        let bricks: Vec<u32> =
            bytemuck::pod_collect_to_vec(&ctx.read_buffer(&volumes.store.bricks, brick_end * 4)?);
        Ok(Some(crate::volume::VolumeReadback {
            grid,
            volume: all[first as usize..end as usize].to_vec(),
            ao: ao[first as usize..end as usize].to_vec(),
            bricks: bricks[first_brick as usize..brick_end as usize].to_vec(),
        }))
    }

    /// Resources the pool has created so far (a steady scene stops creating after its first
    /// frame).
    pub fn transient_resources_created(&self) -> usize {
        self.pool.lock().unwrap_or_else(|e| e.into_inner()).created
    }
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
