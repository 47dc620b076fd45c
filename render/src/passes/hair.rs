//! The hair raster of opaque and blended transparency: blended mode's depth prepass (only
//! fragments a strand covers fully write depth, so sub-pixel strands never hide what is behind
//! them), then the shaded strands blended into the target. Also the strand draw loop the OIT fill
//! and the shadow passes share.

use gen_gpu::{Buffer, DrawExtras, FrameBuffers, Generator, Recorder};
use glam::Vec3;

use super::{ScenePass, strand_reads};
use crate::frame::{FrameIds, FrameState, SceneRenderer};
use crate::graph::FrameGraph;

pub(crate) fn plan(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    batch: &[usize],
    last: bool,
    submission: usize,
) {
    let reads = strand_reads(r, ids, batch, last);
    if r.depth_prepass.is_some() {
        g.pass(format!("hair depth prepass ({}, solid fragments)", r.path))
            .reads(reads.iter().copied())
            .writes(ids.target_writes())
            .submission(submission)
            .add(ScenePass::DepthPrepass);
    }
    g.pass(r.raster_pass_name())
        .reads(ids.hair_shading_reads())
        .reads(reads)
        .writes(ids.target_writes())
        .submission(submission)
        .add(ScenePass::Raster);
}

pub(crate) fn record_prepass(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    clear: Option<[f32; 3]>,
) -> gen_gpu::Result<()> {
    let Some(generator) = &r.depth_prepass else { return Ok(()) };
    let view = &state.plan.view;
    let solid = state.frames.iter().filter(|(i, _)| r.may_cover_pixels(&r.characters[*i], view));
    draw_into_target(r, rec, state, clear, generator, solid, &[])
}

pub(crate) fn record_raster(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    clear: Option<[f32; 3]>,
) -> gen_gpu::Result<()> {
    let (l, v) = (state.lighting, state.volume_buffers);
    let buffers = [l[0], l[1], l[2], l[3], v[0], v[1], v[2]];
    draw_into_target(r, rec, state, clear, &r.generator, state.frames, &buffers)
}

/// One rendering scope on the scene target (cleared to `clear`, or loaded) drawing `batch` and
/// the stored-strand characters with `generator`: the body of every strand-drawing pass.
pub(crate) fn draw_into_target<'b>(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    clear: Option<[f32; 3]>,
    generator: &Generator,
    batch: impl IntoIterator<Item = &'b (usize, FrameBuffers)>,
    extra: &[(u32, &Buffer)],
) -> gen_gpu::Result<()> {
    state.target.begin_rendering(rec, clear);
    let eye = state.plan.view.camera.eye;
    let drawn = draw_characters(r, rec, generator, batch, state, extra, eye);
    rec.end_rendering();
    drawn
}

/// Draws `batch`'s generated characters (shaded with their volumes' AO and shadows when the
/// scene has them), then the stored ones, with `generator`'s fragment stage and its extra
/// buffers.
pub(crate) fn draw_characters<'b>(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    generator: &Generator,
    batch: impl IntoIterator<Item = &'b (usize, FrameBuffers)>,
    state: &FrameState<'_>,
    extra: &[(u32, &Buffer)],
    eye: Vec3,
) -> gen_gpu::Result<()> {
    let stored_params = state.stored_params;
    for (i, frame) in batch {
        let c = &r.characters[*i];
        let mut shading = r.shading(c, eye);
        r.volume_shading(state.plan, c.hair, &mut shading);
        let extras = DrawExtras { fragment_constants: bytemuck::bytes_of(&shading), buffers: extra };
        generator.record_draw_with(rec, &r.hairs[c.hair], frame, r.path, false, extras)?;
    }
    for (c, params) in r.stored_characters.iter().zip(stored_params) {
        let mut shading = r.shading(c, eye);
        r.volume_shading(state.plan, r.hairs.len() + c.hair, &mut shading);
        let extras = DrawExtras { fragment_constants: bytemuck::bytes_of(&shading), buffers: extra };
        r.stored[c.hair].record_draw(rec, generator, params, extras);
    }
    Ok(())
}
