//! LOD + cull and generation of one character's strands for the camera (gen-gpu's compute path
//! passes; the mesh path generates while it draws and runs only the LOD pass, for statistics and
//! indirect arguments).

use gen_gpu::{GenerationPath, Recorder};

use super::ScenePass;
use crate::frame::{FrameIds, FrameState, SceneRenderer};
use crate::graph::{Access, FrameGraph};

pub(crate) fn plan(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    i: usize,
    submission: usize,
) {
    g.pass(format!("lod+cull character {i}"))
        .read(ids.hair[i], Access::ComputeRead)
        .write(ids.lod[i], Access::ComputeWrite)
        .submission(submission)
        .add(ScenePass::LodCull(i));
    // The compute rasterizer generates inside its raster kernel.
    if r.path == GenerationPath::Compute && r.compute_raster.is_none() {
        g.pass(format!("generate character {i}"))
            .read(ids.hair[i], Access::ComputeRead)
            .read(ids.lod[i], Access::ComputeRead)
            .read(ids.lod[i], Access::IndirectRead)
            .write(ids.strands[i], Access::ComputeWrite)
            .submission(submission)
            .add(ScenePass::Generate(i));
    }
}

fn frame<'a>(state: &'a FrameState<'_>, i: usize) -> Option<&'a gen_gpu::FrameBuffers> {
    state.frames.iter().find(|(c, _)| *c == i).map(|(_, f)| f)
}

/// Records character `i`'s LOD pass (`generate == false`) or its generation pass, when the
/// character is in this submission's batch.
pub(crate) fn record(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    state: &FrameState<'_>,
    i: usize,
    generate: bool,
) -> gen_gpu::Result<()> {
    if let Some(frame) = frame(state, i) {
        let hair = &r.hairs[r.characters[i].hair];
        if generate {
            r.generator.record_generate(rec, hair, frame);
        } else {
            r.generator.record_lod(rec, hair, frame);
        }
    }
    Ok(())
}
