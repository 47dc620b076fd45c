//! On-the-fly strand generation: the compute path (LOD pass, prefix sum, generation pass,
//! vertex pulling) and the mesh path (task + mesh shaders), both from `hair_gen.glsl`.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use gen_gpu::{Context, ContextDesc, Filtering, FrameInputs, GenerationPath, Generator, GpuHair, TexturePrecision};
//! let ctx = Context::new(&ContextDesc::default())?;
//! # let asset: hairmesh::asset::HairAsset = todo!();
//! let hair = GpuHair::upload(&ctx, &asset, TexturePrecision::Auto)?;
//! let generator = Generator::new(&ctx, Filtering::Hardware)?;
//! let inputs = FrameInputs::looking_at(&asset, glam::Vec3::new(0.0, 1.7, 0.6), 256, 256);
//! let capture = generator.capture(&ctx, &hair, &inputs, GenerationPath::Compute)?;
//! println!("{} strands generated", capture.strands.len());
//! # Ok(()) }
//! ```

use ash::vk;
use glam::{Mat4, Vec3};
use hairmesh::asset::HairAsset;
use hairmesh::reference::{LodParams, Projection, ViewParams, bundle_lod};

use crate::{
    Binding, Buffer, BufferDesc, ComputePipelineDesc, Context, FrameTimings, GenerationPath, GpuError,
    GpuHair, GraphicsPipelineDesc, GraphicsStages, MemoryLocation, Pipeline, Recorder, Result, shaders,
};

/// How generation reads the textures (specialization constants 0 and 3 of `hair_gen.glsl`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Filtering {
    /// Per strand: the workgroup blends the four texels of the strand's cell in every slice
    /// once (texelFetch + f32 lerps) and evaluates every vertex from those values in shared
    /// memory — about `4·((1 + 3L) + 2·(L + 1))` texel reads per strand (the curve slices serve
    /// the strand and its bundle centre; a quarter of that where a subgroup fetches together)
    /// instead of six trilinear fetches per vertex. Strands of fewer than 17 vertices (vertex levels below 4,
    /// where a mesh workgroup draws several) sample per vertex, filtering manually (the same
    /// f32 lerps), on both paths.
    #[default]
    StrandCoherent,
    /// Per vertex, hardware trilinear filtering (its sub-texel weights are quantized).
    Hardware,
    /// Per vertex, texelFetch + f32 lerps (the reference the coherent variant matches).
    Manual,
}

/// A fragment stage for strand strips, supplied by the renderer. It reads locations 0–2 (see
/// `StrandVaryings` in `hair_gen.glsl`: object-space position and strand parameter, tangent and
/// per-strand random, coverage and strip side) and its push constants start at byte
/// [`FRAGMENT_PUSH_OFFSET`].
#[derive(Clone, Copy, Debug)]
pub struct FragmentStage {
    pub shader: &'static shader_build::ShaderSpirv,
    pub push_constant_bytes: u32,
    pub blend: crate::Blend,
    /// Depth writes (the depth test stays on).
    pub depth_write: bool,
    /// The depth test (`LESS`; `LESS_OR_EQUAL` to redraw strands over their own depth prepass).
    pub depth_compare: vk::CompareOp,
    /// Colour writes (off for a fill pass that only appends to buffers).
    pub color_write: bool,
    /// Storage buffers of its own, at bindings 12 and up of set 0.
    pub extra_bindings: &'static [u32],
    /// A specialization constant of its own `(constant_id, value)`, the id at
    /// [`crate::contract::FIRST_CONSUMER_CONSTANT_ID`] or above (render: the scene's light
    /// count).
    pub specialization: Option<(u32, u32)>,
}

/// What a renderer adds to a strand draw: its fragment stage's push constants and buffers.
#[derive(Clone, Copy, Debug, Default)]
pub struct DrawExtras<'a> {
    pub fragment_constants: &'a [u8],
    pub buffers: &'a [(u32, &'a Buffer)],
}

pub use crate::contract::FRAGMENT_PUSH_OFFSET;

/// Pipeline variants (specialization constants of `hair_gen.glsl`) and the fragment stage.
#[derive(Clone, Copy, Debug, Default)]
pub struct GeneratorOptions {
    pub filtering: Filtering,
    /// Evaluate the exact cubic between layers instead of two quadratics (accuracy benchmark).
    pub exact_cubic: bool,
    /// Caps the strand slots per chunk below what the storage-buffer range allows (tests use
    /// it to exercise chunking with few strands). Rounded down to the alignment step.
    pub max_chunk_slots: Option<u64>,
    /// The fragment stage; `None` uses gen-gpu's placeholder shading (`strand.frag`).
    pub fragment: Option<FragmentStage>,
    /// Colour attachment format of the draws [default: [`COLOR_FORMAT`]].
    pub color_format: Option<vk::Format>,
    /// Rasterization samples of the draws (0 or 1 = no MSAA).
    pub samples: u32,
    /// The generate pass stores each vertex as two `vec4`s even where the device has
    /// `shaderInt64`, where by default it stores the same bytes as one `u64vec4`
    /// ([`Generator::int64_vertex_stores`]; tests compare the two).
    pub vec4_vertex_stores: bool,
}

/// What one frame generates for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameInputs {
    /// Object space → clip space (Vulkan clip: z ∈ [0, w]).
    pub view_proj: Mat4,
    /// Camera for LOD, in object space (f64, as the CPU reference takes it).
    pub view: ViewParams,
    pub lod: LodParams,
    pub viewport: [u32; 2],
    /// Frustum-cull bundles against `view_proj` (on by default).
    pub cull: bool,
}

/// The view matrix (right-handed) of an eye at `eye` looking at `target`, with world +Y up on
/// screen. Looking straight up or down, +Y is the viewing direction and cannot be "up": then
/// the screen's up is −Z looking down and +Z looking up (a top view with −Z at the top, as a
/// map). `eye == target` looks down −Z.
pub fn view_matrix(eye: Vec3, target: Vec3) -> Mat4 {
    let forward = (target - eye).try_normalize().unwrap_or(Vec3::NEG_Z);
    let up = if forward.cross(Vec3::Y).length_squared() > 1e-8 {
        Vec3::Y
    } else {
        Vec3::new(0.0, 0.0, -forward.y.signum())
    };
    Mat4::look_to_rh(eye, forward, up)
}

impl FrameInputs {
    /// A perspective camera at `eye` looking at the asset's centre (45° vertical field of view).
    pub fn looking_at(asset: &HairAsset, eye: Vec3, width: u32, height: u32) -> Self {
        let (lo, hi) = asset.bounds();
        let centre = (0.5 * (lo + hi)).as_vec3();
        let fov_y = 45f32.to_radians();
        let far = (eye.distance(centre) + (hi - lo).length() as f32) * 2.0;
        let proj = Mat4::perspective_rh(fov_y, width as f32 / height.max(1) as f32, far * 1e-4, far);
        // Vulkan's y points down in clip space.
        let flip = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
        let view = view_matrix(eye, centre);
        Self {
            view_proj: flip * proj * view,
            view: ViewParams {
                eye: eye.as_dvec3(),
                vertical_resolution: f64::from(height),
                projection: Projection::Perspective { fov_y: f64::from(fov_y) },
            },
            lod: LodParams::default(),
            viewport: [width, height],
            cull: true,
        }
    }
}

/// `GenParams` in `hair_gen.glsl` (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GenParams {
    view_proj: [f32; 16],
    eye: [f32; 4],
    projection: [f32; 4],
    lod: [f32; 4],
    counts: [u32; 4],
    normalization: [f32; 4],
    layout_info: [u32; 4],
    style0: [f32; 4],
    curl: [f32; 4],
    wave_frizz: [f32; 4],
    frizz_clump: [f32; 4],
    /// Stray fraction, stray amplitude, wave coherence, -.
    stray: [f32; 4],
    seed_info: [u32; 4],
    viewport: [f32; 4],
    lod_error: [f32; 4],
}

pub use crate::contract::{MAX_VERTICES, VERTEX_BYTES};

// One vertex-LOD cap for the CPU reference and the GPU: a strand slot holds 2^E + 1 vertices.
const _: () = assert!(crate::contract::MAX_SEGMENTS_LOG2 == hairmesh::reference::MAX_SEGMENTS_LOG2);
// The strand-coherent tables in shared memory are sized for the most layers an asset may have.
const _: () = assert!(crate::contract::MAX_LAYERS == hairmesh::hair_mesh::MAX_LAYERS);
/// Chunks of strand slots (`MAX_CHUNKS` in `hair_outputs.glsl`).
pub const MAX_CHUNKS: u64 = 16;
const DISPATCH_ARGS_OFFSET: u64 = 16;
pub(crate) const DRAW_ARGS_OFFSET: u64 = DISPATCH_ARGS_OFFSET + MAX_CHUNKS * 12;
/// `subset_dispatches` (`hair_outputs.glsl`): the sparse subset's, then the remainder's.
const SUBSET_DISPATCH_OFFSET: u64 = DRAW_ARGS_OFFSET + MAX_CHUNKS * 16;
const OFFSETS_HEADER: u64 = SUBSET_DISPATCH_OFFSET + 2 * 12;

/// Which live strand slots a fused dispatch covers ([`Generator::record_fused_subset_dispatch`];
/// `subset_slot` in `hair_outputs.glsl`). The two proper subsets partition the slots, so a
/// consumer may draw in two passes — a sparse first one whose results let the second skip work
/// (render's occlusion tiles) — with each pass's invocations dense: a pass whose shader skipped
/// the other subset's strands would leave most SIMD lanes idle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotSubset {
    /// Every live slot.
    All = 0,
    /// Every [`contract::SPARSE_SLOT_STRIDE`]-th slot (0, 8, 16, …): a bundle's strands have
    /// consecutive slots, so this samples every bundle evenly (an eighth of its strands, or for
    /// bundles of fewer than eight strands under LOD, one strand in eight over the whole hair).
    ///
    /// [`contract::SPARSE_SLOT_STRIDE`]: crate::contract::SPARSE_SLOT_STRIDE
    Sparse = 1,
    /// The slots `Sparse` leaves out.
    Remainder = 2,
}

impl SlotSubset {
    /// Slots of this subset among `slots` (`subset_size` in `hair_outputs.glsl`).
    pub fn count(self, slots: u32) -> u32 {
        let sparse = slots.div_ceil(crate::contract::SPARSE_SLOT_STRIDE);
        match self {
            Self::All => slots,
            Self::Sparse => sparse,
            Self::Remainder => slots - sparse,
        }
    }
}
pub(crate) const SLOT_BYTES: u64 = MAX_VERTICES * VERTEX_BYTES;

/// Strand slots per chunk: as many as one storage-buffer window holds (capped by `limit`),
/// rounded so that chunk windows of the vertex (SLOT_BYTES) and info (16 B) buffers start at
/// multiples of the device's storage-buffer offset alignment.
pub(crate) fn chunk_slots(caps: &crate::Capabilities, limit: Option<u64>) -> u64 {
    let align = caps.min_storage_buffer_offset_alignment.max(1);
    let step = (1..=256u64)
        .find(|n| (n * SLOT_BYTES).is_multiple_of(align) && (n * 16).is_multiple_of(align))
        .unwrap_or(256);
    let range_slots = u64::from(caps.max_storage_buffer_range) / SLOT_BYTES;
    let wanted = limit.map_or(range_slots, |m| m.min(range_slots));
    (wanted / step * step).max(step)
}

/// One generated strand read back from the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct CapturedStrand {
    pub bundle: u32,
    pub index: u32,
    pub positions: Vec<Vec3>,
    pub tangents: Vec<Vec3>,
    pub widths: Vec<f32>,
}

/// What a capture produced.
#[derive(Clone, Debug)]
pub struct Capture {
    pub strands: Vec<CapturedStrand>,
    pub stats: GenerationStats,
    pub timings: FrameTimings,
}

/// Counts of one generation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GenerationStats {
    pub bundles: u32,
    pub bundles_culled: u32,
    pub strands: u64,
    pub vertices: u64,
}

impl std::ops::AddAssign for GenerationStats {
    /// Totals over several characters.
    fn add_assign(&mut self, other: Self) {
        self.bundles += other.bundles;
        self.bundles_culled += other.bundles_culled;
        self.strands += other.strands;
        self.vertices += other.vertices;
    }
}

/// Per-frame buffers, sized from the LOD result.
#[derive(Debug)]
pub struct FrameBuffers {
    params: Buffer,
    lods: Buffer,
    offsets: Buffer,
    strand_vertices: Buffer,
    strand_info: Buffer,
    capacity: u64,
    /// Slots per chunk: one chunk's vertex window fits the device's storage-buffer range.
    chunk_slots: u64,
    chunks: u64,
}

impl FrameBuffers {
    /// Chunks the strand slots are generated and drawn in.
    pub fn chunks(&self) -> u64 {
        self.chunks
    }
}

/// Pipelines of both paths.
#[derive(Debug)]
pub struct Generator {
    lod: Pipeline,
    scan: Pipeline,
    generate: Pipeline,
    /// Whether `generate` stores vertices as 64-bit words (`generate_int64.comp`).
    int64_stores: bool,
    pull: Pipeline,
    mesh: Option<Pipeline>,
    mesh_capture: Option<Pipeline>,
    pub options: GeneratorOptions,
    /// Why the mesh path is unavailable, when it is.
    pub mesh_unavailable: Option<String>,
}

/// Mesh-shader output of one strand workgroup: 2·33 vertices, 2·32 triangles, 32 threads.
const MESH_OUTPUT_VERTICES: u32 = 66;
const MESH_OUTPUT_PRIMITIVES: u32 = 64;
const MESH_THREADS: u32 = 32;

pub use crate::backend::target::{COLOR_FORMAT, DEPTH_FORMAT};

/// Set 0 of every strand pipeline ([`crate::contract`]) plus a consumer's own buffers (at
/// [`crate::contract::binding::FIRST_CONSUMER`] and up: a fragment stage's, or those of a
/// consumer pipeline that generates inside its own shader).
pub fn strand_bindings(extra: &[u32]) -> Vec<Binding> {
    use crate::contract::binding as b;
    let all = vk::ShaderStageFlags::ALL;
    let buffers = [b::GEN_PARAMS, b::BUNDLES, b::ROOT_SAMPLES, b::SAMPLE_SETS];
    let textures = [b::HAIR_MESH_TEXTURE, b::U_TEXTURE, b::V_TEXTURE];
    let outputs = [b::BUNDLE_LODS, b::STRAND_OFFSETS, b::STRAND_VERTICES, b::STRAND_INFO];
    let mut list: Vec<Binding> = buffers.iter().map(|&i| Binding::storage_buffer(i, all)).collect();
    list.extend(textures.iter().map(|&i| Binding {
        binding: i,
        ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
        stages: all,
    }));
    list.extend(outputs.iter().map(|&i| Binding::storage_buffer(i, all)));
    list.extend(Binding::storage_buffers(extra, all));
    list
}

/// The per-frame buffers every frame has (parameters, LOD per bundle, offsets and indirect
/// arguments), around the strand buffers the caller sized.
fn frame_buffers(
    ctx: &Context,
    hair: &GpuHair,
    params: GenParams,
    strands: (Buffer, Buffer),
    (capacity, chunk_slots, chunks): (u64, u64, u64),
) -> Result<FrameBuffers> {
    let params = ctx.create_buffer_with_data(
        "generation parameters",
        BufferDesc::storage(size_of::<GenParams>() as u64).location(MemoryLocation::CpuToGpu),
        bytemuck::bytes_of(&params),
    )?;
    let bundles = u64::from(hair.bundle_count);
    let indirect = vk::BufferUsageFlags::INDIRECT_BUFFER;
    Ok(FrameBuffers {
        params,
        lods: Buffer::new(ctx, "bundle LOD", BufferDesc::storage(bundles * 16))?,
        offsets: Buffer::new(
            ctx,
            "strand offsets",
            BufferDesc::storage(OFFSETS_HEADER + bundles * 4).usage(indirect),
        )?,
        strand_vertices: strands.0,
        strand_info: strands.1,
        capacity,
        chunk_slots,
        chunks,
    })
}

impl Generator {
    pub fn new(ctx: &Context, filtering: Filtering) -> Result<Self> {
        Self::with_options(ctx, GeneratorOptions { filtering, ..GeneratorOptions::default() })
    }

    pub fn with_options(ctx: &Context, options: GeneratorOptions) -> Result<Self> {
        let manual = u32::from(options.filtering == Filtering::Manual);
        let per_vertex = u32::from(options.filtering != Filtering::StrandCoherent);
        let cubic = u32::from(options.exact_cubic);
        let extra = options.fragment.map_or(&[][..], |f| f.extra_bindings);
        let bindings = strand_bindings(extra);
        let compute = |name, shader| {
            Pipeline::compute(
                ctx,
                &ComputePipelineDesc {
                    name,
                    shader,
                    bindings: &bindings,
                    push_constant_size: 4,
                    specialization: &[(0, manual), (2, cubic), (3, per_vertex)],
                },
            )
        };
        let fragment = options.fragment.unwrap_or(FragmentStage {
            shader: &shaders::STRAND_FRAG,
            push_constant_bytes: 0,
            blend: crate::Blend::Replace,
            depth_write: true,
            depth_compare: vk::CompareOp::LESS,
            color_write: true,
            extra_bindings: &[],
            specialization: None,
        });
        if let Some((id, _)) = fragment.specialization
            && id < crate::contract::FIRST_CONSUMER_CONSTANT_ID
        {
            return Err(GpuError::Mismatch(format!(
                "fragment stage specialization constant {id} is below the consumer's first ({})",
                crate::contract::FIRST_CONSUMER_CONSTANT_ID
            )));
        }
        let push_size = FRAGMENT_PUSH_OFFSET + fragment.push_constant_bytes;
        let own_constants = |capture: u32| {
            let mut constants = vec![(0, manual), (1, capture), (2, cubic), (3, per_vertex)];
            constants.extend(fragment.specialization);
            constants
        };
        let graphics = |name, stages, capture: u32| {
            Pipeline::graphics(
                ctx,
                &GraphicsPipelineDesc {
                    name,
                    stages,
                    fragment: fragment.shader,
                    bindings: &bindings,
                    push_constant_size: push_size,
                    specialization: &own_constants(capture),
                    color_format: options.color_format.unwrap_or(COLOR_FORMAT),
                    depth_format: Some(DEPTH_FORMAT),
                    blend: fragment.blend,
                    depth_write: fragment.depth_write,
                    color_write: fragment.color_write,
                    samples: options.samples,
                    depth_compare: fragment.depth_compare,
                },
            )
        };
        let mesh_stages =
            GraphicsStages::Mesh { task: Some(&shaders::STRAND_TASK), mesh: &shaders::STRAND_MESH };
        // The mesh path needs one strand's strip in one workgroup; check the device's limits.
        let mesh_unavailable = match ctx.capabilities().mesh_shader {
            None => Some(format!("{} has no VK_EXT_mesh_shader", ctx.capabilities().device_name)),
            Some(m)
                if m.max_output_vertices < MESH_OUTPUT_VERTICES
                    || m.max_output_primitives < MESH_OUTPUT_PRIMITIVES
                    || m.max_mesh_work_group_invocations < MESH_THREADS =>
            {
                Some(format!(
                    "mesh limits too small: {} vertices, {} primitives, {} invocations (needs {MESH_OUTPUT_VERTICES}, {MESH_OUTPUT_PRIMITIVES}, {MESH_THREADS})",
                    m.max_output_vertices, m.max_output_primitives, m.max_mesh_work_group_invocations
                ))
            }
            Some(_) => None,
        };
        let has_mesh = mesh_unavailable.is_none();
        let int64_stores = ctx.capabilities().shader_int64 && !options.vec4_vertex_stores;
        let generate_shader =
            if int64_stores { &shaders::GENERATE_INT64_COMP } else { &shaders::GENERATE_COMP };
        Ok(Self {
            lod: compute("strand LOD", &shaders::LOD_COMP)?,
            scan: compute("strand prefix sum", &shaders::SCAN_COMP)?,
            generate: compute("strand generation", generate_shader)?,
            int64_stores,
            pull: graphics(
                "strands (vertex pulling)",
                GraphicsStages::Vertex(&shaders::STRAND_PULL_VERT),
                0,
            )?,
            mesh: if has_mesh { Some(graphics("strands (task+mesh)", mesh_stages, 0)?) } else { None },
            mesh_capture: if has_mesh {
                Some(graphics("strands (task+mesh, capture)", mesh_stages, 1)?)
            } else {
                None
            },
            options,
            mesh_unavailable,
        })
    }

    /// Whether the generate pass stores each vertex as one `u64vec4` (where the device has
    /// `shaderInt64`, unless [`GeneratorOptions::vec4_vertex_stores`]) rather than two `vec4`s:
    /// the same bytes either way. On CPU devices (llvmpipe) a store at a per-invocation address
    /// is a loop over the SIMD lanes, so one store per vertex instead of two made the
    /// strand-coherent pass about 5 % faster.
    pub fn int64_vertex_stores(&self) -> bool {
        self.int64_stores
    }

    /// Strand slots needed for `inputs`: the CPU's LOD estimate plus one per bundle for f32
    /// rounding, never more than the asset holds.
    pub fn capacity(hair: &GpuHair, inputs: &FrameInputs) -> u64 {
        let asset = &hair.asset;
        let estimate: u64 = (0..hair.bundle_count)
            .map(|b| u64::from(bundle_lod(asset, b, &inputs.view, &inputs.lod).strands))
            .sum();
        (estimate + u64::from(hair.bundle_count)).min(hair.total_strands).max(1)
    }

    /// Bytes of the strand buffers [`Self::prepare`] allocates for `inputs` (before allocating).
    pub fn frame_bytes(hair: &GpuHair, inputs: &FrameInputs) -> u64 {
        Self::capacity(hair, inputs) * (SLOT_BYTES + 16)
    }

    /// Allocates the frame buffers for `inputs` and writes the frame parameters.
    pub fn prepare(&self, ctx: &Context, hair: &GpuHair, inputs: &FrameInputs) -> Result<FrameBuffers> {
        let capacity = Self::capacity(hair, inputs);
        let caps = ctx.capabilities();
        let chunk_slots = chunk_slots(caps, self.options.max_chunk_slots);
        let chunks = capacity.div_ceil(chunk_slots);
        let vertex_bytes = capacity * SLOT_BYTES;
        if chunks > MAX_CHUNKS || vertex_bytes > 1 << 31 {
            return Err(GpuError::OverBudget {
                name: "generated strand vertices".into(),
                requested: vertex_bytes,
                budget: (MAX_CHUNKS * chunk_slots * SLOT_BYTES).min(1 << 31),
                why: "at most 16 chunks of the storage-buffer range and 2 GiB per frame buffer; raise the LOD α or split the character",
            });
        }
        let strands = (
            Buffer::new(ctx, "strand vertices", BufferDesc::storage(vertex_bytes))?,
            Buffer::new(ctx, "strand info", BufferDesc::storage(capacity * 16))?,
        );
        let params = params(hair, inputs, capacity, chunk_slots);
        frame_buffers(ctx, hair, params, strands, (capacity, chunk_slots, chunks))
    }

    /// Frame buffers for a consumer that generates inside its own shader (fused generation,
    /// e.g. the compute rasterizer): the parameters, LOD and offsets only — no strand buffer, so
    /// the memory does not grow with the strand count. Every live strand slot is in chunk 0:
    /// [`Self::record_lod`] writes its dispatch (one invocation per strand, 32 per workgroup),
    /// which [`Self::record_fused_dispatch`] runs.
    pub fn prepare_fused(&self, ctx: &Context, hair: &GpuHair, inputs: &FrameInputs) -> Result<FrameBuffers> {
        let capacity = hair.total_strands.max(1);
        // Bound but never written: fused consumers keep vertices in registers.
        let strands = (
            Buffer::new(ctx, "strand vertices (unused)", BufferDesc::storage(SLOT_BYTES))?,
            Buffer::new(ctx, "strand info (unused)", BufferDesc::storage(16))?,
        );
        // All live slots in chunk 0 of the shaders' view (`chunk_slots = capacity`); the host
        // side binds the one-slot windows above.
        frame_buffers(ctx, hair, params(hair, inputs, capacity, capacity), strands, (1, 1, 1))
    }

    /// Binds `frame` and `hair` (set 0, chunk 0) plus `extra` consumer buffers for `pipeline`,
    /// a consumer pipeline created with [`strand_bindings`].
    pub fn bind_frame(
        &self,
        rec: &Recorder<'_>,
        pipeline: &Pipeline,
        hair: &GpuHair,
        frame: &FrameBuffers,
        extra: &[(u32, &Buffer)],
    ) {
        self.push_all(rec, pipeline, hair, frame, 0, extra);
    }

    /// Dispatches the bound compute pipeline over every live strand slot of a
    /// [`Self::prepare_fused`] frame (32 strands per workgroup, rows of `DISPATCH_ROW`
    /// workgroups), with the arguments [`Self::record_lod`] wrote.
    pub fn record_fused_dispatch(rec: &Recorder<'_>, frame: &FrameBuffers) {
        rec.dispatch_indirect(&frame.offsets, DISPATCH_ARGS_OFFSET);
    }

    /// [`Self::record_fused_dispatch`] over one [`SlotSubset`] of the live slots: the shader
    /// takes its slot from `invocation_subset_slot(subset, slot)` (`hair_outputs.glsl`) with the
    /// same `subset` (as `uint(SlotSubset)`, e.g. in a push constant).
    pub fn record_fused_subset_dispatch(rec: &Recorder<'_>, frame: &FrameBuffers, subset: SlotSubset) {
        match subset {
            SlotSubset::All => Self::record_fused_dispatch(rec, frame),
            SlotSubset::Sparse => rec.dispatch_indirect(&frame.offsets, SUBSET_DISPATCH_OFFSET),
            SlotSubset::Remainder => rec.dispatch_indirect(&frame.offsets, SUBSET_DISPATCH_OFFSET + 12),
        }
    }

    /// Binds everything, with chunk `chunk`'s windows of the strand buffers and the fragment
    /// stage's own buffers.
    fn push_all(
        &self,
        rec: &Recorder<'_>,
        pipeline: &Pipeline,
        hair: &GpuHair,
        frame: &FrameBuffers,
        chunk: u64,
        extra: &[(u32, &Buffer)],
    ) {
        use crate::contract::binding as b;
        let whole = vk::WHOLE_SIZE;
        let first = chunk * frame.chunk_slots;
        let slots = frame.chunk_slots.min(frame.capacity - first.min(frame.capacity)).max(1);
        let mut buffers = vec![
            (b::GEN_PARAMS, &frame.params, 0, whole),
            (b::BUNDLES, &hair.bundles, 0, whole),
            (b::ROOT_SAMPLES, &hair.samples, 0, whole),
            (b::SAMPLE_SETS, &hair.sample_sets, 0, whole),
            (b::BUNDLE_LODS, &frame.lods, 0, whole),
            (b::STRAND_OFFSETS, &frame.offsets, 0, whole),
            (b::STRAND_VERTICES, &frame.strand_vertices, first * SLOT_BYTES, slots * SLOT_BYTES),
            (b::STRAND_INFO, &frame.strand_info, first * 16, slots * 16),
        ];
        buffers.extend(extra.iter().map(|(b, buf)| (*b, *buf, 0, whole)));
        rec.push_descriptors_ranged(
            pipeline,
            &buffers,
            &[
                (b::HAIR_MESH_TEXTURE, &hair.hair_mesh, &hair.sampler),
                (b::U_TEXTURE, &hair.u, &hair.sampler),
                (b::V_TEXTURE, &hair.v, &hair.sampler),
            ],
        );
    }

    /// Compute path pass 1: LOD per bundle and the prefix sum with indirect arguments. What reads
    /// them must be ordered after it: by a frame graph, or by [`Self::barrier_after_lod`].
    pub fn record_lod(&self, rec: &mut Recorder<'_>, hair: &GpuHair, frame: &FrameBuffers) {
        let compute = (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE);
        let read = vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        rec.pass("LOD + cull", |rec| {
            rec.bind_pipeline(&self.lod);
            self.push_all(rec, &self.lod, hair, frame, 0, &[]);
            rec.dispatch(hair.bundle_count.div_ceil(shaders::LOD_COMP.workgroup_size[0]), 1, 1);
        });
        rec.memory_barrier(compute, (vk::PipelineStageFlags2::COMPUTE_SHADER, read));
        rec.pass("prefix sum", |rec| {
            rec.bind_pipeline(&self.scan);
            self.push_all(rec, &self.scan, hair, frame, 0, &[]);
            rec.dispatch(1, 1, 1);
        });
    }

    /// Makes [`Self::record_lod`]'s outputs (LOD, offsets, indirect arguments) visible to the
    /// generate pass and to draws. For callers without a frame graph (a graph derives this from
    /// the passes' declared reads and writes).
    pub fn barrier_after_lod(rec: &Recorder<'_>) {
        rec.memory_barrier(
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
            (
                vk::PipelineStageFlags2::DRAW_INDIRECT
                    | vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::VERTEX_SHADER
                    | vk::PipelineStageFlags2::TASK_SHADER_EXT
                    | vk::PipelineStageFlags2::MESH_SHADER_EXT,
                vk::AccessFlags2::INDIRECT_COMMAND_READ
                    | vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
    }

    /// Compute path pass 2: every strand's vertices into the strand buffer (ordered before its
    /// readers by a frame graph or [`Self::barrier_after_generate`]).
    pub fn record_generate(&self, rec: &mut Recorder<'_>, hair: &GpuHair, frame: &FrameBuffers) {
        rec.pass("generate (compute)", |rec| {
            rec.bind_pipeline(&self.generate);
            for chunk in 0..frame.chunks {
                self.push_all(rec, &self.generate, hair, frame, chunk, &[]);
                rec.push_constants(&self.generate, &(chunk as u32));
                rec.dispatch_indirect(&frame.offsets, DISPATCH_ARGS_OFFSET + 12 * chunk);
            }
        });
    }

    /// Makes [`Self::record_generate`]'s strands visible to vertex pulling and copies. For
    /// callers without a frame graph.
    pub fn barrier_after_generate(rec: &Recorder<'_>) {
        rec.memory_barrier(
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
            (
                vk::PipelineStageFlags2::VERTEX_SHADER
                    | vk::PipelineStageFlags2::COPY
                    | vk::PipelineStageFlags2::HOST,
                vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::TRANSFER_READ
                    | vk::AccessFlags2::HOST_READ,
            ),
        );
    }

    /// Draws the strands inside a rendering scope begun by the caller (colour
    /// [`COLOR_FORMAT`], depth [`DEPTH_FORMAT`]). The compute path expects
    /// [`Self::record_lod`] and [`Self::record_generate`] earlier in the command buffer; the
    /// mesh path generates here.
    pub fn record_draw(
        &self,
        rec: &mut Recorder<'_>,
        hair: &GpuHair,
        frame: &FrameBuffers,
        path: GenerationPath,
        capture: bool,
    ) -> Result<()> {
        self.record_draw_with(rec, hair, frame, path, capture, DrawExtras::default())
    }

    /// [`Self::record_draw`] with the fragment stage's push constants (at
    /// [`FRAGMENT_PUSH_OFFSET`]) and buffers.
    pub fn record_draw_with(
        &self,
        rec: &mut Recorder<'_>,
        hair: &GpuHair,
        frame: &FrameBuffers,
        path: GenerationPath,
        capture: bool,
        extras: DrawExtras<'_>,
    ) -> Result<()> {
        let fragment_constants = extras.fragment_constants;
        match path {
            GenerationPath::Compute => {
                rec.bind_pipeline(&self.pull);
                for chunk in 0..frame.chunks {
                    self.push_all(rec, &self.pull, hair, frame, chunk, extras.buffers);
                    rec.push_constants(&self.pull, &(chunk as u32));
                    rec.push_constant_bytes(&self.pull, FRAGMENT_PUSH_OFFSET, fragment_constants);
                    rec.draw_indirect(&frame.offsets, DRAW_ARGS_OFFSET + 16 * chunk);
                }
                Ok(())
            }
            GenerationPath::Mesh => {
                let pipeline = if capture { self.mesh_capture.as_ref() } else { self.mesh.as_ref() };
                let pipeline = pipeline.ok_or_else(|| GpuError::MeshShaderUnsupported {
                    requested: "mesh",
                    device: self.mesh_unavailable.clone().unwrap_or_default(),
                })?;
                let limits = rec
                    .ctx()
                    .capabilities()
                    .mesh_shader
                    .ok_or(GpuError::MeshShaderUnsupported { requested: "mesh", device: String::new() })?;
                // One task workgroup per bundle, in rows within maxTaskWorkGroupCount
                // (lavapipe does not check it; real GPUs fail).
                let per_row = hair.bundle_count.clamp(1, limits.max_task_work_group_count[0]);
                let rows = hair.bundle_count.div_ceil(per_row);
                if rows > limits.max_task_work_group_count[1]
                    || u64::from(per_row) * u64::from(rows)
                        > u64::from(limits.max_task_work_group_total_count)
                {
                    return Err(GpuError::OverBudget {
                        name: "task workgroups".into(),
                        requested: u64::from(hair.bundle_count),
                        budget: u64::from(limits.max_task_work_group_total_count),
                        why: "maxTaskWorkGroupCount",
                    });
                }
                if capture && frame.chunks > 1 {
                    return Err(GpuError::OverBudget {
                        name: "mesh-path capture".into(),
                        requested: frame.capacity,
                        budget: frame.chunk_slots,
                        why: "the mesh path captures one chunk of strand slots; use the compute path",
                    });
                }
                rec.bind_pipeline(pipeline);
                self.push_all(rec, pipeline, hair, frame, 0, extras.buffers);
                rec.push_constants(pipeline, &per_row);
                rec.push_constant_bytes(pipeline, FRAGMENT_PUSH_OFFSET, fragment_constants);
                rec.draw_mesh_tasks(per_row, rows, 1)
            }
        }
    }

    /// Generates through `path`, drawing into a small offscreen target, and reads back every
    /// generated strand (the mesh path under its capture specialization).
    pub fn capture(
        &self,
        ctx: &Context,
        hair: &GpuHair,
        inputs: &FrameInputs,
        path: GenerationPath,
    ) -> Result<Capture> {
        let frame = self.prepare(ctx, hair, inputs)?;
        let target = crate::RenderTarget::new(ctx, 64, 64)?;
        let ((), timings) = ctx.submit(&format!("capture ({path})"), |rec| {
            self.record_lod(rec, hair, &frame);
            Self::barrier_after_lod(rec);
            if path == GenerationPath::Compute {
                self.record_generate(rec, hair, &frame);
                Self::barrier_after_generate(rec);
            }
            target.begin(rec);
            let drawn =
                rec.pass(&format!("draw ({path})"), |rec| self.record_draw(rec, hair, &frame, path, true));
            rec.end_rendering();
            drawn
        })?;
        let strands = read_strands(ctx, &frame)?;
        let stats = self.stats(ctx, hair, &frame)?;
        Ok(Capture { strands, stats, timings })
    }

    /// Counts of the last generation into `frame`.
    pub fn stats(&self, ctx: &Context, hair: &GpuHair, frame: &FrameBuffers) -> Result<GenerationStats> {
        let header: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.offsets, 8)?);
        let lods: Vec<[u32; 4]> =
            bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.lods, u64::from(hair.bundle_count) * 16)?);
        let vertices = lods.iter().map(|l| u64::from(l[0]) * ((1u64 << l[1]) + 1)).sum();
        Ok(GenerationStats {
            bundles: hair.bundle_count,
            bundles_culled: lods.iter().filter(|l| l[0] == 0).count() as u32,
            strands: u64::from(header[0]),
            vertices,
        })
    }
}

fn read_strands(ctx: &Context, frame: &FrameBuffers) -> Result<Vec<CapturedStrand>> {
    let header: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.offsets, 8)?);
    let count = u64::from(header[0]).min(frame.capacity);
    let info: Vec<[u32; 4]> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.strand_info, count * 16)?);
    let vertices: Vec<[f32; 8]> = bytemuck::pod_collect_to_vec(
        &ctx.read_buffer(&frame.strand_vertices, count * MAX_VERTICES * VERTEX_BYTES)?,
    );
    Ok(info
        .iter()
        .enumerate()
        .map(|(slot, &[bundle, index, n, _])| {
            let v = &vertices[slot * MAX_VERTICES as usize..][..(n as usize).min(MAX_VERTICES as usize)];
            CapturedStrand {
                bundle,
                index,
                positions: v.iter().map(|x| Vec3::new(x[0], x[1], x[2])).collect(),
                widths: v.iter().map(|x| x[3]).collect(),
                tangents: v.iter().map(|x| Vec3::new(x[4], x[5], x[6])).collect(),
            }
        })
        .collect())
}

/// Parameters with only the view filled in (stored strands have no asset).
pub(crate) fn view_only_params(inputs: &FrameInputs, chunk_slots: u64) -> GenParams {
    let e = inputs.view.eye.as_vec3();
    let (tan_half, ortho_half, ortho) = match inputs.view.projection {
        Projection::Perspective { fov_y } => ((0.5 * fov_y).tan() as f32, 0.0, 0.0),
        Projection::Orthographic { height } => (0.0, 0.5 * height as f32, 1.0),
    };
    let mut p: GenParams = bytemuck::Zeroable::zeroed();
    p.view_proj = inputs.view_proj.to_cols_array();
    p.eye = [e.x, e.y, e.z, inputs.view.vertical_resolution as f32];
    p.projection = [tan_half, ortho_half, ortho, 0.0];
    p.seed_info = [0, 0, u32::MAX, chunk_slots as u32];
    p.viewport = [inputs.viewport[0] as f32, inputs.viewport[1] as f32, 0.0, 0.0];
    p
}

impl Generator {
    pub(crate) fn pull_pipeline(&self) -> &Pipeline {
        &self.pull
    }
}

fn params(hair: &GpuHair, inputs: &FrameInputs, capacity: u64, chunk_slots: u64) -> GenParams {
    let asset = &hair.asset;
    let t = &asset.textures;
    let s = &asset.style;
    let (tan_half, ortho_half, ortho) = match inputs.view.projection {
        Projection::Perspective { fov_y } => ((0.5 * fov_y).tan() as f32, 0.0, 0.0),
        Projection::Orthographic { height } => (0.0, 0.5 * height as f32, 1.0),
    };
    let lod = &inputs.lod;
    let e = inputs.view.eye.as_vec3();
    let n = t.normalization;
    let f = |v: f64| v as f32;
    GenParams {
        view_proj: inputs.view_proj.to_cols_array(),
        eye: [e.x, e.y, e.z, f(inputs.view.vertical_resolution)],
        projection: [tan_half, ortho_half, ortho, if inputs.cull { 1.0 } else { 0.0 }],
        lod: [
            if lod.enabled { 1.0 } else { 0.0 },
            f(lod.strand_alpha),
            f(lod.vertex_alpha),
            f(lod.morph_band),
        ],
        counts: [
            hair.bundle_count,
            lod.max_segments_log2.min(crate::contract::MAX_SEGMENTS_LOG2),
            asset.square_sets.len() as u32,
            asset.triangle_sets.len() as u32,
        ],
        normalization: [f(n.origin.x), f(n.origin.y), f(n.origin.z), f(n.scale)],
        layout_info: [0, t.layout.width, t.layout.height, t.layout.layers],
        style0: [f(s.width), f(s.tip_width), f(s.root_fade), f(s.length_variation)],
        curl: [f(s.curl.radius), f(s.curl.frequency), f(s.curl.phase), 0.0],
        wave_frizz: [f(s.wave.amplitude), f(s.wave.frequency), f(s.frizz.amplitude), f(s.frizz.frequency)],
        frizz_clump: [f(s.frizz.exponent), f(s.clump.strength), f(s.clump.exponent), f(s.twist)],
        stray: [f(s.stray.fraction), f(s.stray.amplitude), f(s.wave.coherence), 0.0],
        seed_info: [
            s.seed,
            asset.square_sets.len() as u32,
            capacity.min(u64::from(u32::MAX)) as u32,
            chunk_slots as u32,
        ],
        viewport: [inputs.viewport[0] as f32, inputs.viewport[1] as f32, 0.0, 0.0],
        lod_error: [f(lod.vertex_error_pixels), 0.0, 0.0, 0.0],
    }
}

#[cfg(test)]
mod tests {
    use super::SlotSubset;

    #[test]
    fn slot_subsets_partition_the_slots() {
        for slots in [0u32, 1, 7, 8, 9, 15, 16, 17, 1000, 100_003] {
            let sparse = SlotSubset::Sparse.count(slots);
            assert_eq!(SlotSubset::All.count(slots), slots);
            assert_eq!(sparse + SlotSubset::Remainder.count(slots), slots, "{slots} slots");
            // Slots 0, 8, 16, … below `slots` (`subset_slot` in hair_outputs.glsl).
            let stride = crate::contract::SPARSE_SLOT_STRIDE as usize;
            assert_eq!(sparse as usize, (0..slots).step_by(stride).count(), "{slots} slots");
        }
    }
}

#[cfg(test)]
mod view_tests {
    use super::view_matrix;
    use glam::Vec3;

    /// The target lies straight ahead (−Z in view space) from every direction, the poles
    /// included, and the matrix stays a rotation.
    #[test]
    fn the_view_is_well_defined_from_every_direction() {
        let target = Vec3::new(0.0, 1.5, 0.0);
        for dir in
            [Vec3::Y, Vec3::NEG_Y, Vec3::X, Vec3::Z, Vec3::new(1e-6, 1.0, 0.0), Vec3::new(0.0, -1.0, 1e-7)]
        {
            let eye = target + dir * 2.0;
            let view = view_matrix(eye, target);
            assert!(view.is_finite(), "{dir}: {view}");
            let ahead = view.transform_point3(target);
            assert!(ahead.truncate().length() < 1e-4 && (ahead.z + 2.0).abs() < 1e-4, "{dir}: {ahead}");
            assert!((view.determinant() - 1.0).abs() < 1e-4, "{dir}: not a rotation");
        }
        assert!(view_matrix(target, target).is_finite());
    }
}
