//! The compute strand rasterizer: hair drawn without the triangle pipeline, the fast path on
//! CPU devices (lavapipe rasterizes pixel-thin ribbons at 5–9 M triangles/s).
//!
//! Per frame (`docs/architecture.md` has the graph):
//! 1. **clear** the per-pixel words: K visibility words (the K nearest fragments; K = 1 for
//!    opaque and blended scenes, `oit_k` with OIT) and a coverage word;
//! 2. **raster**: per character, one invocation per live strand slot generates the strand
//!    (gen-gpu's strand-coherent evaluation, `hair_gen.glsl`, fused: no strand buffer) and
//!    walks each segment along its screen-space major axis; every pixel its footprint overlaps
//!    gets a visibility word (view depth, then the shading inputs) inserted among its K nearest
//!    (`atomicMin` with one slot; with more, while the slots are filling, the next slot
//!    claimed by the same atomic that adds the fragment's coverage, then a compare-and-swap
//!    replacing the farthest of the unordered slots), and its alpha's optical depth added to
//!    the coverage word
//!    (`strand_raster.glsl`; stored strands go through the same segment code,
//!    `hair_raster_stored.comp`); a character whose bounds lie wholly inside the view volume's
//!    depth goes through the kernels' variant without depth clipping ([`DepthClipping`]).
//!    Occluders hide hair through a copy of their depth buffer. The
//!    strands go in two phases around the **occlusion tiles**, which let the second skip what
//!    lies behind opaque 8×8 tiles without changing a pixel;
//! 3. **shade**: each pixel's K fragments sorted, shaded with the triangle path's `shade_hair`
//!    and composited front to back, the rest behind them with the K-th's colour;
//! 4. **resolve**: each pixel's colour averaged with its 3×3 neighbours' at about its depth (a
//!    pixel of sub-pixel strands stands for several strands; its neighbours' fragments sample
//!    them), composited at alpha `1 − exp(−Σ optical depth)` over the target, writing depth.
//!
//! Scenes in `"opaque"` and `"blended"` transparency draw alike here: every fragment's coverage
//! counts (the density blended mode keeps, and what OIT's alpha is), the nearest fragment gives
//! the colour. A pixel thus never loses the coverage of strands behind a sub-pixel strand, as
//! the triangle raster's opaque mode does.
//!
//! Memory is `8·(K + 1) + 16` bytes per pixel with one slot, `8·(K + 2) + 16` with more (a
//! threshold word), plus the materials: independent of the strand count. The visibility word
//! (layout in `raster_common.glsl`) holds the shading inputs themselves — view depth (relative resolution 2⁻¹⁴), the material, an octahedral world
//! tangent (9 + 9 bits), τ and the strand random (5 bits each), the coverage (4 bits) — so
//! nothing re-generates a strand. The CPU port of the kernel ([`crate::cpu::raster`]) is what
//! the GPU results are tested against.
//!
//! Here: which rasterizer a scene gets ([`resolve_raster`]); in `pipelines` the kernels and
//! their variants, in `buffers` the per-pixel words and per-frame buffers, in `order` the
//! drawing order (phases, slot orders, the second front eighth), in `push` the push constants.

use gen_gpu::{
    Binding, Buffer, BufferDesc, ComputePipelineDesc, Context, MemoryLocation, Pipeline, SlotSubset, vk,
};
use glam::{Mat4, Vec3};

use crate::contract::{
    DEPTH_CLIPPING_CONSTANT_ID, FUSED_STRANDS_CONSTANT_ID, FUSED_STRANDS_STRAIGHT, FUSED_STRANDS_STYLED,
    GENERATED_RASTER_BINDINGS, LOAD_BY_ADDRESS_CONSTANT_ID, ONLY_MATERIAL_CONSTANT_ID, RASTER_BINDINGS,
    RASTER_SHADE_BINDINGS, RASTER_SPLIT_BINDINGS, RASTER_TILE_BINDINGS, RESOLVE_BINDINGS,
    VISIBILITY_SLOTS_CONSTANT_ID, scene_lights_constant,
};
use crate::graph::TransientPool;
use crate::scene::{Effects, Raster};
use crate::shaders;

mod buffers;
mod order;
mod pipelines;
mod push;
#[cfg(test)]
mod tests;

pub(crate) use buffers::{
    FLAG_MARK, FLAG_SCENE_DEPTH, FLAG_SLOT_ORDER, FLAG_TILES, RasterBuffers, RasterFrameDesc, RasterMaterial,
    compute_writes_to_readback, fills_to_compute,
};
pub use buffers::{
    TILE_SIZE, claimed_slots, coverage_sum, pixel_stride, rect_word_ranges, screen_rect, slots_within,
    tile_grid,
};
pub use order::{
    RasterPhase, SECOND_FRONT_MIN_DETAIL, SECOND_FRONT_MIN_STRANDS, SLOT_ORDER_BUDGET_BYTES, StrandOrder,
    second_front_pays,
};
pub(crate) use order::{
    SLOT_ORDER_ENTRY_BYTES, SLOT_ORDER_HEADER, SLOT_ORDER_REST_DISPATCH, SlotOrderHistory,
};
pub use pipelines::{ComputeRaster, DepthClipping, FusedStrands, LoadPath, straight_strand};
pub(crate) use push::{
    RasterPush, ResolvePush, SHADE_FINAL_DEPTH, ShadePush, SplitPush, TilePush, raster_push,
    stored_group_size,
};

/// Most hair materials (distinct colour/variation/specular settings) one frame may hold: the
/// visibility word has 10 bits for it (`MAX_MATERIALS` in `raster_common.glsl`).
pub const MAX_MATERIALS: usize = 1024;

/// Strands wider than this many pixels are drawn this wide: bounds the work of one segment
/// (a column spans at most `2 × 64 + 1` pixels).
pub const MAX_HALF_WIDTH_PIXELS: f32 = 64.0;

/// Fixed-point units per unit of optical depth in the coverage buffer (`COVERAGE_SCALE`).
pub const COVERAGE_SCALE: f32 = 256.0;

/// The rasterizer a renderer uses, once a scene's `"raster"` choice is resolved for a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterPath {
    /// Camera-facing strips through the hardware (or lavapipe's) triangle pipeline.
    Triangles,
    /// The compute rasterizer of this module.
    Compute,
}

impl std::fmt::Display for RasterPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Triangles => "triangles",
            Self::Compute => "compute",
        })
    }
}

/// Why the compute rasterizer cannot draw a scene's effects on a device (`None`: it can).
pub fn compute_unavailable(effects: &Effects, caps: &gen_gpu::Capabilities) -> Option<String> {
    if !caps.buffer_int64_atomics {
        Some(format!("{} has no 64-bit buffer atomics (shaderBufferInt64Atomics)", caps.device_name))
    } else if effects.msaa > 1 {
        Some("MSAA applies to the triangle raster (the compute rasterizer has its own coverage AA)".into())
    } else {
        None
    }
}

/// Resolves a scene's choice: `auto` takes the compute rasterizer on CPU devices whenever it
/// can draw the scene's effects, the triangle raster otherwise; `compute` is an error where it
/// cannot.
pub fn resolve_raster(
    choice: Raster,
    effects: &Effects,
    caps: &gen_gpu::Capabilities,
) -> Result<RasterPath, crate::RenderError> {
    let unavailable = compute_unavailable(effects, caps);
    match choice {
        Raster::Triangles => Ok(RasterPath::Triangles),
        Raster::Compute => match unavailable {
            None => Ok(RasterPath::Compute),
            Some(why) => Err(crate::RenderError::RasterUnavailable { why }),
        },
        // The volume LOD path draws through the compute rasterizer's visibility buffer.
        Raster::Auto if effects.volume_lod => match unavailable {
            None => Ok(RasterPath::Compute),
            Some(why) => Err(crate::RenderError::RasterUnavailable {
                why: format!("effects.volume_lod needs the compute rasterizer: {why}"),
            }),
        },
        Raster::Auto => Ok(if caps.is_cpu() && unavailable.is_none() {
            RasterPath::Compute
        } else {
            RasterPath::Triangles
        }),
    }
}
