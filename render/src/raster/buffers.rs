//! The compute rasterizer's per-frame buffers: the per-pixel words, their layout, the materials
//! and the frame header, and the barriers between them and the other passes.

use super::*;

/// 64-bit words per pixel with `k` visibility slots (`pixel_stride` in `raster_common.glsl`):
/// the slots and the coverage word, and with more than one slot the threshold word.
pub fn pixel_stride(k: u32) -> u64 {
    if k == 1 { 2 } else { u64::from(k) + 2 }
}

/// The byte ranges (offset, size) of the pixel words of the pixels in `rect` (x0, y0, x1, y1;
/// exclusive ends) of a `width` pixels wide frame with `k` slots: one range per row, or one for
/// them all when the rectangle spans the whole width. The frame clears just these (the hair's
/// screen rectangle), since nothing outside it is shaded or resolved.
pub fn rect_word_ranges(rect: [u32; 4], width: u32, k: u32) -> Vec<(u64, u64)> {
    let [x0, y0, x1, y1] = rect.map(u64::from);
    let (width, bytes) = (u64::from(width), pixel_stride(k) * 8);
    let x1 = x1.min(width);
    if x0 >= x1 || y0 >= y1 {
        return Vec::new();
    }
    if x0 == 0 && x1 == width {
        return vec![(y0 * width * bytes, (y1 - y0) * width * bytes)];
    }
    (y0..y1).map(|y| ((y * width + x0) * bytes, (x1 - x0) * bytes)).collect()
}

/// The optical-depth sum (fixed point) of a pixel's coverage word: its low half, complemented
/// (`coverage_sum` in `raster_common.glsl`).
pub fn coverage_sum(word: u64) -> u64 {
    u64::from(!(word as u32))
}

/// How many of a pixel's K > 1 slots have been claimed, from its coverage word: its high half,
/// complemented (`claimed_slots` in `raster_common.glsl`; 0 with one slot).
pub fn claimed_slots(word: u64) -> u32 {
    !((word >> 32) as u32)
}

/// The visibility slots per pixel a frame gets: `wanted` (1 for opaque and blended scenes,
/// `oit_k` with OIT), fewer when [`pixel_stride`] words per pixel would not fit one storage
/// buffer.
pub fn slots_within(wanted: u32, pixels: u64, max_storage_buffer_range: u32) -> u32 {
    let words = u64::from(max_storage_buffer_range) / 8 / pixels.max(1);
    let most = if words >= 4 { words - 2 } else { 1 };
    u64::from(wanted).min(most).max(1) as u32
}

/// Side of the tiles of the occlusion test (`TILE_SIZE`).
pub const TILE_SIZE: u32 = 8;

/// Tiles per row and column of a `width × height` frame.
pub fn tile_grid(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(TILE_SIZE), height.div_ceil(TILE_SIZE))
}

/// Bit 0 of [`RasterPush::flags`]: test fragments against the occluders' depth.
pub(crate) const FLAG_SCENE_DEPTH: u32 = 1;

/// `RasterParams.flags`: the fused kernel takes its slots from the character's slot order
/// (`raster_split.comp`: the strands visible last frame first) instead of the phase's subset.
pub(crate) const FLAG_SLOT_ORDER: u32 = 2;

/// `RasterParams.flags`: the fused kernel marks the segments that reach the image
/// (`strand_raster.glsl` `mark_segment`; [`SlotOrderHistory`]).
pub(crate) const FLAG_MARK: u32 = 4;

/// `RasterParams.flags`: the phase skips what lies behind the occlusion tiles made before it
/// ([`RasterPhase::tile_culled`]).
pub(crate) const FLAG_TILES: u32 = 8;

/// `RasterMaterial` of `raster_frame.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct RasterMaterial {
    pub(crate) hair_color: [f32; 4],
    pub(crate) specular_shift: [f32; 4],
    pub(crate) specular_strength: [f32; 4],
    pub(crate) opacity: [f32; 4],
    /// The character's hair volume for AO: world → voxel coordinates, and (dims, first voxel);
    /// dims 0 without AO ([`crate::volume`]).
    pub(crate) world_to_voxel: [f32; 16],
    pub(crate) volume: [u32; 4],
    /// x: the region's first brick, y: bit 0 AO, bit 1 volume shadows.
    pub(crate) volume_info: [u32; 4],
}

/// The header of `RasterFrame` in `raster_frame.glsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct RasterFrameHeader {
    view_proj: [f32; 16],
    inv_view_proj: [f32; 16],
    eye: [f32; 4],
    forward: [f32; 4],
    size: [u32; 4],
}

/// Before a test kernel: the buffer fills that cleared its storage visible to its reads and
/// writes.
pub(crate) fn fills_to_compute(rec: &gen_gpu::Recorder<'_>) {
    rec.memory_barrier(
        (vk::PipelineStageFlags2::CLEAR, vk::AccessFlags2::TRANSFER_WRITE),
        (
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
        ),
    );
}

/// After a test kernel: its storage writes visible to the copy and host reads of a read-back.
pub(crate) fn compute_writes_to_readback(rec: &gen_gpu::Recorder<'_>) {
    rec.memory_barrier(
        (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
        (
            vk::PipelineStageFlags2::COPY | vk::PipelineStageFlags2::HOST,
            vk::AccessFlags2::TRANSFER_READ | vk::AccessFlags2::HOST_READ,
        ),
    );
}

/// One frame's buffers of the compute rasterizer (from the renderer's transient pool).
#[derive(Debug)]
pub(crate) struct RasterBuffers {
    /// Per pixel the visibility word and the (complemented) coverage word.
    pub(crate) pixel_words: Buffer,
    /// The camera and materials of the shade and resolve passes (host-written).
    pub(crate) frame: Buffer,
    /// Each pixel's nearest fragment shaded (the shade pass → the resolve).
    pub(crate) shaded: Buffer,
    /// The occlusion tiles (the tile pass → the rest of the strands).
    pub(crate) tiles: Buffer,
    /// The pixels the frame's hair can cover (x0, y0, x1, y1; exclusive ends): the shade pass
    /// and the resolve run over just these.
    pub(crate) rect: [u32; 4],
    /// Visibility slots per pixel (the K nearest fragments).
    pub(crate) k: u32,
    /// `[pixels whose fragments exceed their K slots, …]`.
    pub(crate) counters: Buffer,
    /// The occluders' depth, copied from the depth attachment (when there are occluders).
    pub(crate) scene_depth: Option<Buffer>,
}

/// What sizes and fills one frame's [`RasterBuffers`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct RasterFrameDesc<'a> {
    pub(crate) view: &'a crate::camera::FrameView,
    pub(crate) materials: &'a [RasterMaterial],
    pub(crate) light_count: usize,
    pub(crate) occluders: bool,
    /// See [`RasterBuffers::rect`].
    pub(crate) rect: [u32; 4],
    /// Visibility slots wanted per pixel (see [`slots_within`]).
    pub(crate) k: u32,
}

impl RasterBuffers {
    /// Takes the buffers for the frame from `pool` and writes the camera and the materials (at
    /// most [`MAX_MATERIALS`]).
    pub(crate) fn new(
        ctx: &Context,
        pool: &mut TransientPool,
        desc: &RasterFrameDesc<'_>,
    ) -> gen_gpu::Result<Self> {
        let RasterFrameDesc { view, materials, light_count, occluders, rect, k } = *desc;
        let pixels = u64::from(view.width) * u64::from(view.height);
        let transfer = vk::BufferUsageFlags::TRANSFER_DST;
        let k = slots_within(k, pixels, ctx.capabilities().max_storage_buffer_range);
        let pixel_words = pool.buffer(
            ctx,
            "visibility + coverage",
            BufferDesc::storage(pixels * pixel_stride(k) * 8).usage(transfer),
        )?;
        let counters = pool.buffer(
            ctx,
            "raster counters",
            BufferDesc::storage(16)
                .usage(transfer | vk::BufferUsageFlags::TRANSFER_SRC)
                .location(MemoryLocation::GpuToCpu),
        )?;
        let scene_depth = if occluders {
            Some(pool.buffer(
                ctx,
                "occluder depth (copy)",
                BufferDesc::storage(pixels * 4).usage(transfer),
            )?)
        } else {
            None
        };
        let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
        let forward = (view.camera.target - view.camera.eye).normalize_or(Vec3::NEG_Z);
        let header = RasterFrameHeader {
            view_proj: view_proj.to_cols_array(),
            inv_view_proj: view_proj.inverse().to_cols_array(),
            eye: view.camera.eye.extend(light_count as f32).to_array(),
            forward: forward.extend(0.0).to_array(),
            size: [view.width, view.height, 0, 0],
        };
        let mut bytes = bytemuck::bytes_of(&header).to_vec();
        bytes.extend_from_slice(bytemuck::cast_slice(&materials[..materials.len().min(MAX_MATERIALS)]));
        let mut frame = pool.buffer(
            ctx,
            "raster frame",
            BufferDesc::storage(bytes.len() as u64).location(MemoryLocation::CpuToGpu),
        )?;
        match frame.mapped_mut() {
            Some(m) if m.len() >= bytes.len() => m[..bytes.len()].copy_from_slice(&bytes),
            _ => ctx.write_buffer(&mut frame, 0, &bytes)?,
        }
        let shaded = pool.buffer(ctx, "shaded hair", BufferDesc::storage(pixels * 16))?;
        let (tx, ty) = tile_grid(view.width, view.height);
        let tile_bytes = u64::from(crate::contract::RASTER_TILE_WORDS) * 4;
        let tiles =
            pool.buffer(ctx, "occlusion tiles", BufferDesc::storage(u64::from(tx * ty) * tile_bytes))?;
        Ok(Self { pixel_words, frame, shaded, tiles, rect, k, counters, scene_depth })
    }

    pub(crate) fn give_back(self, pool: &mut TransientPool) {
        pool.give_back_buffer(self.pixel_words);
        pool.give_back_buffer(self.frame);
        pool.give_back_buffer(self.shaded);
        pool.give_back_buffer(self.tiles);
        pool.give_back_buffer(self.counters);
        if let Some(d) = self.scene_depth {
            pool.give_back_buffer(d);
        }
    }
}

/// The pixel rectangle (x0, y0, x1, y1; exclusive ends) that the hair inside `boxes` (object
/// bounds and their object → world transforms) can cover seen through `view_proj` in a
/// `width × height` frame: the projected corners' box, widened by the widest strand and the
/// resolve's filter; the whole frame when a box reaches behind the camera.
pub fn screen_rect(
    view_proj: Mat4,
    width: u32,
    height: u32,
    boxes: impl IntoIterator<Item = (Mat4, (Vec3, Vec3))>,
) -> [u32; 4] {
    use crate::camera::BoxOnScreen;
    let mut lo = glam::Vec2::splat(f32::INFINITY);
    let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
    let size = glam::Vec2::new(width as f32, height as f32);
    for (transform, (a, b)) in boxes {
        match crate::camera::project_box(view_proj * transform, a, b, width, height) {
            BoxOnScreen::InFront { lo: l, hi: h } => (lo, hi) = (lo.min(l), hi.max(h)),
            // Conservative: a box behind the camera is rare enough not to special-case.
            BoxOnScreen::Straddling | BoxOnScreen::Behind => return [0, 0, width, height],
        }
    }
    if lo.x > hi.x {
        return [0, 0, 0, 0];
    }
    let margin = MAX_HALF_WIDTH_PIXELS + 2.0;
    let lo = (lo - margin).floor().clamp(glam::Vec2::ZERO, size);
    let hi = (hi + margin).ceil().clamp(glam::Vec2::ZERO, size);
    [lo.x as u32, lo.y as u32, hi.x as u32, hi.y as u32]
}
