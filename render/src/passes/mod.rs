//! The passes of a scene frame, one small module each. A pass module has a planning side (the
//! pass's reads and writes, added to the frame graph) and a recording side (what it records,
//! given the frame's resources). The executor ([`crate::graph::GraphRun`]) puts the barriers
//! between them and wraps each in its label and timestamp scope.
//!
//! | module | passes |
//! |---|---|
//! | [`upload`] | per hair changed since the last frame (an edit, a simulation step): its re-baked texels and bundle entries |
//! | [`shadow`] | per shadow-casting light: generate in the light's view, occluder depth, hair depth, opacity, and the copies into the map atlases (cached after the first frame) |
//! | [`generate`] | per character: LOD + cull (both paths), generate (compute path) |
//! | [`occluders`] | the occluder meshes, shaded and lit, into the scene target |
//! | [`hair`] | the hair raster: blended mode's depth prepass, opaque/blended shading |
//! | [`compute_raster`] | the compute rasterizer: clear, occluder depth copy, fused raster per batch, shade, resolve |
//! | [`oit`] | clear the OIT lists, fill them, resolve them |
//! | [`volume`] | per hair: LOD over every strand, clear, voxelize, resolve, AO (cached while the hair is unchanged); per far character: raymarch |
//! | [`copy_out`] | the target into the readback buffers |

pub mod compute_raster;
pub mod copy_out;
pub mod generate;
pub mod hair;
pub mod occluders;
pub mod oit;
pub mod shadow;
pub mod upload;
pub mod volume;

use gen_gpu::Recorder;

use crate::frame::{FrameIds, FrameState, SceneRenderer};
use crate::graph::{FrameGraph, GraphRun, PassNode};

/// What a pass of a scene frame records (the payload of its graph node).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScenePass {
    /// Shadow passes ([`shadow`]).
    Shadow(shadow::ShadowPass),
    /// LOD + cull of generated character `i`.
    LodCull(usize),
    /// Compute-path generation of character `i`.
    Generate(usize),
    ClearOit,
    Occluders,
    /// Blended mode's solid-fragment depth prepass.
    DepthPrepass,
    /// The hair raster (opaque or blended).
    Raster,
    OitFill,
    OitResolve,
    /// Compute rasterizer: clear the visibility and coverage buffers.
    ClearVisibility,
    /// Compute rasterizer: the occluders' depth into the buffer the kernels test against.
    OccluderDepthCopy,
    /// Compute rasterizer: one batch's characters (and the stored strands on the last), one
    /// phase.
    ComputeRaster(crate::raster::RasterPhase),
    /// Compute rasterizer: one batch's characters' slot orders (the strands visible last frame
    /// first).
    RasterSlotOrder,
    /// Compute rasterizer: the occlusion tiles between the phases.
    RasterTiles,
    RasterShade,
    RasterResolve,
    /// Hair `h`'s volume, one step ([`volume`]).
    Volume(usize, volume::VolumeStep),
    /// Raymarch of character `i`'s volume into the visibility buffer.
    March(usize),
    CopyOut,
    /// The `k`-th staged hair update of the frame ([`upload`]).
    UpdateHair(usize),
}

/// Plans the passes of one batch of characters (one submission): generation, then (first
/// batch) the OIT clear and the occluders, the hair raster, and (last batch) the OIT resolve and
/// the copy out.
pub(crate) fn frame_batch(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    batch: &[usize],
    submission: usize,
    first: bool,
    last: bool,
) {
    for &i in batch {
        generate::plan(r, g, ids, i, submission);
    }
    if r.compute_raster.is_some() {
        if first {
            for h in 0..r.volume_sources() {
                volume::plan_hair(r, g, ids, h, submission);
            }
            compute_raster::plan_clear(g, ids, submission);
            if !r.occluders.is_empty() {
                occluders::plan(g, ids, submission);
                compute_raster::plan_occluder_depth(g, ids, submission);
            }
            if let Some(v) = &ids.volumes {
                for &i in &v.marched {
                    volume::plan_march(r, g, ids, i, submission);
                }
            }
        }
        compute_raster::plan_raster(r, g, ids, batch, last, submission);
        if last {
            compute_raster::plan_shade(g, ids, submission);
            // The occluders' image into the readback buffers, the hair over it; without
            // occluders the resolve writes the hair's rectangle and the frame's read fills in
            // the background around it.
            if compute_raster::resolves_over_occluders(r) {
                copy_out::plan(g, ids, submission);
            }
            compute_raster::plan_resolve(g, ids, submission);
        }
        return;
    }
    if first {
        for h in 0..r.volume_sources() {
            volume::plan_hair(r, g, ids, h, submission);
        }
    }
    if first && r.oit.is_some() {
        oit::plan_clear(g, ids, submission);
    }
    if first && !r.occluders.is_empty() {
        occluders::plan(g, ids, submission);
    }
    if r.oit.is_some() {
        oit::plan_fill(r, g, ids, batch, last, submission);
        if last {
            oit::plan_resolve(g, ids, submission);
        }
    } else {
        hair::plan(r, g, ids, batch, last, submission);
    }
    if last {
        copy_out::plan(g, ids, submission);
    }
}

/// Records one pass of a scene frame.
pub(crate) fn record(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    pass: &PassNode<ScenePass>,
    state: &FrameState<'_>,
    run: &GraphRun<'_, ScenePass>,
) -> gen_gpu::Result<()> {
    // The first pass that renders into the target clears it.
    let clear = run.untouched(state.plan.ids.color).then_some(r.scene.scene.output.background);
    match pass.payload {
        ScenePass::Shadow(_) => Ok(()),
        ScenePass::LodCull(i) => generate::record(r, rec, state, i, false),
        ScenePass::Generate(i) => generate::record(r, rec, state, i, true),
        ScenePass::ClearOit => oit::record_clear(rec, state),
        ScenePass::Occluders => occluders::record(r, rec, state, clear),
        ScenePass::DepthPrepass => hair::record_prepass(r, rec, state, clear),
        ScenePass::Raster => hair::record_raster(r, rec, state, clear),
        ScenePass::OitFill => oit::record_fill(r, rec, state, clear),
        ScenePass::OitResolve => oit::record_resolve(r, rec, state),
        ScenePass::ClearVisibility => compute_raster::record_clear(rec, state),
        ScenePass::OccluderDepthCopy => compute_raster::record_occluder_depth(rec, state),
        ScenePass::ComputeRaster(phase) => compute_raster::record_raster(r, rec, state, phase),
        ScenePass::RasterSlotOrder => compute_raster::record_slot_order(r, rec, state),
        ScenePass::RasterTiles => compute_raster::record_tiles(r, rec, state),
        ScenePass::RasterShade => compute_raster::record_shade(r, rec, state),
        ScenePass::RasterResolve => compute_raster::record_resolve(r, rec, state),
        ScenePass::Volume(h, step) => volume::record_hair(r, rec, state, h, step),
        ScenePass::March(i) => volume::record_march(r, rec, state, i),
        ScenePass::CopyOut => copy_out::record(rec, state),
        ScenePass::UpdateHair(k) => upload::record(r, rec, k),
    }
}

/// The strand resources a draw of `batch` (plus the stored strands on the last batch) reads.
pub(crate) fn strand_reads(
    r: &SceneRenderer,
    ids: &FrameIds,
    batch: &[usize],
    last: bool,
) -> Vec<(crate::graph::Res, crate::graph::Access)> {
    use crate::graph::Access;
    let mut reads = Vec::new();
    for &i in batch {
        reads.push((ids.lod[i], Access::IndirectRead));
        reads.push((ids.lod[i], Access::PreRasterRead));
        if r.path == gen_gpu::GenerationPath::Compute {
            reads.push((ids.strands[i], Access::PreRasterRead));
        } else {
            reads.push((ids.hair[i], Access::PreRasterRead));
        }
    }
    if last {
        reads.extend(ids.stored.iter().map(|&s| (s, Access::PreRasterRead)));
    }
    reads
}
