//! The compute rasterizer's passes ([`crate::raster`]): clear the visibility and coverage
//! buffers, copy the occluders' depth where hair must test against it, rasterize each batch's
//! characters (generation fused into the raster kernel) and the stored strands in two phases
//! around the occlusion tiles, shade, resolve over the target.

use gen_gpu::{Generator, Recorder, SlotSubset, vk};

use super::ScenePass;
use crate::contract::binding;
use crate::frame::{FrameIds, FrameState, SceneRenderer};
use crate::graph::{Access, FrameGraph};
use crate::raster::{
    FLAG_MARK, FLAG_SLOT_ORDER, RasterPhase, ResolvePush, SLOT_ORDER_REST_DISPATCH, ShadePush, SplitPush,
    TilePush, raster_push, stored_group_size, tile_grid,
};
use crate::shaders;

pub(crate) fn plan_clear(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    g.pass("clear visibility + coverage")
        .write(ids.visibility, Access::TransferWrite)
        .submission(submission)
        .add(ScenePass::ClearVisibility);
}

/// After the occluders: their depth into a buffer the raster kernels read.
pub(crate) fn plan_occluder_depth(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    g.pass("occluder depth → raster")
        .read(ids.depth, Access::TransferRead)
        .write(ids.scene_depth, Access::TransferWrite)
        .submission(submission)
        .add(ScenePass::OccluderDepthCopy);
}

/// Per batch: its characters' (and on the last batch the stored strands') front strands, the
/// occlusion tiles, then the rest of their strands with the tile test — for characters generated
/// in the kernel without a slot order, a second eighth with its own tiles in between
/// ([`RasterPhase::sequence`]). Every character's LOD result drives its fused raster dispatches.
pub(crate) fn plan_raster(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    batch: &[usize],
    last: bool,
    submission: usize,
) {
    let ordered = r.raster_slot_order() && !batch.is_empty();
    // A second front eighth where the batch generates its strands in the kernel and takes them
    // in the phases' subsets (with a slot order the front is the strands seen last frame), for
    // its characters whose bundles keep many strands (raster::second_front_pays; the others
    // skip the phase): the rest then meets tiles closed by a quarter of the strands, the second
    // eighth those of the first (worth one more tile pass and dispatch; a third eighth gains
    // nothing more: docs/compute-raster-notes.md). Stored strands
    // are drawn in the first and last phase.
    let second = batch.iter().any(|&i| ids.second_front(i));
    let fused_parts = if ordered || !second { 1 } else { 2 };
    let phases = RasterPhase::sequence(r.occlusion_tiles, fused_parts);
    if ordered {
        let mut pass = g.pass("strand slot order (compute raster)");
        for &i in batch {
            pass = pass.read(ids.lod[i], Access::ComputeRead);
        }
        pass.write(ids.slot_orders, Access::ComputeWrite)
            .write(ids.strand_marks, Access::ComputeWrite)
            .submission(submission)
            .add(ScenePass::RasterSlotOrder);
    }
    for phase in phases {
        if phase.tile_culled() {
            g.pass("occlusion tiles (compute raster)")
                .read(ids.visibility, Access::ComputeRead)
                .write(ids.raster_tiles, Access::ComputeWrite)
                .submission(submission)
                .add(ScenePass::RasterTiles);
        }
        let name = match (phase.subset, ordered) {
            (SlotSubset::All, _) => r.raster_pass_name(),
            (SlotSubset::Sparse, false) if phase.tile_culled() => {
                format!("{}: second eighth, tile-culled", r.raster_pass_name())
            }
            (SlotSubset::Sparse, false) => format!("{}: front strands", r.raster_pass_name()),
            (SlotSubset::Sparse, true) => {
                format!("{}: front strands (visible last frame)", r.raster_pass_name())
            }
            (SlotSubset::Remainder, _) => format!("{}: other strands, tile-culled", r.raster_pass_name()),
        };
        let mut pass = g.pass(name);
        for &i in batch {
            pass = pass
                .read(ids.hair[i], Access::ComputeRead)
                .read(ids.lod[i], Access::ComputeRead)
                .read(ids.lod[i], Access::IndirectRead);
        }
        if last {
            pass = pass.reads(ids.stored.iter().map(|&s| (s, Access::ComputeRead)));
        }
        if !r.occluders.is_empty() {
            pass = pass.read(ids.scene_depth, Access::ComputeRead);
        }
        if phase.tile_culled() {
            pass = pass.read(ids.raster_tiles, Access::ComputeRead);
        }
        if ordered {
            pass = pass
                .read(ids.slot_orders, Access::ComputeRead)
                .read(ids.slot_orders, Access::IndirectRead)
                .read(ids.final_depth, Access::ComputeRead)
                .write(ids.strand_marks, Access::ComputeWrite);
        }
        pass.write(ids.visibility, Access::ComputeWrite)
            .submission(submission)
            .add(ScenePass::ComputeRaster(phase));
    }
}

pub(crate) fn plan_shade(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    g.pass("shade hair (compute raster)")
        .read(ids.visibility, Access::ComputeRead)
        .read(ids.raster_frame, Access::ComputeRead)
        .reads(ids.compute_hair_shading_reads())
        .write(ids.shaded, Access::ComputeWrite)
        .write(ids.final_depth, Access::ComputeWrite)
        .submission(submission)
        .add(ScenePass::RasterShade);
}

/// Whether the resolve blends the hair over an image already in the readback buffers: the
/// occluders', copied out first. Else nothing draws into the attachments, the resolve writes the
/// hair's rectangle alone and the frame's read fills in the background around it
/// (`SceneTarget::read`). The frame plans, records and reads by this one rule.
pub(crate) fn resolves_over_occluders(r: &SceneRenderer) -> bool {
    !r.occluders.is_empty()
}

/// The last pass of the frame: the hair resolved straight into the frame's image (the readback
/// buffers), over the occluders' image when [`resolves_over_occluders`].
pub(crate) fn plan_resolve(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    g.pass("resolve hair (compute raster)")
        .read(ids.visibility, Access::ComputeRead)
        .read(ids.raster_frame, Access::ComputeRead)
        .read(ids.shaded, Access::ComputeRead)
        .write(ids.readback, Access::ComputeWrite)
        .submission(submission)
        .add(ScenePass::RasterResolve);
}

/// Clears the pixel words of the hair's screen rectangle: the frame's other pixels are never
/// shaded or resolved, no fragment reaches them, and the occlusion tiles count them as open
/// (raster_tiles.comp), so what they hold — an earlier frame's words, or whatever the pool's
/// memory held — changes nothing. (The OIT frame of the Sintel groom, ten words per pixel,
/// otherwise fills 74 MB.)
pub(crate) fn record_clear(rec: &mut Recorder<'_>, state: &FrameState<'_>) -> gen_gpu::Result<()> {
    let Some(b) = state.raster else { return Ok(()) };
    // All ones: no fragment, and a complemented coverage sum of zero.
    for (offset, size) in crate::raster::rect_word_ranges(b.rect, state.plan.view.width, b.k) {
        rec.fill_buffer_range(&b.pixel_words, offset, size, u32::MAX)?;
    }
    rec.fill_buffer(&b.counters, 0);
    Ok(())
}

pub(crate) fn record_occluder_depth(rec: &mut Recorder<'_>, state: &FrameState<'_>) -> gen_gpu::Result<()> {
    if let Some(depth) = state.raster.and_then(|b| b.scene_depth.as_ref()) {
        rec.copy_image_to_buffer(&state.target.depth, depth);
    }
    Ok(())
}

/// Each of the batch's characters' slot order (`raster_split.comp`) from the marks the last
/// frame that drew it set, which it then clears.
pub(crate) fn record_slot_order(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
) -> gen_gpu::Result<()> {
    let (Some(cr), Some(history)) = (&r.compute_raster, state.slot_history) else { return Ok(()) };
    rec.bind_pipeline(&cr.split);
    for (i, frame) in state.frames {
        let Some(c) = history.characters.get(*i).and_then(Option::as_ref) else { continue };
        let hair = &r.hairs[r.characters[*i].hair];
        let extra = [(binding::RASTER_SLOTS, &c.order), (binding::RASTER_MARKS, &c.marks)];
        r.generator.bind_frame(rec, &cr.split, hair, frame, &extra);
        rec.push_constants(&cr.split, &SplitPush { history: u32::from(c.history) });
        rec.dispatch(1, 1, 1);
    }
    Ok(())
}

pub(crate) fn record_tiles(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
) -> gen_gpu::Result<()> {
    let (Some(cr), Some(b)) = (&r.compute_raster, state.raster) else { return Ok(()) };
    let view = &state.plan.view;
    let (tx, ty) = tile_grid(view.width, view.height);
    rec.bind_pipeline(&cr.tiles);
    rec.push_storage_buffers(
        &cr.tiles,
        &[(binding::VISIBILITY, &b.pixel_words), (binding::RASTER_TILES, &b.tiles)],
    );
    // Two stages: each tile's own word from its 64 pixels, then (after a barrier) its squares'
    // from the own words — where each invocation reading the 9 tiles' pixels itself read every
    // pixel up to nine times.
    for stage in 0..2 {
        if stage == 1 {
            rec.memory_barrier(
                (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
            );
        }
        let push = TilePush {
            size: [view.width, view.height],
            tiles: [tx, ty],
            k: b.k,
            stage,
            pad: [0; 2],
            rect: b.rect,
        };
        rec.push_constants(&cr.tiles, &push);
        rec.dispatch((tx * ty).div_ceil(shaders::RASTER_TILES_COMP.workgroup_size[0]), 1, 1);
    }
    Ok(())
}

pub(crate) fn record_raster(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    phase: RasterPhase,
) -> gen_gpu::Result<()> {
    let (Some(cr), Some(b)) = (&r.compute_raster, state.raster) else { return Ok(()) };
    let occluders = b.scene_depth.is_some();
    let depth = b.scene_depth.as_ref().unwrap_or(&cr.no_scene_depth);
    let extra = [
        (binding::VISIBILITY, &b.pixel_words),
        (binding::SCENE_DEPTH, depth),
        (binding::RASTER_TILES, &b.tiles),
    ];
    // The last frame's depths, and whether the fused kernel marks against them.
    let marking = state.slot_history.is_some_and(|h| h.marking());
    let final_depth = state.slot_history.and_then(|h| h.final_depth_buffer()).unwrap_or(&cr.no_scene_depth);
    let tiles_x = tile_grid(state.plan.view.width, state.plan.view.height).0;
    // Where the kernels' plain loads read through (0 when they read through the bindings:
    // unused, ComputeRaster::load_path).
    let addresses =
        (cr.buffer_address(&b.pixel_words), cr.buffer_address(&b.tiles), cr.buffer_address(depth));
    // Characters wholly inside the view volume's depth (nearly all) go through the kernel
    // without clipping; the pipeline is bound again only where that changes.
    let clipping = r.raster_depth_clipping(&state.plan.view);
    let mut bound = None;
    for (i, frame) in state.frames {
        // A character without a second front eighth skips that phase and draws its rest after
        // the first front (strand part 1).
        let second_front = state.plan.ids.second_front(*i);
        if phase.later_front() && !second_front {
            continue;
        }
        let c = &r.characters[*i];
        let hair = &r.hairs[c.hair];
        let clipping = clipping[*i];
        let pipeline = cr.raster.get(clipping);
        if bound != Some(clipping) {
            rec.bind_pipeline(pipeline);
            bound = Some(clipping);
        }
        // With a slot order (the two phases of a scene that has one), its part for this phase
        // and the marks to set.
        let ordered = (r.raster_slot_order() && phase.subset != SlotSubset::All)
            .then(|| state.slot_history.and_then(|h| h.characters.get(*i)).and_then(Option::as_ref))
            .flatten();
        let stand_in = &cr.no_scene_depth;
        let extra = [
            extra[0],
            extra[1],
            extra[2],
            (binding::RASTER_SLOTS, ordered.map_or(stand_in, |c| &c.order)),
            (binding::RASTER_MARKS, ordered.map_or(stand_in, |c| &c.marks)),
            (binding::RASTER_FINAL_DEPTH, final_depth),
        ];
        let order = ordered.map(|c| &c.order);
        r.generator.bind_frame(rec, pipeline, hair, frame, &extra);
        let material = state.materials[*i];
        let opacity = r.raster_opacity(material);
        let mut push = raster_push(c.transform, material, 0, occluders, phase, tiles_x, b.k, opacity);
        (push.words_address, push.tiles_address, push.scene_depth_address) = addresses;
        push.volume_fraction = state.plan.volume_fraction(*i);
        // A slot order puts a slot in either phase, by its marks: each slot then draws the strand
        // the front's part gives it (the slot order's phases are two: no second eighth).
        push.strand_part = match order {
            Some(_) => 0,
            None if second_front => phase.part,
            None => phase.part.min(1),
        };
        if order.is_some() {
            push.flags |= FLAG_SLOT_ORDER | if marking { FLAG_MARK } else { 0 };
            push.final_depth_address = cr.buffer_address(final_depth);
        }
        rec.push_constants(pipeline, &push);
        match order {
            Some(order) if phase.subset == SlotSubset::Sparse => rec.dispatch_indirect(order, 0),
            Some(order) => rec.dispatch_indirect(order, SLOT_ORDER_REST_DISPATCH),
            None => Generator::record_fused_subset_dispatch(rec, frame, phase.subset),
        }
    }
    if phase.later_front() {
        // Stored strands have no second eighth: they are drawn in the first and the last phase.
        return Ok(());
    }
    let stored_materials = &state.materials[r.characters.len()..];
    let stored = r.stored_characters.iter().zip(state.stored_params).zip(stored_materials).enumerate();
    for (j, ((c, params), &material)) in stored {
        // The volume LOD path numbers stored characters after the generated ones.
        let volume_fraction = state.plan.volume_fraction(r.characters.len() + j);
        if volume_fraction >= 1.0 {
            continue;
        }
        let stored = &r.stored[c.hair];
        let pipeline = cr.raster_stored.get(clipping[r.characters.len() + j]);
        let opacity = r.raster_opacity(material);
        stored.record_compute(
            rec,
            pipeline,
            params,
            &extra,
            stored_group_size(),
            phase.subset,
            |rec, chunk| {
                let mut push =
                    raster_push(c.transform, material, chunk.slots, occluders, phase, tiles_x, b.k, opacity);
                (push.words_address, push.tiles_address, push.scene_depth_address) = addresses;
                push.vertices_address = cr.load_address(chunk.vertices_address);
                push.volume_fraction = volume_fraction;
                rec.push_constants(pipeline, &push);
            },
        );
    }
    Ok(())
}

pub(crate) fn record_shade(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
) -> gen_gpu::Result<()> {
    let (Some(cr), Some(b)) = (&r.compute_raster, state.raster) else { return Ok(()) };
    let l = state.lighting;
    // The K-th nearest depths for the next frame's slot order, where there is one.
    let final_depth =
        state.slot_history.and_then(|h| h.final_depth_buffer()).filter(|_| r.raster_slot_order());
    let buffers = [
        (binding::VISIBILITY, &b.pixel_words),
        (binding::RASTER_FRAME, &b.frame),
        (binding::SHADED, &b.shaded),
        (binding::RASTER_COUNTERS, &b.counters),
        (binding::RASTER_FINAL_DEPTH, final_depth.unwrap_or(&cr.no_scene_depth)),
        (binding::VOLUME_AO, r.volumes.as_ref().map_or(&cr.no_scene_depth, |v| &v.store.ao)),
        (binding::VOLUME, r.volumes.as_ref().map_or(&cr.no_scene_depth, |v| &v.store.volume)),
        (binding::VOLUME_BRICKS, r.volumes.as_ref().map_or(&cr.no_scene_depth, |v| &v.store.bricks)),
        l[0],
        l[1],
        l[2],
        l[3],
    ];
    rec.bind_pipeline(&cr.shade);
    rec.push_storage_buffers(&cr.shade, &buffers);
    let [x0, y0, x1, y1] = b.rect;
    // Where the kernel's plain loads read through (0 when it reads through the bindings): the
    // pixel words and the shadow maps, found by their bindings among the frame's lighting
    // buffers (which always hold all four).
    let map =
        |binding| l.iter().find(|(b, _)| *b == binding).map_or(0, |(_, buffer)| cr.buffer_address(buffer));
    let push = ShadePush {
        rect: b.rect,
        k: b.k,
        flags: if final_depth.is_some() { crate::raster::SHADE_FINAL_DEPTH } else { 0 },
        words_address: cr.buffer_address(&b.pixel_words),
        shadow_depth_address: map(binding::SHADOW_DEPTH),
        shadow_opacity_address: map(binding::SHADOW_OPACITY),
        occluder_depth_address: map(binding::OCCLUDER_DEPTH),
    };
    rec.push_constants(&cr.shade, &push);
    let [gx, gy, _] = shaders::RASTER_SHADE_COMP.workgroup_size;
    rec.dispatch((x1 - x0).div_ceil(gx), (y1 - y0).div_ceil(gy), 1);
    Ok(())
}

/// Over the occluders' image that the copy out left in the readback buffers, or over the
/// background, which the frame's read then fills in around the rectangle (on CPU devices
/// writing those pixels here cost more than the rest of the resolve).
pub(crate) fn record_resolve(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
) -> gen_gpu::Result<()> {
    let (Some(cr), Some(b)) = (&r.compute_raster, state.raster) else { return Ok(()) };
    let buffers = [
        (binding::VISIBILITY, &b.pixel_words),
        (binding::RASTER_FRAME, &b.frame),
        (binding::SHADED, &b.shaded),
        (binding::OUTPUT_COLOR, &state.target.color_readback),
        (binding::OUTPUT_DEPTH, &state.target.depth_readback),
    ];
    let background = if resolves_over_occluders(r) {
        [0.0, 0.0, 0.0, 1.0]
    } else {
        let [red, green, blue] = r.scene.scene.output.background;
        [red, green, blue, 0.0]
    };
    let [x0, y0, x1, y1] = b.rect;
    if x0 >= x1 || y0 >= y1 {
        return Ok(());
    }
    rec.bind_pipeline(&cr.resolve);
    rec.push_storage_buffers(&cr.resolve, &buffers);
    let push = ResolvePush {
        rect: b.rect,
        background,
        k: b.k,
        pad: 0,
        shaded_address: cr.buffer_address(&b.shaded),
    };
    rec.push_constants(&cr.resolve, &push);
    let [gx, gy, _] = shaders::RASTER_RESOLVE_COMP.workgroup_size;
    rec.dispatch((x1 - x0).div_ceil(gx), (y1 - y0).div_ceil(gy), 1);
    Ok(())
}
