//! The hair volumes' passes ([`crate::volume`]): per hair whose volume this frame needs and does
//! not have cached, a LOD pass over every strand, the clear of its sums, the voxelization
//! (generation fused), the resolve and (with `"ao"`) the AO; then, per character drawn as a
//! volume, its raymarch into the compute rasterizer's visibility buffer.

use gen_gpu::{Generator, Recorder};

use super::ScenePass;
use crate::contract::binding;
use crate::frame::{FrameIds, FrameState, SceneRenderer, VoxelSource};
use crate::graph::{Access, FrameGraph};
use crate::shaders;
use crate::volume::{MarchPush, VolumePassPush, VoxelizePush};

/// Which step of a hair's volume a pass records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeStep {
    Lod,
    Clear,
    Voxelize,
    Resolve,
    Bricks,
    Ao,
}

/// Plans hair `h`'s volume passes (marked cached when its volume is up to date).
pub(crate) fn plan_hair(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    h: usize,
    submission: usize,
) {
    let Some(v) = ids.volumes.as_ref() else { return };
    let Some(plan) = v.hairs[h] else { return };
    let n = plan.grid.dims;
    let size = format!("{}×{}×{}", n[0], n[1], n[2]);
    // Volume sources after the uploaded hairs are stored strands (their characters' buffers).
    let stored = h.checked_sub(r.hairs.len());
    if stored.is_none() {
        g.pass(format!("lod hair {h} (voxelize: a voxel per pixel)"))
            .read(ids.hair_uploads[h], Access::ComputeRead)
            .write(v.lod[h], Access::ComputeWrite)
            .cached(plan.cached)
            .submission(submission)
            .add(ScenePass::Volume(h, VolumeStep::Lod));
    }
    g.pass(format!("clear voxel sums hair {h}"))
        .write(v.sums[h], Access::TransferWrite)
        .cached(plan.cached)
        .submission(submission)
        .add(ScenePass::Volume(h, VolumeStep::Clear));
    let voxelize = match stored {
        None => g
            .pass(format!("voxelize hair {h} ({size}, fused generation)"))
            .read(ids.hair_uploads[h], Access::ComputeRead)
            .read(v.lod[h], Access::ComputeRead)
            .read(v.lod[h], Access::IndirectRead),
        Some(s) => {
            let characters = r.stored_characters.iter().zip(&ids.stored).filter(|(c, _)| c.hair == s);
            g.pass(format!("voxelize hair {h} ({size}, stored strands)"))
                .reads(characters.map(|(_, &res)| (res, Access::ComputeRead)))
        }
    };
    voxelize
        .write(v.sums[h], Access::ComputeWrite)
        .cached(plan.cached)
        .submission(submission)
        .add(ScenePass::Volume(h, VolumeStep::Voxelize));
    g.pass(format!("resolve volume hair {h}"))
        .read(v.sums[h], Access::ComputeRead)
        .write(v.volume, Access::ComputeWrite)
        .write(v.ao, Access::ComputeWrite)
        .cached(plan.cached)
        .submission(submission)
        .add(ScenePass::Volume(h, VolumeStep::Resolve));
    g.pass(format!("volume bricks hair {h}"))
        .read(v.volume, Access::ComputeRead)
        .write(v.bricks, Access::ComputeWrite)
        .cached(plan.cached)
        .submission(submission)
        .add(ScenePass::Volume(h, VolumeStep::Bricks));
    if r.effects.ao {
        g.pass(format!("volume AO hair {h}"))
            .read(v.volume, Access::ComputeRead)
            .write(v.ao, Access::ComputeWrite)
            .cached(plan.cached)
            .submission(submission)
            .add(ScenePass::Volume(h, VolumeStep::Ao));
    }
}

/// Plans the raymarch of character `i` (drawn as a volume) after the visibility clear.
pub(crate) fn plan_march(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    i: usize,
    submission: usize,
) {
    let Some(v) = ids.volumes.as_ref() else { return };
    let Some((_, source)) = r.volume_character(i) else { return };
    let Some(plan) = v.hairs[source] else { return };
    let n = plan.grid.dims;
    let name = match i.checked_sub(r.characters.len()) {
        None => format!("raymarch character {i}"),
        Some(j) => format!("raymarch stored character {j}"),
    };
    let mut pass = g
        .pass(format!("{name} (volume {}×{}×{})", n[0], n[1], n[2]))
        .read(v.volume, Access::ComputeRead)
        .read(v.bricks, Access::ComputeRead)
        .read(ids.raster_frame, Access::ComputeRead);
    if !r.occluders.is_empty() {
        pass = pass.read(ids.scene_depth, Access::ComputeRead);
    }
    pass.write(ids.visibility, Access::ComputeWrite).submission(submission).add(ScenePass::March(i));
}

/// Groups of 64 invocations for `voxels`, as a 2D dispatch (the kernels rebuild the index from
/// the row width).
fn voxel_groups(voxels: u64) -> (u32, u32) {
    let groups = voxels.div_ceil(64).max(1);
    let x = groups.min(32_768);
    (x as u32, groups.div_ceil(x) as u32)
}

pub(crate) fn record_hair(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    h: usize,
    step: VolumeStep,
) -> gen_gpu::Result<()> {
    let (Some(volumes), Some(frame)) = (&r.volumes, state.volumes) else { return Ok(()) };
    let Some(Some(hv)) = frame.hairs.get(h) else { return Ok(()) };
    let p = &volumes.pipelines;
    let grid = hv.grid;
    let [nx, ny, nz] = grid.dims;
    let region = hv.address.dims;
    let bricks = [hv.address.first_brick, 0, 0, 0];
    let sums = [(binding::VOXEL_SUMS, &hv.sums)];
    let object_to_voxel = grid.object_to_voxel().to_cols_array();
    match (step, &hv.source) {
        (VolumeStep::Lod, VoxelSource::Generated(f)) => r.generator.record_lod(rec, &r.hairs[h], f),
        (VolumeStep::Lod, VoxelSource::Stored(..)) => {}
        (VolumeStep::Clear, _) => rec.fill_buffer(&hv.sums, 0),
        (VolumeStep::Voxelize, VoxelSource::Generated(f)) => {
            rec.bind_pipeline(&p.voxelize);
            r.generator.bind_frame(rec, &p.voxelize, &r.hairs[h], f, &sums);
            rec.push_constants(&p.voxelize, &VoxelizePush { object_to_voxel, dims: [nx, ny, nz, 0] });
            Generator::record_fused_dispatch(rec, f);
        }
        (VolumeStep::Voxelize, VoxelSource::Stored(s, params)) => {
            let pipeline = &p.voxelize_stored;
            let group = shaders::HAIR_VOXELIZE_STORED_COMP.workgroup_size[0];
            r.stored[*s].record_compute(
                rec,
                pipeline,
                params,
                &sums,
                group,
                gen_gpu::SlotSubset::All,
                |rec, chunk| {
                    rec.push_constants(
                        pipeline,
                        &VoxelizePush { object_to_voxel, dims: [nx, ny, nz, chunk.slots] },
                    );
                },
            );
        }
        (VolumeStep::Resolve, _) => {
            rec.bind_pipeline(&p.resolve);
            rec.push_storage_buffers(
                &p.resolve,
                &[
                    (binding::VOXEL_SUMS, &hv.sums),
                    (binding::VOLUME, &volumes.store.volume),
                    (binding::VOLUME_AO, &volumes.store.ao),
                ],
            );
            rec.push_constants(&p.resolve, &VolumePassPush { dims: region, ao: [0.0; 4], bricks });
            let (x, y) = voxel_groups(grid.voxels());
            rec.dispatch(x, y, 1);
        }
        (VolumeStep::Bricks, _) => {
            rec.bind_pipeline(&p.bricks);
            rec.push_storage_buffers(
                &p.bricks,
                &[(binding::VOLUME, &volumes.store.volume), (binding::VOLUME_BRICKS, &volumes.store.bricks)],
            );
            rec.push_constants(&p.bricks, &VolumePassPush { dims: region, ao: [0.0; 4], bricks });
            let (x, y) = voxel_groups(grid.bricks());
            rec.dispatch(x, y, 1);
        }
        (VolumeStep::Ao, _) => {
            rec.bind_pipeline(&p.ao);
            rec.push_storage_buffers(
                &p.ao,
                &[(binding::VOLUME, &volumes.store.volume), (binding::VOLUME_AO, &volumes.store.ao)],
            );
            let radius = crate::volume::ao_radius_voxels(&grid, r.effects.ao_radius);
            let push =
                VolumePassPush { dims: region, ao: [radius as f32, volumes.opacity, 0.0, 0.0], bricks };
            rec.push_constants(&p.ao, &push);
            let (x, y) = voxel_groups(grid.voxels());
            rec.dispatch(x, y, 1);
        }
    }
    Ok(())
}

pub(crate) fn record_march(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    i: usize,
) -> gen_gpu::Result<()> {
    let (Some(volumes), Some(frame), Some(cr), Some(b)) =
        (&r.volumes, state.volumes, &r.compute_raster, state.raster)
    else {
        return Ok(());
    };
    let Some(m) = frame.marches.iter().find(|m| m.character == i) else { return Ok(()) };
    let p = &volumes.pipelines;
    let depth = b.scene_depth.as_ref().unwrap_or(&cr.no_scene_depth);
    rec.bind_pipeline(&p.march);
    rec.push_storage_buffers(
        &p.march,
        &[
            (binding::VOLUME, &volumes.store.volume),
            (binding::VOLUME_BRICKS, &volumes.store.bricks),
            (binding::VISIBILITY, &b.pixel_words),
            (binding::RASTER_FRAME, &b.frame),
            (binding::SCENE_DEPTH, depth),
        ],
    );
    let push: &MarchPush = &m.push;
    rec.push_constants(&p.march, push);
    let [x0, y0, x1, y1] = m.push.rect;
    let [gx, gy, _] = shaders::VOLUME_MARCH_COMP.workgroup_size;
    rec.dispatch((x1 - x0).div_ceil(gx).max(1), (y1 - y0).div_ceil(gy).max(1), 1);
    Ok(())
}
