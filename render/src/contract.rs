//! render's side of the generator → consumer contract: the bindings its fragment stages add to
//! gen-gpu's strand pipelines (from `gen_gpu::contract::binding::FIRST_CONSUMER` on) and the
//! bindings of its own pipelines (occluder meshes).
//!
//! `build.rs` writes these constants into `hk_render_contract.glsl`; render's GLSL takes every
//! binding from that header or from gen-gpu's `hk_gen_contract.glsl` (literals fail the build,
//! and so does a binding neither contract declares).

/// Bindings render's fragment stages add to a strand pipeline (set 0), and their own pipelines'.
pub mod binding {
    /// OIT: per-pixel list heads (`oit.glsl`).
    pub const OIT_HEADS: u32 = 12;
    /// OIT: the node pool.
    pub const OIT_NODES: u32 = 13;
    /// OIT: next free node, pool size, overflow count, width.
    pub const OIT_COUNTERS: u32 = 14;
    /// Deep opacity maps: nearest hair depth per texel (`lighting.glsl`, `shadow_opacity.frag`).
    pub const SHADOW_DEPTH: u32 = 15;
    /// Deep opacity maps: opacity at the end of each layer.
    pub const SHADOW_OPACITY: u32 = 16;
    /// The scene's lights (`SceneLight`).
    pub const LIGHTS: u32 = 17;
    /// Nearest occluder depth per shadow-map texel.
    pub const OCCLUDER_DEPTH: u32 = 18;
    /// Compute rasterizer: per pixel a visibility word (view depth and the nearest fragment's
    /// shading attributes) and a coverage word (accumulated optical depth), 64 bits each
    /// (`raster_common.glsl`).
    pub const VISIBILITY: u32 = 19;
    /// Compute rasterizer: a character's strand slots in drawing order — those whose strands
    /// were visible last frame, then the others — with each part's indirect dispatch
    /// (`raster_split.comp`).
    pub const RASTER_SLOTS: u32 = 20;
    /// Compute rasterizer: the frame's camera and the hair materials (`RasterFrame`).
    pub const RASTER_FRAME: u32 = 21;
    /// Compute rasterizer: the occluders' depth per pixel (a copy of the scene depth buffer).
    pub const SCENE_DEPTH: u32 = 22;
    /// Compute rasterizer: each pixel's nearest fragment shaded (colour, view depth).
    pub const SHADED: u32 = 23;
    /// Compute rasterizer: per 8×8 tile, the farthest nearest depth when the tile is opaque.
    pub const RASTER_TILES: u32 = 24;
    /// Compute rasterizer: counters (pixels whose fragments exceed their K slots).
    pub const RASTER_COUNTERS: u32 = 25;
    /// Hair volumes: per voxel the mean strand direction and the area density σ
    /// (`crate::volume`; every hair's region side by side).
    pub const VOLUME: u32 = 26;
    /// Hair volumes: per voxel the ambient occlusion (1 = none).
    pub const VOLUME_AO: u32 = 27;
    /// Compute rasterizer's resolve: the frame's colour, RGBA16F per pixel (its readback buffer).
    pub const OUTPUT_COLOR: u32 = 30;
    /// Compute rasterizer's resolve: the frame's depth, f32 per pixel (its readback buffer).
    pub const OUTPUT_DEPTH: u32 = 31;
    /// Compute rasterizer: one bit per strand slot of a character, set when a fragment of the
    /// strand lies at or in front of its pixel's K-th nearest depth of the previous frame
    /// (kept from frame to frame: the next frame draws those strands first).
    pub const RASTER_MARKS: u32 = 32;
    /// Compute rasterizer: per pixel the depth bits of its K-th nearest fragment at the end of
    /// the last frame (all ones: fewer than K), written by the shade pass.
    pub const RASTER_FINAL_DEPTH: u32 = 33;
    /// Voxelization: per voxel the 64-bit fixed-point sums of area and area × direction.
    pub const VOXEL_SUMS: u32 = 28;
    /// Hair volumes: per brick of 4³ voxels, 1 when a trilinear sample inside it can see hair.
    pub const VOLUME_BRICKS: u32 = 29;
    /// Occluder pipelines (their own layout, not a strand pipeline): positions.
    pub const OCCLUDER_POSITIONS: u32 = 0;
    /// Occluder pipelines: normals.
    pub const OCCLUDER_NORMALS: u32 = 1;
    /// Occluder pipelines: triangle indices.
    pub const OCCLUDER_INDICES: u32 = 2;
}

/// The bindings of `lighting.glsl`, in the order the shading binds them.
pub const LIGHTING_BINDINGS: [u32; 4] =
    [binding::SHADOW_DEPTH, binding::SHADOW_OPACITY, binding::LIGHTS, binding::OCCLUDER_DEPTH];

/// What the compute rasterizer's raster kernels add to the strand bindings.
pub const RASTER_BINDINGS: [u32; 3] = [binding::VISIBILITY, binding::SCENE_DEPTH, binding::RASTER_TILES];

/// What the compute rasterizer's fused-generation kernel adds to the strand bindings besides
/// [`RASTER_BINDINGS`]: its slot order, the marks it sets, the last frame's depths it tests.
pub const GENERATED_RASTER_BINDINGS: [u32; 6] =
    concat(RASTER_BINDINGS, [binding::RASTER_SLOTS, binding::RASTER_MARKS, binding::RASTER_FINAL_DEPTH]);

/// What the compute rasterizer's split pass adds to the strand bindings.
pub const RASTER_SPLIT_BINDINGS: [u32; 2] = [binding::RASTER_SLOTS, binding::RASTER_MARKS];

/// The compute rasterizer's tile pass.
pub const RASTER_TILE_BINDINGS: [u32; 2] = [binding::VISIBILITY, binding::RASTER_TILES];

/// What the voxelization kernel adds to the strand bindings.
pub const VOXELIZE_BINDINGS: [u32; 1] = [binding::VOXEL_SUMS];

/// The volume resolve: sums in, the volume (and AO initialised to none) out.
pub const VOLUME_RESOLVE_BINDINGS: [u32; 3] = [binding::VOXEL_SUMS, binding::VOLUME, binding::VOLUME_AO];

/// The volume bricks pass.
pub const VOLUME_BRICK_BINDINGS: [u32; 2] = [binding::VOLUME, binding::VOLUME_BRICKS];

/// The volume AO pass.
pub const VOLUME_AO_BINDINGS: [u32; 2] = [binding::VOLUME, binding::VOLUME_AO];

/// The volume raymarch: the volume in, fragments into the compute rasterizer's visibility buffer.
pub const MARCH_BINDINGS: [u32; 5] = [
    binding::VOLUME,
    binding::VOLUME_BRICKS,
    binding::VISIBILITY,
    binding::RASTER_FRAME,
    binding::SCENE_DEPTH,
];

/// The compute rasterizer's shade pass: its own buffers, the volumes (AO, volume shadows), then
/// the lighting.
pub const RASTER_SHADE_BINDINGS: [u32; 12] = [
    binding::VISIBILITY,
    binding::RASTER_FRAME,
    binding::SHADED,
    binding::RASTER_COUNTERS,
    binding::RASTER_FINAL_DEPTH,
    binding::VOLUME_AO,
    binding::VOLUME,
    binding::VOLUME_BRICKS,
    LIGHTING_BINDINGS[0],
    LIGHTING_BINDINGS[1],
    LIGHTING_BINDINGS[2],
    LIGHTING_BINDINGS[3],
];

/// The compute rasterizer's resolve: its inputs, then the frame's image (readback buffers).
pub const RESOLVE_BINDINGS: [u32; 5] = [
    binding::VISIBILITY,
    binding::RASTER_FRAME,
    binding::SHADED,
    binding::OUTPUT_COLOR,
    binding::OUTPUT_DEPTH,
];

/// The OIT buffers (`oit.glsl`).
pub const OIT_BINDINGS: [u32; 3] = [binding::OIT_HEADS, binding::OIT_NODES, binding::OIT_COUNTERS];

/// What the hair fragment stages read of the hair volumes (AO, volume shadows;
/// `hair_fragment.glsl`), in the order the draws bind them.
pub const FRAGMENT_VOLUME_BINDINGS: [u32; 3] = [binding::VOLUME, binding::VOLUME_AO, binding::VOLUME_BRICKS];

/// `a` then `b` (for the binding lists below).
const fn concat<const A: usize, const B: usize, const N: usize>(a: [u32; A], b: [u32; B]) -> [u32; N] {
    let mut out = [0; N];
    let mut i = 0;
    while i < N {
        out[i] = if i < A { a[i] } else { b[i - A] };
        i += 1;
    }
    out
}

/// The shaded hair fragment stage's buffers: the lighting, then the volumes.
pub const HAIR_FRAGMENT_BINDINGS: [u32; 7] = concat(LIGHTING_BINDINGS, FRAGMENT_VOLUME_BINDINGS);

/// The OIT fill stage's buffers: the lists, the lighting, the volumes.
pub const OIT_FILL_BINDINGS: [u32; 10] = concat(OIT_BINDINGS, HAIR_FRAGMENT_BINDINGS);

/// Every constant of the header, as `(GLSL macro, value)`.
pub const GLSL_DEFINES: &[(&str, u64)] = &[
    ("HK_BINDING_OIT_HEADS", binding::OIT_HEADS as u64),
    ("HK_BINDING_OIT_NODES", binding::OIT_NODES as u64),
    ("HK_BINDING_OIT_COUNTERS", binding::OIT_COUNTERS as u64),
    ("HK_BINDING_SHADOW_DEPTH", binding::SHADOW_DEPTH as u64),
    ("HK_BINDING_SHADOW_OPACITY", binding::SHADOW_OPACITY as u64),
    ("HK_BINDING_LIGHTS", binding::LIGHTS as u64),
    ("HK_BINDING_OCCLUDER_DEPTH", binding::OCCLUDER_DEPTH as u64),
    ("HK_BINDING_VISIBILITY", binding::VISIBILITY as u64),
    ("HK_BINDING_RASTER_FRAME", binding::RASTER_FRAME as u64),
    ("HK_BINDING_RASTER_SLOTS", binding::RASTER_SLOTS as u64),
    ("HK_BINDING_RASTER_MARKS", binding::RASTER_MARKS as u64),
    ("HK_BINDING_RASTER_FINAL_DEPTH", binding::RASTER_FINAL_DEPTH as u64),
    ("HK_BINDING_SCENE_DEPTH", binding::SCENE_DEPTH as u64),
    ("HK_BINDING_SHADED", binding::SHADED as u64),
    ("HK_BINDING_RASTER_TILES", binding::RASTER_TILES as u64),
    ("HK_BINDING_RASTER_COUNTERS", binding::RASTER_COUNTERS as u64),
    ("HK_BINDING_VOLUME", binding::VOLUME as u64),
    ("HK_BINDING_VOLUME_AO", binding::VOLUME_AO as u64),
    ("HK_BINDING_VOXEL_SUMS", binding::VOXEL_SUMS as u64),
    ("HK_BINDING_VOLUME_BRICKS", binding::VOLUME_BRICKS as u64),
    ("HK_BINDING_OUTPUT_COLOR", binding::OUTPUT_COLOR as u64),
    ("HK_BINDING_OUTPUT_DEPTH", binding::OUTPUT_DEPTH as u64),
    ("HK_BINDING_OCCLUDER_POSITIONS", binding::OCCLUDER_POSITIONS as u64),
    ("HK_BINDING_OCCLUDER_NORMALS", binding::OCCLUDER_NORMALS as u64),
    ("HK_BINDING_OCCLUDER_INDICES", binding::OCCLUDER_INDICES as u64),
];

/// Specialization constant of the shading that loops over a scene's lights (the compute
/// rasterizer's shade kernel, the occluders): the scene's light count, so that the loop is
/// written out light by light with constant indices (`lighting.glsl`).
/// 32 and up: the strand pipelines' fragment stages are gen-gpu's, whose own constants are below
/// `gen_gpu::contract::FIRST_CONSUMER_CONSTANT_ID` (32; the generator checks).
pub const SCENE_LIGHTS_CONSTANT_ID: u32 = 32;

/// Lights a scene may have (`scene::MAX_LIGHTS`). `lighting.glsl` writes loops over the lights
/// out to eight turns (`FOR_EACH_SCENE_LIGHT`): change both together.
pub const MAX_LIGHTS: u32 = 8;
const _: () = assert!(MAX_LIGHTS == 8, "lighting.glsl writes out eight lights (FOR_EACH_SCENE_LIGHT)");

/// The `(constant_id, value)` specialization of a pipeline that shades a scene of `lights`
/// lights (the scene validates at most [`MAX_LIGHTS`]).
pub fn scene_lights_constant(lights: usize) -> (u32, u32) {
    (SCENE_LIGHTS_CONSTANT_ID, lights.min(MAX_LIGHTS as usize) as u32)
}

/// Specialization constant of the compute rasterizer's shade kernel: the scene's only hair
/// material (0), or `u32::MAX` when it has several (`raster_shade.comp`).
pub const ONLY_MATERIAL_CONSTANT_ID: u32 = 33;

/// Specialization constant of the compute rasterizer's raster and shade kernels: 1 when they
/// read the buffers they only load from through the device addresses in their push constants,
/// 0 through their bindings (`raster::LoadPath`, `raster_common.glsl`).
pub const LOAD_BY_ADDRESS_CONSTANT_ID: u32 = 34;

/// Specialization constant of the compute rasterizer's raster kernels: 1 when they clip each
/// segment to the view volume's depth, 0 when the host found the character's bounds wholly
/// inside it (`raster::DepthClipping`, `strand_raster.glsl`).
pub const DEPTH_CLIPPING_CONSTANT_ID: u32 = 35;

/// Specialization constant of the compute rasterizer's raster, tile and shade kernels: the
/// visibility slots per pixel (K) of the frames they run in, or 0 for kernels that read K from
/// their push constants (any K: the tests' stored-strand kernels). The fused-generation kernel
/// compiles the code that takes its strands from a slot order and marks the segments that
/// reach the image (`raster_split.comp`) unless K is 1 (`raster::ComputeRaster::new`).
pub const VISIBILITY_SLOTS_CONSTANT_ID: u32 = 36;

/// Specialization constant of the compute rasterizer's fused-generation kernel: what it draws
/// of each strand (`raster::FusedStrands`): [`FUSED_STRANDS_STYLED`], the frames' strands, or
/// [`FUSED_STRANDS_STRAIGHT`], each strand as the straight line from its root to its tip through
/// the same walk, for benchmarks that separate generation's cost from rasterization's.
pub const FUSED_STRANDS_CONSTANT_ID: u32 = 37;

/// [`FUSED_STRANDS_CONSTANT_ID`]: the strands as generated (every frame).
pub const FUSED_STRANDS_STYLED: u32 = 0;

/// [`FUSED_STRANDS_CONSTANT_ID`]: straight lines from root to tip (benchmarks).
pub const FUSED_STRANDS_STRAIGHT: u32 = 1;

/// 32-bit words per 8×8 tile of the compute rasterizer's occlusion tiles (`raster_tiles.comp`
/// writes them, `strand_raster.glsl` reads them): the farthest depth of the tile's own pixels,
/// then of the 2×2 and of the 3×3 tiles it is the top left of.
pub const RASTER_TILE_WORDS: u32 = 3;

/// The compute rasterizer's coverage limit, in fixed-point units of optical depth (256 per unit,
/// `raster::COVERAGE_SCALE`): no coverage is added to a pixel past it, and a pixel at it reads
/// as opaque (`coverage_alpha` in `raster_common.glsl`, `cpu::raster::RasterBuffers::alpha`).
/// Optical depth 4.5: alpha 1 − 1.1 %. A pixel that reaches it holds at least that much hair,
/// so reading it as opaque moves its alpha by at most 1.1 %, while dense hair gets there after
/// about three times fewer fragments than at a limit of 12: the occlusion tiles close after the
/// front strands and cull more of the rest (`docs/compute-raster-notes.md`).
pub const COVERAGE_LIMIT: u32 = 1152;

/// The header's constants that are not bindings, as `(GLSL macro, value)`.
pub const GLSL_CONSTANTS: &[(&str, u64)] = &[
    ("HK_RASTER_TILE_WORDS", RASTER_TILE_WORDS as u64),
    ("HK_COVERAGE_LIMIT", COVERAGE_LIMIT as u64),
    ("HK_SCENE_LIGHTS_CONSTANT_ID", SCENE_LIGHTS_CONSTANT_ID as u64),
    ("HK_ONLY_MATERIAL_CONSTANT_ID", ONLY_MATERIAL_CONSTANT_ID as u64),
    ("HK_LOAD_BY_ADDRESS_CONSTANT_ID", LOAD_BY_ADDRESS_CONSTANT_ID as u64),
    ("HK_DEPTH_CLIPPING_CONSTANT_ID", DEPTH_CLIPPING_CONSTANT_ID as u64),
    ("HK_VISIBILITY_SLOTS_CONSTANT_ID", VISIBILITY_SLOTS_CONSTANT_ID as u64),
    ("HK_FUSED_STRANDS_CONSTANT_ID", FUSED_STRANDS_CONSTANT_ID as u64),
    ("HK_FUSED_STRANDS_STRAIGHT", FUSED_STRANDS_STRAIGHT as u64),
];

/// Every binding a render shader may use: the values of [`GLSL_DEFINES`] (all of which are
/// bindings).
pub const BINDINGS: [u32; GLSL_DEFINES.len()] = {
    let mut out = [0; GLSL_DEFINES.len()];
    let mut i = 0;
    while i < GLSL_DEFINES.len() {
        out[i] = GLSL_DEFINES[i].1 as u32;
        i += 1;
    }
    out
};

/// File name of the generated header.
pub const HEADER_FILE: &str = "hk_render_contract.glsl";
