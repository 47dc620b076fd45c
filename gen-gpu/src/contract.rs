//! The generator → consumer contract: descriptor bindings, push-constant layout, varying
//! locations and strand-buffer layout shared by gen-gpu's shaders and every consumer (render's
//! fragment stages today; a compute rasterizer or voxelizer next).
//!
//! These Rust constants are the single source: `build.rs` writes them into the GLSL header
//! `hk_gen_contract.glsl` (`#define HK_BINDING_GEN_PARAMS 0u` …), which every shader
//! `#include`s; shader-build refuses binding numbers written as literals and any binding a module
//! uses that the contract does not declare. Consumer crates find the header through the
//! `DEP_HAIRKIT_GEN_GPU_INCLUDE` folder cargo passes to their build scripts.
//!
//! # Set 0 of a strand pipeline
//! | bindings | what | written by |
//! |---|---|---|
//! | [`binding::GEN_PARAMS`] … [`binding::HEAD_FIELD`] (0–7) | frame parameters, bundle table, root samples, the three 3D textures (hair mesh, û with w, v̂), the head's distance field | the CPU (per frame / per asset) |
//! | [`binding::BUNDLE_LODS`] … [`binding::STRAND_INFO`] (8–11) | LOD per bundle, prefix sum + indirect arguments, strand vertices, strand info | the generator |
//! | [`binding::FIRST_CONSUMER`] and up (12–) | the consumer's own buffers (render: OIT lists, shadow maps, lights) | the consumer |
//!
//! Push constants: bytes `0..FRAGMENT_PUSH_OFFSET` belong to the pre-raster stages (the chunk
//! index or the task rows); a fragment stage's own block starts at [`FRAGMENT_PUSH_OFFSET`].
//!
//! # Consuming generated strands
//! * **Fragment stage** of a generator pipeline (`gen_gpu::FragmentStage`): read the varyings at
//!   [`location::POSITION_TAU`], [`location::TANGENT_RANDOM`], [`location::COVERAGE_SIDE`]
//!   (documented in `hair_gen.glsl`, `StrandVaryings`) and declare extra buffers at bindings
//!   from [`binding::FIRST_CONSUMER`] on.
//! * **A compute consumer reading the generator's buffers**: bind `BUNDLE_LODS`, `STRAND_OFFSETS`,
//!   `STRAND_VERTICES`, `STRAND_INFO` (include `hair_gen.glsl` then `hair_outputs.glsl`) after the
//!   compute path's generate pass; a slot holds [`MAX_VERTICES`] vertices of [`VERTEX_BYTES`]
//!   bytes (`vec4(position, width)`, `vec4(tangent, tau)`), `strand_info[slot]` its bundle,
//!   index, vertex count and LOD width scale, `offsets[]`/`total_strands` how many slots are live.
//! * **A compute consumer generating inside its own shader** (fused generation, no strand buffer):
//!   include `hair_gen.glsl` with bindings 0–7 bound as the generator binds them, take a
//!   bundle's `bundle_lod(bundle)` (or the LOD pass's `lods[]`), then either
//!   - one strand per invocation (what `generate.comp` does in the strand-coherent variant):
//!     `StrandStream s = strand_stream(bundle, strand, lod, from_control)`, then
//!     `strand_stream_next(s)` once per vertex, 0 to 2^level in order, for position, width and
//!     tangent (or `strand_stream_point(s, k)` for the unmorphed positions alone). Invocations of
//!     a subgroup whose strands have the same vertex count make these calls together (no
//!     `break` or `return` in between): the subgroup fetches the texels of strands that share
//!     a cell together; or
//!   - one strand per workgroup: `strand_load_control(…)` + `barrier()` when
//!     `strand_coherent(…)`, `strand_compute_vertex(bundle, strand, lod, base, k, …)` into the
//!     shared vertex array, `barrier()`, and `strand_vertex_of_group(…)`.
//!
//!   Its own buffers go at `FIRST_CONSUMER` and up. A consumer that draws in two passes (a sparse
//!   first one whose results let the second skip work) dispatches each over its own slots with
//!   `Generator::record_fused_subset_dispatch(…, SlotSubset::Sparse)`, then `Remainder`, and takes
//!   its slot from `invocation_subset_slot(subset, slot)`: every invocation draws a strand.

/// Descriptor bindings of set 0.
pub mod binding {
    /// `GenParams`: view, LOD, style, counts (std430, one per frame and character).
    pub const GEN_PARAMS: u32 = 0;
    /// The bundle table (bounds, strand counts, cells).
    pub const BUNDLES: u32 = 1;
    /// Root samples as unorm16 pairs.
    pub const ROOT_SAMPLES: u32 = 2;
    /// Offsets and counts of the root sample sets.
    pub const SAMPLE_SETS: u32 = 3;
    /// The hair-mesh 3D texture (sampler3D).
    pub const HAIR_MESH_TEXTURE: u32 = 4;
    /// û in rgb and w in alpha (sampler3D): the asset's two layer textures in one, so a
    /// fetch reads both.
    pub const U_TEXTURE: u32 = 5;
    /// v̂ (sampler3D).
    pub const V_TEXTURE: u32 = 6;
    /// The head's signed distance field (sampler3D, one channel; `hairmesh::head_field`):
    /// strand vertices are pushed out of the head through it.
    pub const HEAD_FIELD: u32 = 7;
    /// LOD per bundle (written by the LOD pass).
    pub const BUNDLE_LODS: u32 = 8;
    /// Prefix sum of strands per bundle, dispatch and draw arguments.
    pub const STRAND_OFFSETS: u32 = 9;
    /// Generated vertices (the current chunk's window).
    pub const STRAND_VERTICES: u32 = 10;
    /// Per generated strand: bundle, index, vertex count, LOD width scale.
    pub const STRAND_INFO: u32 = 11;
    /// The first binding a consumer may use for its own buffers.
    pub const FIRST_CONSUMER: u32 = 12;
    /// The one binding of gen-gpu's diagnostic shaders (test patterns and strips; their own
    /// pipelines, not strand pipelines).
    pub const DIAGNOSTIC_OUTPUT: u32 = 0;
}

/// Fragment-stage input locations of a strand strip (`StrandVaryings` in `hair_gen.glsl`).
pub mod location {
    /// `vec4`: object-space position, strand parameter τ.
    pub const POSITION_TAU: u32 = 0;
    /// `vec4`: object-space tangent, per-strand random.
    pub const TANGENT_RANDOM: u32 = 1;
    /// `vec4`: x coverage, y strip side, z coverage of the real (not LOD-widened) strand.
    pub const COVERAGE_SIDE: u32 = 2;
}

/// Where a fragment stage's push constants begin (bytes before it belong to the pre-raster
/// stages).
pub const FRAGMENT_PUSH_OFFSET: u32 = 16;

/// The vertex-LOD cap `E` (at most `2^E` segments per strand), shared with the CPU reference
/// (`hairmesh::reference::MAX_SEGMENTS_LOG2`; gen-gpu checks they agree at compile time).
pub const MAX_SEGMENTS_LOG2: u32 = 5;

/// Steps and step halvings of the head push (`hairmesh::head_field::PUSH_STEPS`,
/// `PUSH_HALVINGS`; gen-gpu checks they agree at compile time).
pub const HEAD_PUSH_STEPS: u32 = 4;
pub const HEAD_PUSH_HALVINGS: u32 = 3;

/// Most hair-mesh layers `L` (`hairmesh::hair_mesh::MAX_LAYERS`): sizes the strand-coherent
/// control data in shared memory.
pub const MAX_LAYERS: u32 = 64;

/// Vertices per strand slot of the strand buffer: `2^E + 1`.
pub const MAX_VERTICES: u64 = (1 << MAX_SEGMENTS_LOG2) + 1;

/// Bytes per generated vertex: `vec4(position, width)`, `vec4(tangent, tau)`.
pub const VERTEX_BYTES: u64 = 32;

/// A fused consumer may split its dispatch over the live strand slots into two
/// ([`crate::SlotSubset`]): every `SPARSE_SLOT_STRIDE`-th slot (an even sample of the whole hair,
/// for a first pass whose results let the second skip work), then the others.
pub const SPARSE_SLOT_STRIDE: u32 = 8;

/// The specialization constant `DISPATCH_WORKERS` of `dispatch_order.glsl`, which the backend
/// sets on every compute pipeline ([`crate::Context::dispatch_workers`]).
pub const DISPATCH_WORKERS_CONSTANT_ID: u32 = 16;

/// Specialization constant ids from this one on belong to a consumer's fragment stage
/// ([`crate::FragmentStage::specialization`]); gen-gpu's own are below it.
pub const FIRST_CONSUMER_CONSTANT_ID: u32 = 32;

/// Every constant of the header, as `(GLSL macro, value)`.
pub const GLSL_DEFINES: &[(&str, u64)] = &[
    ("HK_BINDING_GEN_PARAMS", binding::GEN_PARAMS as u64),
    ("HK_BINDING_BUNDLES", binding::BUNDLES as u64),
    ("HK_BINDING_ROOT_SAMPLES", binding::ROOT_SAMPLES as u64),
    ("HK_BINDING_SAMPLE_SETS", binding::SAMPLE_SETS as u64),
    ("HK_BINDING_HAIR_MESH_TEXTURE", binding::HAIR_MESH_TEXTURE as u64),
    ("HK_BINDING_U_TEXTURE", binding::U_TEXTURE as u64),
    ("HK_BINDING_V_TEXTURE", binding::V_TEXTURE as u64),
    ("HK_BINDING_HEAD_FIELD", binding::HEAD_FIELD as u64),
    ("HK_BINDING_BUNDLE_LODS", binding::BUNDLE_LODS as u64),
    ("HK_BINDING_STRAND_OFFSETS", binding::STRAND_OFFSETS as u64),
    ("HK_BINDING_STRAND_VERTICES", binding::STRAND_VERTICES as u64),
    ("HK_BINDING_STRAND_INFO", binding::STRAND_INFO as u64),
    ("HK_BINDING_FIRST_CONSUMER", binding::FIRST_CONSUMER as u64),
    ("HK_BINDING_DIAGNOSTIC_OUTPUT", binding::DIAGNOSTIC_OUTPUT as u64),
    ("HK_LOCATION_POSITION_TAU", location::POSITION_TAU as u64),
    ("HK_LOCATION_TANGENT_RANDOM", location::TANGENT_RANDOM as u64),
    ("HK_LOCATION_COVERAGE_SIDE", location::COVERAGE_SIDE as u64),
    ("HK_FRAGMENT_PUSH_OFFSET", FRAGMENT_PUSH_OFFSET as u64),
    ("HK_MAX_SEGMENTS_LOG2", MAX_SEGMENTS_LOG2 as u64),
    ("HK_MAX_VERTICES", MAX_VERTICES),
    ("HK_MAX_LAYERS", MAX_LAYERS as u64),
    ("HK_HEAD_PUSH_STEPS", HEAD_PUSH_STEPS as u64),
    ("HK_HEAD_PUSH_HALVINGS", HEAD_PUSH_HALVINGS as u64),
    ("HK_SPARSE_SLOT_STRIDE", SPARSE_SLOT_STRIDE as u64),
    ("HK_DISPATCH_WORKERS_CONSTANT_ID", DISPATCH_WORKERS_CONSTANT_ID as u64),
];

/// Every binding number a gen-gpu shader may use.
pub const BINDINGS: &[u32] = &[
    binding::GEN_PARAMS,
    binding::BUNDLES,
    binding::ROOT_SAMPLES,
    binding::SAMPLE_SETS,
    binding::HAIR_MESH_TEXTURE,
    binding::U_TEXTURE,
    binding::V_TEXTURE,
    binding::HEAD_FIELD,
    binding::BUNDLE_LODS,
    binding::STRAND_OFFSETS,
    binding::STRAND_VERTICES,
    binding::STRAND_INFO,
];

/// File name of the generated header.
pub const HEADER_FILE: &str = "hk_gen_contract.glsl";
