//! The (resolved) colour and depth into the readback buffers.

use gen_gpu::Recorder;

use super::ScenePass;
use crate::frame::{FrameIds, FrameState};
use crate::graph::{Access, FrameGraph};

pub(crate) fn plan(g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    let (color, depth) = ids.resolve.unwrap_or((ids.color, ids.depth));
    g.pass("copy out")
        .read(color, Access::TransferRead)
        .read(depth, Access::TransferRead)
        .write(ids.readback, Access::TransferWrite)
        .submission(submission)
        .add(ScenePass::CopyOut);
}

pub(crate) fn record(rec: &mut Recorder<'_>, state: &FrameState<'_>) -> gen_gpu::Result<()> {
    state.target.copy_out(rec);
    Ok(())
}
