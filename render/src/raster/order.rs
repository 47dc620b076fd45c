//! The order strands are drawn in: the phases around the occlusion tiles, each character's slot
//! order kept from frame to frame, and when a second front eighth pays.

use super::*;

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

/// The strand LOD detail below which a character gets no second front eighth
/// ([`second_front_pays`]).
pub const SECOND_FRONT_MIN_DETAIL: f64 = 0.5;

/// The live strands per bundle below which a character gets no second front eighth
/// ([`second_front_pays`]): bundles of many strands draw faster with it, bundles of a few
/// slower (`docs/compute-raster-notes.md`); this lies between.
pub const SECOND_FRONT_MIN_STRANDS: f64 = 32.0;

/// Whether a character's strands, generated in the raster kernel, get a second front eighth
/// ([`RasterPhase::sequence`]): when strand LOD keeps at least half of them
/// ([`SECOND_FRONT_MIN_DETAIL`]; LOD off, or the detail level of the asset's mean bundle face
/// at its bounds' centre) and its bundles keep [`SECOND_FRONT_MIN_STRANDS`] on average.
/// Characters whose bundles keep a few widened strands (a crowd under strand LOD) draw slower
/// with it: the second eighth costs more than the tiles it closes save.
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
