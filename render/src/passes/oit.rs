//! Order-independent transparency (per-pixel linked lists with a k-buffer resolve, as TressFX):
//! clear the lists, fill them with shaded fragments (depth-tested against the occluders, nothing
//! written to the target), resolve them over the target. Fragments that find the node pool full
//! go to their pixel's overflow tail (`oit.glsl`), counted.

use gen_gpu::Recorder;

use super::{ScenePass, strand_reads};
use crate::contract::binding;
use crate::frame::{FrameIds, FrameState, SceneRenderer};
use crate::graph::{Access, FrameGraph};

pub(crate) fn plan_clear(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    g.pass("clear OIT lists")
        .write(ids.oit_lists, Access::TransferWrite)
        .submission(submission)
        .add(ScenePass::ClearOit);
}

pub(crate) fn plan_fill(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    batch: &[usize],
    last: bool,
    submission: usize,
) {
    g.pass(format!("raster hair ({}, OIT fill)", r.path))
        .reads(ids.hair_shading_reads())
        .reads(strand_reads(r, ids, batch, last))
        // The target is attached for its depth (occluders hide hair); no colour is written.
        .writes(ids.target_writes())
        .write(ids.oit_lists, Access::FragmentWrite)
        .submission(submission)
        .add(ScenePass::OitFill);
}

pub(crate) fn plan_resolve(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    g.pass("OIT resolve")
        .read(ids.oit_lists, Access::FragmentRead)
        .writes(ids.target_writes())
        .submission(submission)
        .add(ScenePass::OitResolve);
}

pub(crate) fn record_clear(rec: &mut Recorder<'_>, state: &FrameState<'_>) -> gen_gpu::Result<()> {
    let Some(oit) = state.oit else { return Ok(()) };
    rec.fill_buffer(&oit.heads, u32::MAX);
    let address = oit.nodes_address;
    let init = [
        0u32,
        oit.pool as u32,
        0,
        state.plan.view.width,
        oit.pixel_words,
        0,
        address as u32,
        (address >> 32) as u32,
    ];
    rec.update_buffer(&oit.counters, 0, bytemuck::cast_slice(&init))
}

/// The fill stage's buffers: the lists, then the lighting.
fn fill_buffers<'a>(state: &FrameState<'a>) -> Option<[(u32, &'a gen_gpu::Buffer); 10]> {
    let oit = state.oit?;
    let (l, v) = (state.lighting, state.volume_buffers);
    // A pool reached through its device address may exceed what a binding may span: the
    // (unread) binding then gets the counters as a stand-in.
    let nodes = if oit.nodes_address != 0 { &oit.counters } else { &oit.nodes };
    Some([
        (binding::OIT_HEADS, &oit.heads),
        (binding::OIT_NODES, nodes),
        (binding::OIT_COUNTERS, &oit.counters),
        l[0],
        l[1],
        l[2],
        l[3],
        v[0],
        v[1],
        v[2],
    ])
}

pub(crate) fn record_fill(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    clear: Option<[f32; 3]>,
) -> gen_gpu::Result<()> {
    let (Some(oit), Some(extra)) = (&r.oit, fill_buffers(state)) else { return Ok(()) };
    super::hair::draw_into_target(r, rec, state, clear, &oit.fill, state.frames, &extra)
}

pub(crate) fn record_resolve(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
) -> gen_gpu::Result<()> {
    let (Some(oit), Some(extra)) = (&r.oit, fill_buffers(state)) else { return Ok(()) };
    state.target.begin_rendering(rec, None);
    rec.bind_pipeline(&oit.resolve);
    rec.push_storage_buffers(&oit.resolve, &extra[..3]);
    rec.push_constants(&oit.resolve, &oit.k);
    rec.draw(3, 1);
    rec.end_rendering();
    Ok(())
}
