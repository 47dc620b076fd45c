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
//! nothing re-generates a strand. The CPU port of the kernel ([`cpu`]) is what the GPU results
//! are tested against.

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

/// Bytes of a slot order's header (`raster_slots.glsl`): two indirect dispatches, the front and
/// the rest part's lengths.
pub(crate) const SLOT_ORDER_HEADER: u64 = 32;
/// Bytes of a slot order's entry: the slot and its strand's marks.
pub(crate) const SLOT_ORDER_ENTRY_BYTES: u64 = 8;
/// What [`SlotOrderHistory`] keeps per strand slot: its marks and two order entries.
pub(crate) const SLOT_ORDER_BYTES_PER_SLOT: u64 = 4 + 2 * SLOT_ORDER_ENTRY_BYTES;
/// The most the slot orders keep from frame to frame for a scene's characters' strand slots
/// (3.3 M slots; `raster_split.comp`): the characters past it draw every eighth slot first, so
/// the memory stays bounded whatever the strand count.
pub const SLOT_ORDER_BUDGET_BYTES: u64 = 64 << 20;
/// Where the rest part's indirect dispatch sits in a slot order.
pub(crate) const SLOT_ORDER_REST_DISPATCH: u64 = 12;

/// What the compute rasterizer keeps from one frame to the next so that the strand segments
/// that reached the last frame's image are drawn first (two-phase occlusion culling, per strand
/// segment): the last frame's depth per pixel, written by the shade pass, and per generated
/// character its marks and its slot order. Which segments come first changes only the order of
/// drawing — each segment is drawn in exactly one phase and the phases' result does not depend
/// on the order — so a stale or missing history (the first frames, a resized output, an edited
/// hair whose slots moved) costs time, never correctness.
#[derive(Debug, Default)]
pub(crate) struct SlotOrderHistory {
    /// The last frame's K-th nearest depth bits per pixel (0 where the pixel was not opaque),
    /// its width and height, and whether a frame has written it since it was made.
    pub(crate) final_depth: Option<(u32, u32, Buffer, bool)>,
    /// Per generated character.
    pub(crate) characters: Vec<Option<CharacterOrder>>,
}

/// One character's part of [`SlotOrderHistory`].
#[derive(Debug)]
pub(crate) struct CharacterOrder {
    /// Strand slots the buffers hold.
    pub(crate) capacity: u64,
    /// Per strand slot a mask of its segments that reached the image (`hair_raster.comp`).
    pub(crate) marks: Buffer,
    /// The frame's drawing order (`raster_slots.glsl`), made from the marks.
    pub(crate) order: Buffer,
    /// Whether the last frame that drew the character set the marks (else they are clear).
    pub(crate) history: bool,
}

/// A generated character's strands in the compute rasterizer's drawing order
/// ([`crate::frame::SceneRenderer::strand_order`], `raster_slots.glsl`): per entry its slot and
/// its strand's marks from the last frame (bit `i * 32 / segments` of segment `i`; all ones:
/// drawn whole) — the front phase walks the marked segments, the rest the others —; the front
/// phase's entries, then the rest's.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StrandOrder {
    pub front: Vec<[u32; 2]>,
    pub rest: Vec<[u32; 2]>,
}

/// Which of characters of `capacities` strand slots get a slot order: those, in scene order,
/// whose history fits [`SLOT_ORDER_BUDGET_BYTES`] together with the ones before them.
pub(crate) fn within_slot_order_budget(capacities: &[u64]) -> Vec<bool> {
    let mut bytes = 0u64;
    capacities
        .iter()
        .map(|&capacity| {
            bytes = bytes.saturating_add(capacity.max(1).saturating_mul(SLOT_ORDER_BYTES_PER_SLOT));
            bytes <= SLOT_ORDER_BUDGET_BYTES
        })
        .collect()
}

impl SlotOrderHistory {
    /// The last frame's depths per pixel, once made.
    pub(crate) fn final_depth_buffer(&self) -> Option<&Buffer> {
        self.final_depth.as_ref().map(|(_, _, buffer, _)| buffer)
    }

    /// Whether this frame's raster marks segments: against depths a frame has written.
    pub(crate) fn marking(&self) -> bool {
        matches!(self.final_depth, Some((_, _, _, true)))
    }

    /// Makes the buffers for a `width × height` frame and characters of `capacities` slots
    /// where they are missing or too small (new ones have no history).
    pub(crate) fn prepare(
        &mut self,
        ctx: &Context,
        width: u32,
        height: u32,
        capacities: &[u64],
    ) -> gen_gpu::Result<()> {
        if !matches!(&self.final_depth, Some((w, h, _, _)) if (*w, *h) == (width, height)) {
            let pixels = u64::from(width) * u64::from(height);
            // Zero: no pixel known to be opaque, so nothing is marked against it.
            let buffer = ctx.create_buffer_with_data(
                "hair depth (last frame)",
                BufferDesc::storage(pixels * 4),
                &vec![0u8; (pixels * 4) as usize],
            )?;
            self.final_depth = Some((width, height, buffer, false));
        }
        self.characters.resize_with(capacities.len(), || None);
        let within = within_slot_order_budget(capacities);
        for ((character, &capacity), within) in self.characters.iter_mut().zip(capacities).zip(within) {
            if !within {
                // No entry: the character keeps the sparse front (record_raster falls back).
                *character = None;
                continue;
            }
            if !matches!(character, Some(c) if c.capacity >= capacity) {
                let slots = capacity.max(1);
                let marks = ctx.create_buffer_with_data(
                    "strand marks",
                    BufferDesc::storage(slots * 4),
                    &vec![0u8; (slots * 4) as usize],
                )?;
                // Both parts may hold every slot.
                let order = Buffer::new(
                    ctx,
                    "strand slot order",
                    BufferDesc::storage(SLOT_ORDER_HEADER + slots * 2 * SLOT_ORDER_ENTRY_BYTES)
                        .usage(vk::BufferUsageFlags::INDIRECT_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC),
                )?;
                *character = Some(CharacterOrder { capacity, marks, order, history: false });
            }
        }
        Ok(())
    }
}

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

/// The strand LOD detail below which a character gets no second front eighth
/// ([`second_front_pays`]).
pub const SECOND_FRONT_MIN_DETAIL: f64 = 0.5;

/// The live strands per bundle below which a character gets no second front eighth
/// ([`second_front_pays`]): measured faster with it at 69 (the 100k-strand character), slower
/// at 7 (the 10k-strand one); this lies between.
pub const SECOND_FRONT_MIN_STRANDS: f64 = 32.0;

/// Whether a character's strands, generated in the raster kernel, get a second front eighth
/// ([`RasterPhase::sequence`]): when strand LOD keeps at least half of them
/// ([`SECOND_FRONT_MIN_DETAIL`]; LOD off, or the detail level of the asset's mean bundle face
/// at its bounds' centre) and its bundles keep [`SECOND_FRONT_MIN_STRANDS`] on average.
/// Measured with it: the 100k-strand close-up 2-3 % faster; the 10k-strand close-up (7 strands
/// per bundle) 3.5 % slower; the 100-head crowd at strand α 64, whose bundles keep a few
/// widened strands, 10 % slower.
pub fn second_front_pays(asset: &hairmesh::asset::HairAsset, inputs: &gen_gpu::FrameInputs) -> bool {
    let lod = &inputs.lod;
    let bundles = asset.bundles.len() as f64;
    if asset.bundles.is_empty() {
        return false;
    }
    let strands = asset.total_strands() as f64 / bundles;
    let detail = if lod.enabled {
        let face = asset.bundles.iter().map(|b| b.face_size()).sum::<f64>() / bundles;
        let (lo, hi) = asset.bounds();
        let distance = inputs.view.eye.distance(0.5 * (lo + hi));
        hairmesh::reference::detail_level(face, distance, lod.strand_alpha, &inputs.view)
    } else {
        1.0
    };
    detail >= SECOND_FRONT_MIN_DETAIL && detail * strands >= SECOND_FRONT_MIN_STRANDS
}

/// One raster dispatch of a frame's strands: the slots it takes, and with generation fused into
/// the kernel which of each bundle's strands those draw. A bundle's sparse slots (every
/// `SPARSE_SLOT_STRIDE`-th, an eighth) draw its first strands in part 0 (the front phase: any
/// prefix of a bundle's root set is blue noise, so a front eighth covers every bundle evenly)
/// and its next eighth in part 1; its other slots (the remainder) draw the strands after the
/// `part` eighths drawn before them (at least one), so that every live strand is drawn once.
/// With a slot order (`raster_split.comp`) a slot comes in either phase by its marks and draws
/// the strand part 0 gives it; such frames have two phases.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RasterPhase {
    pub subset: SlotSubset,
    pub part: u32,
}

impl RasterPhase {
    /// Every strand in one dispatch (no occlusion tiles).
    pub const ALL: Self = Self { subset: SlotSubset::All, part: 0 };

    /// The phases of a frame: with occlusion tiles the front eighth, then with `fused_parts` = 2
    /// (fused generation, where each phase's tiles pay for themselves) a second eighth against
    /// the tiles the first made, then the rest against tiles made again; else one phase.
    pub fn sequence(occlusion_tiles: bool, fused_parts: u32) -> Vec<Self> {
        if !occlusion_tiles {
            return vec![Self::ALL];
        }
        let fronts = fused_parts.clamp(1, 2);
        (0..fronts)
            .map(|part| Self { subset: SlotSubset::Sparse, part })
            .chain([Self { subset: SlotSubset::Remainder, part: fronts }])
            .collect()
    }

    /// Whether the dispatch skips what lies behind the occlusion tiles, made just before it.
    pub fn tile_culled(self) -> bool {
        self.subset == SlotSubset::Remainder || self.later_front()
    }

    /// Whether this is a front eighth after the first (fused generation only: characters
    /// without a second eighth and stored strands skip it).
    pub fn later_front(self) -> bool {
        self.subset == SlotSubset::Sparse && self.part >= 1
    }
}

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
struct RasterFrameHeader {
    view_proj: [f32; 16],
    inv_view_proj: [f32; 16],
    eye: [f32; 4],
    forward: [f32; 4],
    size: [u32; 4],
}

/// How the compute rasterizer's raster and shade kernels read the buffers they only load
/// from (pixel words, occlusion tiles, scene depth, shadow maps, stored vertices): a
/// specialization of their pipelines (`LOAD_BY_ADDRESS`, `raster_common.glsl`), so each
/// compiles one of the two loads. The image is the same either way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoadPath {
    /// Through buffer references to the device addresses in the push constants, the default
    /// where the device has buffer device addresses: CPU devices gather such loads with vector
    /// instructions, where a binding's load at a per-lane index is a loop over the lanes.
    BufferReferences,
    /// Through the descriptor bindings.
    Bindings,
}

/// What the compute rasterizer's fused-generation kernel draws of each strand: a
/// specialization of its pipelines (`FUSED_STRANDS`, `hair_raster.comp`).
///
/// [`Self::Straight`] is for measuring, not for pictures: it draws each strand as the straight
/// line from its root to its tip on the hair-mesh curve (the unstyled curve's end points, at
/// the strand's length), split into the same vertices and walked by the same rasterizer, so
/// that generating it costs two control-point loads and a lerp per vertex. The difference to a
/// [`Self::Styled`] frame of the same scene is what generating the real strands costs inside
/// the kernel (`hair-bench --only raster`, the far character's row); its CPU port is
/// [`straight_strand`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FusedStrands {
    /// The strands as the generator makes them (every frame).
    #[default]
    Styled,
    /// Straight lines from root to tip through the same walk (benchmarks).
    Straight,
}

impl FusedStrands {
    fn constant(self) -> u32 {
        match self {
            Self::Styled => FUSED_STRANDS_STYLED,
            Self::Straight => FUSED_STRANDS_STRAIGHT,
        }
    }
}

/// The points [`FusedStrands::Straight`] draws for strand `strand` of `bundle` with
/// `segments` segments: from the hair-mesh curve's point at the root (curve parameter 0) to
/// its point at the strand's length (the style's length scale), evenly spaced. Object space.
pub fn straight_strand(
    hair: &hairmesh::asset::HairAsset,
    bundle: u32,
    strand: u32,
    segments: u32,
) -> Vec<Vec3> {
    let root = hair.root_parameter(bundle, strand);
    let at = |t: f64| hair.textures.curve_point(hair.curve, bundle, root.x, root.y, t);
    let (start, end) = (at(0.0), at(1.0));
    let scale = hair.style.length_scale(bundle, strand);
    (0..=segments).map(|k| start.lerp(end, f64::from(k) / f64::from(segments) * scale).as_vec3()).collect()
}

/// Whether a character's segments need clipping to the view volume's depth (`0 ≤ z ≤ w`):
/// the raster kernels come in both variants (`DEPTH_CLIPPING`, `strand_raster.glsl`), and a
/// character wholly inside that depth range — nearly every character of nearly every frame —
/// is drawn by the one without clipping. That one carries less through its strand loop (the
/// far 100k-strand character's raster phases measured 6 % faster) and draws the same pixels
/// for such a character; the other is exact for any strand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthClipping {
    /// Every segment clipped to `0 ≤ z ≤ w` (strands through the near or far plane).
    Clip,
    /// No segment tested: the host found every vertex inside the depth range.
    Skip,
}

impl DepthClipping {
    /// What hair inside the object-space box `bounds` needs when `object_to_clip` (the
    /// matrix the kernels multiply positions by, in f32) takes it to clip space: [`Self::Skip`]
    /// only when every corner — so, clip z and w being linear, every point of the box — has
    /// `z ≥ 0` and `w − z ≥ 0` by a margin that the kernel's f32 rounding of any point of the
    /// box cannot cross, and `w` far from 0. A box that is empty, not finite or reaches
    /// outside by any amount gets [`Self::Clip`].
    pub fn for_bounds(object_to_clip: Mat4, (lo, hi): (Vec3, Vec3)) -> Self {
        if !(lo.cmple(hi).all() && lo.is_finite() && hi.is_finite() && object_to_clip.is_finite()) {
            return Self::Clip;
        }
        let m = object_to_clip.as_dmat4();
        let extent = lo.abs().max(hi.abs()).as_dvec3().extend(1.0);
        // Bounds of the magnitudes the kernel's dot products for z and w add: their f32
        // rounding (and that of the generated positions) errs by a few ulps of these (2^-23,
        // 1.2e-7, each), inside a margin of 4e-6 of them.
        let row = |r: usize| glam::DVec4::new(m.x_axis[r], m.y_axis[r], m.z_axis[r], m.w_axis[r]);
        let scale_z = row(2).abs().dot(extent);
        let scale_w = row(3).abs().dot(extent);
        let margin = 4e-6;
        let inside = crate::camera::box_corners(lo, hi).into_iter().all(|corner| {
            let clip = m * corner.as_dvec3().extend(1.0);
            clip.z >= margin * scale_z && clip.w - clip.z >= margin * (scale_z + scale_w) && clip.w > 1e-15
        });
        if inside { Self::Skip } else { Self::Clip }
    }
}

/// A raster kernel's two pipelines, with and without depth clipping ([`DepthClipping`]).
#[derive(Debug)]
pub(crate) struct ClippingVariants {
    clip: Pipeline,
    skip: Pipeline,
}

impl ClippingVariants {
    pub(crate) fn get(&self, clipping: DepthClipping) -> &Pipeline {
        match clipping {
            DepthClipping::Clip => &self.clip,
            DepthClipping::Skip => &self.skip,
        }
    }
}

/// The compute rasterizer's pipelines.
#[derive(Debug)]
pub struct ComputeRaster {
    pub(crate) raster: ClippingVariants,
    pub(crate) raster_stored: ClippingVariants,
    /// Each character's slot order before its raster phases (`raster_split.comp`).
    pub(crate) split: Pipeline,
    pub(crate) shade: Pipeline,
    pub(crate) tiles: Pipeline,
    pub(crate) resolve: Pipeline,
    /// Bound at the scene-depth binding when there are no occluders, and at the tiles' in
    /// single-phase dispatches (never read then).
    pub(crate) no_scene_depth: Buffer,
    loads: LoadPath,
    /// The visibility slots per pixel the kernels were specialized for (`None`: any).
    slots: Option<u32>,
    /// What the fused-generation kernel draws of each strand.
    fused: FusedStrands,
}

impl ComputeRaster {
    /// The pipelines for a scene of `lights` lights (at most [`crate::scene::MAX_LIGHTS`]) and
    /// `materials` distinct hair materials, reading as `loads` says (buffer references only
    /// where the device has buffer device addresses: else through the bindings): the shade
    /// kernel is specialized for the light count and for a single material; the raster, tile
    /// and shade kernels for `slots` visibility slots per pixel when given (what every frame's
    /// [`RasterBuffers`] then hold: the scene's, [`slots_within`] its output), else they take
    /// it from their push constants (any K: [`Self::rasterize_stored_words`]). The fused
    /// raster kernel compiles the code that takes a slot order and marks segments
    /// (`raster_split.comp`) unless `slots` is 1; it draws the strands as `fused` says.
    pub fn new(
        ctx: &Context,
        lights: usize,
        materials: usize,
        loads: LoadPath,
        slots: Option<u32>,
        fused: FusedStrands,
    ) -> gen_gpu::Result<Self> {
        let loads = if ctx.capabilities().buffer_device_address { loads } else { LoadPath::Bindings };
        let by_address = (LOAD_BY_ADDRESS_CONSTANT_ID, u32::from(loads == LoadPath::BufferReferences));
        let compute = |name: &str, shader, bindings: &[Binding], push, specialization: &[(u32, u32)]| {
            Pipeline::compute(
                ctx,
                &ComputePipelineDesc {
                    specialization,
                    ..ComputePipelineDesc::new(name, shader, bindings, push)
                },
            )
        };
        let push = size_of::<RasterPush>() as u32;
        let slot_count = (VISIBILITY_SLOTS_CONSTANT_ID, slots.unwrap_or(0));
        let variants =
            |name: &str, shader, bindings: &[u32], own: &[(u32, u32)]| -> gen_gpu::Result<ClippingVariants> {
                let strand = gen_gpu::strand_bindings(bindings);
                let variant = |clipping: DepthClipping, suffix| {
                    let clips = (DEPTH_CLIPPING_CONSTANT_ID, u32::from(clipping == DepthClipping::Clip));
                    let constants = [&[by_address, clips, slot_count], own].concat();
                    compute(&format!("{name}{suffix}"), shader, &strand, push, &constants)
                };
                Ok(ClippingVariants {
                    clip: variant(DepthClipping::Clip, ", depth clipping")?,
                    skip: variant(DepthClipping::Skip, "")?,
                })
            };
        let raster = variants(
            "compute raster (fused generation)",
            &shaders::HAIR_RASTER_COMP,
            &GENERATED_RASTER_BINDINGS,
            &[(FUSED_STRANDS_CONSTANT_ID, fused.constant())],
        )?;
        let raster_stored = variants(
            "compute raster (stored strands)",
            &shaders::HAIR_RASTER_STORED_COMP,
            &RASTER_BINDINGS,
            &[],
        )?;
        let split = compute(
            "compute raster slot order",
            &shaders::RASTER_SPLIT_COMP,
            &gen_gpu::strand_bindings(&RASTER_SPLIT_BINDINGS),
            size_of::<SplitPush>() as u32,
            &[],
        )?;
        let stage = vk::ShaderStageFlags::COMPUTE;
        let shade_bindings = Binding::storage_buffers(&RASTER_SHADE_BINDINGS, stage);
        let only_material = if materials == 1 { 0 } else { u32::MAX };
        let specialization = [
            scene_lights_constant(lights),
            (ONLY_MATERIAL_CONSTANT_ID, only_material),
            by_address,
            slot_count,
        ];
        let shade = compute(
            "compute raster shade",
            &shaders::RASTER_SHADE_COMP,
            &shade_bindings,
            size_of::<ShadePush>() as u32,
            &specialization,
        )?;
        let tiles = compute(
            "compute raster tiles",
            &shaders::RASTER_TILES_COMP,
            &Binding::storage_buffers(&RASTER_TILE_BINDINGS, stage),
            size_of::<TilePush>() as u32,
            &[slot_count],
        )?;
        let resolve = compute(
            "compute raster resolve",
            &shaders::RASTER_RESOLVE_COMP,
            &Binding::storage_buffers(&RESOLVE_BINDINGS, stage),
            size_of::<ResolvePush>() as u32,
            &[by_address],
        )?;
        let no_scene_depth = Buffer::new(ctx, "no scene depth", BufferDesc::storage(16))?;
        Ok(Self { raster, raster_stored, split, shade, tiles, resolve, no_scene_depth, loads, slots, fused })
    }

    /// What the fused-generation kernel draws of each strand ([`Self::new`]).
    pub fn fused_strands(&self) -> FusedStrands {
        self.fused
    }

    /// How the kernels read: what [`Self::new`] was asked for where the device allows it.
    pub fn load_path(&self) -> LoadPath {
        self.loads
    }

    /// The visibility slots per pixel the kernels were specialized for ([`Self::new`]; `None`:
    /// any).
    pub fn slots(&self) -> Option<u32> {
        self.slots
    }

    /// `address` (a device address) for a kernel's push constants when the kernels read
    /// through buffer references, else 0 (unused: they read through the bindings).
    pub(crate) fn load_address(&self, address: u64) -> u64 {
        match self.loads {
            LoadPath::BufferReferences => address,
            LoadPath::Bindings => 0,
        }
    }

    /// [`Self::load_address`] of `buffer`'s device address.
    pub(crate) fn buffer_address(&self, buffer: &Buffer) -> u64 {
        self.load_address(buffer.device_address())
    }
}

impl ComputeRaster {
    /// Rasterizes `stored` strands alone (no shading, no occluders) into fresh visibility and
    /// coverage buffers of `inputs.viewport`'s size and reads them back: the kernel as the
    /// tests compare it with its CPU port ([`crate::cpu::raster::raster_strand`]). `model` places the strands
    /// in the world (tangents are stored in world space). The kernel reads as
    /// [`Self::load_path`] says.
    pub fn rasterize_stored(
        &self,
        ctx: &Context,
        stored: &gen_gpu::StoredStrands,
        inputs: &gen_gpu::FrameInputs,
        model: Mat4,
        material: u32,
    ) -> gen_gpu::Result<crate::cpu::raster::RasterBuffers> {
        let [width, height] = inputs.viewport;
        let all = self.rasterize_stored_words(ctx, stored, inputs, model, material, 1, None, None)?;
        Ok(crate::cpu::raster::RasterBuffers {
            width,
            height,
            visibility: all.iter().step_by(2).copied().collect(),
            coverage: all.iter().skip(1).step_by(2).map(|&w| coverage_sum(w)).collect(),
        })
    }

    /// As [`Self::rasterize_stored`] with `k` visibility slots per pixel, returning the pixel
    /// words as the kernel leaves them ([`pixel_stride`] per pixel: the K slots, unordered for
    /// K > 1, the complemented coverage word, the threshold word). The kernel starts from
    /// `initial` when given (that many words: what earlier passes left), else from cleared
    /// words. `clipping` picks the kernel's variant; `None`: the one frames would take for the
    /// strands' bounds ([`DepthClipping::for_bounds`]).
    #[allow(clippy::too_many_arguments)]
    pub fn rasterize_stored_words(
        &self,
        ctx: &Context,
        stored: &gen_gpu::StoredStrands,
        inputs: &gen_gpu::FrameInputs,
        model: Mat4,
        material: u32,
        k: u32,
        initial: Option<&[u64]>,
        clipping: Option<DepthClipping>,
    ) -> gen_gpu::Result<Vec<u64>> {
        let [width, height] = inputs.viewport;
        let pixels = u64::from(width) * u64::from(height);
        let transfer = vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
        let bytes = pixels * pixel_stride(k) * 8;
        if self.slots.is_some_and(|slots| slots != k) {
            return Err(gen_gpu::GpuError::BadUpload {
                name: "visibility + coverage".into(),
                offset: 0,
                size: bytes,
                why: "not the slot count the kernels were specialized for",
            });
        }
        let desc = BufferDesc::storage(bytes).usage(transfer);
        let words = match initial {
            Some(initial) if initial.len() as u64 * 8 != bytes => {
                return Err(gen_gpu::GpuError::BadUpload {
                    name: "visibility + coverage".into(),
                    offset: 0,
                    size: initial.len() as u64 * 8,
                    why: "not the pixel words of the viewport and slots",
                });
            }
            Some(initial) => {
                ctx.create_buffer_with_data("visibility + coverage", desc, bytemuck::cast_slice(initial))?
            }
            None => Buffer::new(ctx, "visibility + coverage", desc)?,
        };
        let params = stored.frame_params(ctx, inputs)?;
        let extra = [
            (crate::contract::binding::VISIBILITY, &words),
            (crate::contract::binding::SCENE_DEPTH, &self.no_scene_depth),
            (crate::contract::binding::RASTER_TILES, &self.no_scene_depth),
        ];
        let clipping = clipping.unwrap_or_else(|| DepthClipping::for_bounds(inputs.view_proj, stored.bounds));
        let pipeline = self.raster_stored.get(clipping);
        ctx.submit("compute raster (stored strands)", |rec| {
            // (Initial words were written before the submission: visible to it.)
            if initial.is_none() {
                rec.fill_buffer(&words, u32::MAX);
                fills_to_compute(rec);
            }
            stored.record_compute(
                rec,
                pipeline,
                &params,
                &extra,
                stored_group_size(),
                SlotSubset::All,
                |rec, chunk| {
                    let mut push =
                        raster_push(model, material, chunk.slots, false, RasterPhase::ALL, 1, k, 1.0);
                    push.words_address = self.buffer_address(&words);
                    push.vertices_address = self.load_address(chunk.vertices_address);
                    // (Neither read with all slots in one phase and no occluders.)
                    let unread = self.buffer_address(&self.no_scene_depth);
                    (push.tiles_address, push.scene_depth_address) = (unread, unread);
                    rec.push_constants(pipeline, &push);
                },
            );
            compute_writes_to_readback(rec);
            Ok(())
        })?;
        let bytes = ctx.read_buffer(&words, bytes)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }
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

#[cfg(test)]
mod tests {
    use glam::{Mat4, Vec3};

    use super::screen_rect;

    fn view_proj() -> Mat4 {
        let proj = Mat4::perspective_rh(60f32.to_radians(), 2.0, 0.01, 100.0);
        Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0))
            * proj
            * Mat4::look_at_rh(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y)
    }

    #[test]
    fn slots_fit_one_storage_buffer_with_their_coverage_and_threshold_words() {
        use super::{pixel_stride, slots_within};
        assert_eq!((pixel_stride(1), pixel_stride(2), pixel_stride(8)), (2, 4, 10));
        let pixels = 1280 * 720;
        assert_eq!(slots_within(16, pixels, 128 << 20), 16);
        // 9 words per pixel fit 64 MiB at 1280×720: 7 slots and their two words.
        let range = 64 << 20;
        assert_eq!(slots_within(16, pixels, range), 7);
        assert!(
            pixels * pixel_stride(7) * 8 <= u64::from(range)
                && pixels * pixel_stride(8) * 8 > u64::from(range)
        );
        // Too small for two slots and their two words: one slot (two words), or one anyway.
        assert_eq!(slots_within(8, pixels, (pixels * 3 * 8) as u32), 1);
        assert_eq!(slots_within(8, pixels, 8), 1);
    }

    #[test]
    fn a_second_front_only_where_strand_lod_keeps_most_strands() {
        use crate::camera::{Camera, Character, character_inputs};
        use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
        use hairmesh::reference::LodParams;
        use hairmesh::{ExtrudeParams, HairMesh};
        let scalp = hairmesh::procedural::head_cap(6, 24);
        let mesh = HairMesh::extrude(&scalp, &ExtrudeParams::default()).expect("the head cap extrudes");
        let params = AssetParams { strands: StrandCount::Total(20_000), ..AssetParams::default() };
        let asset =
            HairAsset::build(&mesh, &params, hairmesh::style::Style::default()).expect("the asset builds");
        let character = Character { hair: 0, transform: Mat4::IDENTITY };
        let pays = |distance: f32, lod: LodParams| {
            let camera = Camera {
                eye: Vec3::new(0.0, 1.6, distance),
                target: Vec3::new(0.0, 1.6, 0.0),
                fov_y: 45f32.to_radians(),
            };
            super::second_front_pays(&asset, &character_inputs(&camera, &character, 1280, 720, lod))
        };
        let strand_alpha = |a: f64| LodParams { enabled: true, strand_alpha: a, ..LodParams::default() };
        assert!(pays(0.6, strand_alpha(1.0)), "a close-up at full detail");
        assert!(pays(40.0, LodParams { enabled: false, ..LodParams::default() }), "LOD off: every strand");
        assert!(!pays(10.0, strand_alpha(64.0)), "a crowd's character whose bundles keep a few strands");
        let sparse_params = AssetParams { strands: StrandCount::Total(1000), ..AssetParams::default() };
        let sparse = HairAsset::build(&mesh, &sparse_params, hairmesh::style::Style::default())
            .expect("the asset builds");
        let camera = Camera { eye: Vec3::new(0.0, 1.6, 0.6), target: Vec3::new(0.0, 1.6, 0.0), fov_y: 0.8 };
        let inputs = character_inputs(&camera, &character, 1280, 720, strand_alpha(1.0));
        assert!(
            !super::second_front_pays(&sparse, &inputs),
            "bundles of a few strands each, even at full detail"
        );
    }

    #[test]
    fn fused_frames_draw_a_second_eighth_between_the_front_and_the_rest() {
        use super::RasterPhase;
        use gen_gpu::SlotSubset::{All, Remainder, Sparse};
        let phase = |subset, part| RasterPhase { subset, part };
        assert_eq!(RasterPhase::sequence(false, 2), vec![phase(All, 0)]);
        assert_eq!(RasterPhase::sequence(true, 1), vec![phase(Sparse, 0), phase(Remainder, 1)]);
        assert_eq!(
            RasterPhase::sequence(true, 2),
            vec![phase(Sparse, 0), phase(Sparse, 1), phase(Remainder, 2)]
        );
        // At most two fronts: each bundle's sparse slots hold an eighth of its strands.
        assert_eq!(RasterPhase::sequence(true, 5).len(), 3);
        let culled: Vec<bool> =
            RasterPhase::sequence(true, 2).into_iter().map(RasterPhase::tile_culled).collect();
        assert_eq!(culled, [false, true, true], "every phase after the front meets the tiles");
        assert!(!RasterPhase::ALL.tile_culled());
    }

    #[test]
    fn the_cleared_ranges_are_the_rects_pixel_words() {
        use super::{pixel_stride, rect_word_ranges};
        let (width, height) = (13u32, 7u32);
        for k in [1, 4] {
            let bytes = pixel_stride(k) * 8;
            for rect in
                [[2, 1, 9, 5], [0, 2, 13, 6], [0, 0, 13, 7], [12, 6, 13, 7], [3, 3, 3, 5], [5, 5, 4, 6]]
            {
                let mut cleared = vec![0u32; (width * height) as usize];
                for (offset, size) in rect_word_ranges(rect, width, k) {
                    assert!(offset % bytes == 0 && size % bytes == 0 && size > 0, "{rect:?}: whole pixels");
                    for pixel in offset / bytes..(offset + size) / bytes {
                        cleared[pixel as usize] += 1;
                    }
                }
                let [x0, y0, x1, y1] = rect;
                for y in 0..height {
                    for x in 0..width {
                        let inside = (x0..x1).contains(&x) && (y0..y1).contains(&y);
                        assert_eq!(
                            cleared[(y * width + x) as usize],
                            u32::from(inside),
                            "{rect:?} at ({x}, {y})"
                        );
                    }
                }
            }
            // The whole width in one range.
            assert_eq!(rect_word_ranges([0, 2, 13, 6], width, k).len(), 1);
            assert_eq!(rect_word_ranges([1, 2, 13, 6], width, k).len(), 4);
        }
    }

    #[test]
    fn the_rect_covers_the_projected_bounds_with_a_margin() {
        let unit = (Vec3::splat(-0.1), Vec3::splat(0.1));
        let [x0, y0, x1, y1] = screen_rect(view_proj(), 800, 400, [(Mat4::IDENTITY, unit)]);
        // The box projects to about ±10 px around the centre; the margin adds 66.
        assert!(x0 > 300 && x1 < 500 && y0 > 100 && y1 < 300, "{:?}", [x0, y0, x1, y1]);
        assert!(x0 < 400 - 66 && x1 > 400 + 66, "{:?}", [x0, y0, x1, y1]);
        // Moved off to the side: clamped to the frame.
        let side = Mat4::from_translation(Vec3::new(6.0, 0.0, 0.0));
        let [_, _, x1, _] = screen_rect(view_proj(), 800, 400, [(side, unit)]);
        assert_eq!(x1, 800);
    }

    #[test]
    fn depth_clipping_is_skipped_only_for_boxes_inside_the_depth_range() {
        use super::DepthClipping::{self, Clip, Skip};
        // The eye at z = 5 looking down -z; near plane at z = 4.99, far plane at z = -95.
        let boxed =
            |lo: [f32; 3], hi: [f32; 3]| DepthClipping::for_bounds(view_proj(), (lo.into(), hi.into()));
        assert_eq!(boxed([-1.0; 3], [1.0; 3]), Skip);
        assert_eq!(boxed([-1.0, -1.0, 4.5], [1.0, 1.0, 4.98]), Skip, "1 cm in front of the eye");
        assert_eq!(boxed([-1.0, -1.0, 4.5], [1.0, 1.0, 4.995]), Clip, "through the near plane");
        assert_eq!(boxed([-1.0, -1.0, 5.5], [1.0, 1.0, 6.0]), Clip, "behind the eye");
        assert_eq!(boxed([-1.0, -1.0, -85.0], [1.0, 1.0, -80.0]), Skip);
        assert_eq!(boxed([-1.0, -1.0, -96.0], [1.0, 1.0, -90.0]), Clip, "through the far plane");
        // Far off to the side still counts as inside: x and y are clipped per pixel.
        assert_eq!(boxed([300.0, 0.0, -1.0], [301.0, 1.0, 0.0]), Skip);
        assert_eq!(boxed([1.0; 3], [-1.0; 3]), Clip, "an empty box");
        assert_eq!(boxed([f32::NAN; 3], [1.0; 3]), Clip);
        assert_eq!(boxed([-1.0; 3], [f32::INFINITY; 3]), Clip);
        // The object's transform moves the unit box onto the near plane.
        let onto = view_proj() * Mat4::from_translation(Vec3::new(0.0, 0.0, 4.5));
        assert_eq!(DepthClipping::for_bounds(onto, (Vec3::splat(-1.0), Vec3::splat(1.0))), Clip);
        // Seeded random boxes: wherever clipping is skipped, every point of the box the kernel
        // projects in f32 has 0 <= z <= w and w > 0.
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut random = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut skipped = 0;
        for _ in 0..2_000 {
            let a = Vec3::new(random() - 0.5, random() - 0.5, 5.0 - 110.0 * random() * random())
                * Vec3::new(20.0, 20.0, 1.0);
            let extent = Vec3::new(random(), random(), random()) * 2.0;
            let (lo, hi) = (a, a + extent);
            if boxed(lo.into(), hi.into()) == Skip {
                skipped += 1;
                for _ in 0..16 {
                    let p = lo + extent * Vec3::new(random(), random(), random());
                    let clip = view_proj() * p.extend(1.0);
                    assert!(
                        clip.z >= 0.0 && clip.w - clip.z >= 0.0 && clip.w > 0.0,
                        "{p} in {lo}..{hi}: {clip}"
                    );
                }
            }
        }
        assert!((500..1_900).contains(&skipped), "{skipped} of 2000 boxes skip the clipping");
    }

    #[test]
    fn a_box_behind_the_camera_takes_the_whole_frame_and_no_box_none() {
        let around_eye = (Vec3::new(-1.0, -1.0, 4.0), Vec3::new(1.0, 1.0, 6.0));
        assert_eq!(screen_rect(view_proj(), 64, 32, [(Mat4::IDENTITY, around_eye)]), [0, 0, 64, 32]);
        assert_eq!(screen_rect(view_proj(), 64, 32, []), [0, 0, 0, 0]);
        let nan = (Vec3::splat(f32::NAN), Vec3::splat(f32::NAN));
        assert_eq!(screen_rect(view_proj(), 64, 32, [(Mat4::IDENTITY, nan)]), [0, 0, 64, 32]);
    }
    #[test]
    fn slot_orders_stay_within_their_budget() {
        use super::{SLOT_ORDER_BUDGET_BYTES, SLOT_ORDER_BYTES_PER_SLOT, within_slot_order_budget};
        let per = SLOT_ORDER_BUDGET_BYTES / SLOT_ORDER_BYTES_PER_SLOT;
        // 40 % of the budget each: two fit, the third does not (nor a later small one: scene
        // order, so which characters get one does not depend on what comes after them).
        let c = per * 2 / 5;
        assert_eq!(within_slot_order_budget(&[c, c, c, 1]), vec![true, true, false, false]);
        assert_eq!(within_slot_order_budget(&[per]), vec![true]);
        assert_eq!(within_slot_order_budget(&[per + 1]), vec![false]);
        assert_eq!(within_slot_order_budget(&[u64::MAX, 1]), vec![false, false]);
        assert!(within_slot_order_budget(&[]).is_empty());
    }

    #[test]
    fn the_slot_order_puts_marked_segments_first() {
        use crate::cpu::raster::slot_order;
        // No history: every eighth slot first, walking all of its segments; the others after.
        let order = slot_order(&[], 20, false);
        assert_eq!(order.front, vec![[0, u32::MAX], [8, u32::MAX], [16, u32::MAX]]);
        assert_eq!(order.rest.len(), 17);
        assert!(order.rest.iter().all(|e| e[0] % 8 != 0 && e[1] == 0));
        // Marks on three of 16 slots (one with every segment): more than 16 / 8, so they go
        // first alone, walking their marked segments; the rest walks the others, and a strand
        // marked whole has no rest entry.
        let mut marks = vec![0u32; 16];
        marks[3] = 0x0000_00ff;
        marks[5] = u32::MAX;
        marks[9] = 0x8000_0001;
        let order = slot_order(&marks, 16, true);
        assert_eq!(order.front, vec![[3, 0xff], [5, u32::MAX], [9, 0x8000_0001]]);
        assert_eq!(order.rest.len(), 15);
        assert!(order.rest.contains(&[3, 0xff]) && order.rest.contains(&[9, 0x8000_0001]));
        assert!(!order.rest.iter().any(|e| e[0] == 5));
        assert!(order.rest.contains(&[0, 0]));
        // One marked strand of 16 (fewer than 16 / 8): the sparse slots join the front whole,
        // and leave the rest.
        let mut marks = vec![0u32; 16];
        marks[3] = 0xf0;
        let order = slot_order(&marks, 16, true);
        assert_eq!(order.front, vec![[3, 0xf0], [0, u32::MAX], [8, u32::MAX]]);
        assert_eq!(order.rest.len(), 14);
        assert!(!order.rest.iter().any(|e| e[0] == 0 || e[0] == 8));
        // Marks without history count for nothing; every slot is drawn in some phase.
        assert_eq!(slot_order(&marks, 16, false), slot_order(&[], 16, false));
    }
}
