//! Occluder meshes (scalps, bodies), shaded and lit (with shadows when the scene has them),
//! into the scene target before the hair, so they hide what is behind them.

use gen_gpu::Recorder;

use super::ScenePass;
use crate::frame::{FrameIds, FrameState, SceneRenderer};
use crate::graph::{Access, FrameGraph};
use crate::occluder::occluder_push;

pub(crate) fn plan(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    g.pass("occluders")
        .read(ids.occluder_meshes, Access::PreRasterRead)
        .reads(ids.shading_reads())
        // The hair's AO darkens the occluders.
        .reads(ids.volumes.iter().map(|v| (v.ao, Access::FragmentRead)))
        .writes(ids.target_writes())
        .submission(submission)
        .add(ScenePass::Occluders);
}

pub(crate) fn record(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    clear: Option<[f32; 3]>,
) -> gen_gpu::Result<()> {
    let Some(pipes) = &r.occluder_pipes else { return Ok(()) };
    let view = &state.plan.view;
    let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
    state.target.begin_rendering(rec, clear);
    // Depth first: the lighting (shadow-map lookups, AO) then runs once per pixel, where
    // drawing shaded surfaces in mesh order lit every surface that was nearest so far.
    for o in &r.occluders {
        let push = occluder_push(o.transform, view_proj, view.camera.eye, 0, o.color);
        r.meshes[o.mesh].record_draw(rec, &pipes.depth, &push, &[]);
    }
    let light_count = r.scene.lights().len();
    for o in &r.occluders {
        let mut push = occluder_push(o.transform, view_proj, view.camera.eye, light_count, o.color);
        if let (true, Some(volumes), Some(Some(p))) = (
            r.effects.ao,
            r.volumes.as_ref(),
            state.plan.ids.volumes.as_ref().and_then(|v| v.hairs.get(o.hair_volume)),
        ) {
            push.world_to_voxel = p.grid.world_to_voxel(o.hair_transform).to_cols_array();
            push.volume = volumes.store.address(o.hair_volume, &p.grid).dims;
        }
        let l = state.lighting;
        let buffers = [l[0], l[1], l[2], l[3], state.volume_buffers[1]];
        r.meshes[o.mesh].record_draw(rec, &pipes.shade, &push, &buffers);
    }
    rec.end_rendering();
    Ok(())
}
