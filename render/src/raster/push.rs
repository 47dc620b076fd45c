//! The compute rasterizer's push-constant blocks, mirrored from its shaders (sizes asserted).

use super::*;

/// `RasterParams` push constants of `strand_raster.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct RasterPush {
    /// Object → world, its linear part (a GLSL `mat3`: three columns padded to 16 bytes).
    pub(crate) model: [f32; 12],
    pub(crate) material: u32,
    pub(crate) slots: u32,
    pub(crate) flags: u32,
    pub(crate) max_half_width: f32,
    /// The phase: the [`SlotSubset`] this dispatch draws (`SLOT_SUBSET_SPARSE`, … in
    /// `hair_outputs.glsl`).
    pub(crate) phase: u32,
    pub(crate) tiles_x: u32,
    pub(crate) k: u32,
    pub(crate) opacity: f32,
    /// The character's share of the transition band drawn by its volume ([`crate::volume`]).
    pub(crate) volume_fraction: f32,
    /// Fused generation: which of each bundle's strands the phase's slots draw
    /// ([`RasterPhase::part`]; `front_first_strand` in `hair_raster.comp`).
    pub(crate) strand_part: u32,
    /// Device addresses of the visibility + coverage words, of the occlusion tiles and of the
    /// occluders' depth: the kernel's plain loads read through them (0: through the bindings).
    pub(crate) words_address: u64,
    pub(crate) tiles_address: u64,
    pub(crate) scene_depth_address: u64,
    /// Stored strands: the bound chunk's vertices (0: through the binding).
    pub(crate) vertices_address: u64,
    /// Fused generation: the last frame's depths ([`FLAG_MARK`]; 0: through the binding).
    pub(crate) final_depth_address: u64,
}

// Vulkan guarantees 128 bytes of push constants.
const _: () = assert!(size_of::<RasterPush>() == 128);

/// The split kernel's push constants (raster_split.comp `SplitParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct SplitPush {
    /// 1 when the marks are the last frame's, 0 when there are none (the sparse slots first).
    pub(crate) history: u32,
}

/// `ShadePush.flags`: write each pixel's K-th nearest depth for the next frame's slot order
/// ([`SlotOrderHistory`]).
pub(crate) const SHADE_FINAL_DEPTH: u32 = 1;

/// The tile kernel's push constants (raster_tiles.comp `TileParams`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct TilePush {
    /// The frame's width and height in pixels.
    pub(crate) size: [u32; 2],
    /// Tiles per row and column ([`tile_grid`]).
    pub(crate) tiles: [u32; 2],
    pub(crate) k: u32,
    /// 0: each tile's own word from its pixels; 1: the squares' words from the own words.
    pub(crate) stage: u32,
    pub(crate) pad: [u32; 2],
    /// The cleared pixels ([`RasterBuffers::rect`]).
    pub(crate) rect: [u32; 4],
}

/// The resolve kernel's push constants (raster_resolve.comp `ResolveParams`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ResolvePush {
    /// The pixels the shade pass wrote, and the resolve ([`RasterBuffers::rect`]).
    pub(crate) rect: [u32; 4],
    /// rgb: the background; w: 1 when the output buffers hold the occluders' image.
    pub(crate) background: [f32; 4],
    pub(crate) k: u32,
    pub(crate) pad: u32,
    /// The shaded colours' device address (0: read through the binding).
    pub(crate) shaded_address: u64,
}

/// The shade kernel's push constants (raster_shade.comp `Rect`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct ShadePush {
    pub(crate) rect: [u32; 4],
    pub(crate) k: u32,
    /// [`SHADE_FINAL_DEPTH`], or 0.
    pub(crate) flags: u32,
    pub(crate) words_address: u64,
    pub(crate) shadow_depth_address: u64,
    pub(crate) shadow_opacity_address: u64,
    pub(crate) occluder_depth_address: u64,
}

/// The push constants of one character's raster dispatch in `phase` (its slot subset, its
/// strand part, and the tile test when the phase is tile-culled).
#[allow(clippy::too_many_arguments, reason = "one field each of the push constants")]
pub(crate) fn raster_push(
    transform: Mat4,
    material: u32,
    slots: u32,
    occluders: bool,
    phase: RasterPhase,
    tiles_x: u32,
    k: u32,
    opacity: f32,
) -> RasterPush {
    RasterPush {
        model: {
            let [x, y, z, _] = transform.to_cols_array_2d();
            [x[0], x[1], x[2], 0.0, y[0], y[1], y[2], 0.0, z[0], z[1], z[2], 0.0]
        },
        material,
        slots,
        flags: if occluders { FLAG_SCENE_DEPTH } else { 0 }
            | if phase.tile_culled() { FLAG_TILES } else { 0 },
        max_half_width: MAX_HALF_WIDTH_PIXELS,
        phase: phase.subset as u32,
        tiles_x,
        k,
        opacity,
        volume_fraction: 0.0,
        strand_part: phase.part,
        words_address: 0,
        tiles_address: 0,
        scene_depth_address: 0,
        vertices_address: 0,
        final_depth_address: 0,
    }
}

/// Workgroup size of the stored-strand kernel (from its SPIR-V).
pub(crate) fn stored_group_size() -> u32 {
    shaders::HAIR_RASTER_STORED_COMP.workgroup_size[0]
}
