//! On-the-fly strand generation: the compute path (LOD pass, prefix sum, generation pass,
//! vertex pulling) and the mesh path (task + mesh shaders), both from `hair_gen.glsl`.
//!
//! The [`Generator`] and its options are here; a frame's inputs and buffers in `frame`, the
//! recorded passes and draws in `record`, read-backs and counts in `capture`.
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

mod capture;
mod frame;
mod record;

use ash::vk;
use glam::{Mat4, Vec3};
use hairmesh::asset::HairAsset;
use hairmesh::reference::{LodParams, Projection, ViewParams, bundle_lod};

use crate::{
    Binding, Buffer, BufferDesc, ComputePipelineDesc, Context, FrameTimings, GenerationPath, GpuError,
    GpuHair, GraphicsPipelineDesc, GraphicsStages, MemoryLocation, Pipeline, Recorder, Result, shaders,
};

pub use capture::{Capture, CapturedStrand, GenerationStats};
pub(crate) use frame::view_only_params;
pub use frame::{FrameBuffers, FrameInputs, view_matrix};

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

pub use crate::contract::{MAX_VERTICES, VERTEX_BYTES};

// One vertex-LOD cap for the CPU reference and the GPU: a strand slot holds 2^E + 1 vertices.
const _: () = assert!(crate::contract::MAX_SEGMENTS_LOG2 == hairmesh::reference::MAX_SEGMENTS_LOG2);
// The strand-coherent tables in shared memory are sized for the most layers an asset may have.
const _: () = assert!(crate::contract::MAX_LAYERS == hairmesh::hair_mesh::MAX_LAYERS);
// The head push takes the reference's steps (hair_gen.glsl, keep_out_of_head).
const _: () = assert!(crate::contract::HEAD_PUSH_STEPS == hairmesh::head_field::PUSH_STEPS);
const _: () = assert!(crate::contract::HEAD_PUSH_HALVINGS == hairmesh::head_field::PUSH_HALVINGS);
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
    let textures = [b::HAIR_MESH_TEXTURE, b::U_TEXTURE, b::V_TEXTURE, b::HEAD_FIELD];
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
    /// is a loop over the SIMD lanes, so one store per vertex instead of two is cheaper
    /// (`docs/compute-raster-notes.md`).
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
}

impl Generator {
    pub(crate) fn pull_pipeline(&self) -> &Pipeline {
        &self.pull
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
