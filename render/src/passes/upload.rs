//! Hair uploads: the texels and bundle entries an edit or a simulation step re-baked
//! ([`crate::frame::SceneRenderer::update_hair`]), copied into the hair's textures before
//! anything of the frame reads them. Only hairs that changed since the last frame get a pass,
//! so a scene without edits or dynamics has none.

use gen_gpu::Recorder;

use super::ScenePass;
use crate::frame::{FrameIds, SceneRenderer};
use crate::graph::{Access, FrameGraph};

/// One pass per staged update, in the order they were staged, at the start of `submission`
/// (the shadow maps' when they are made this frame, else the first batch's).
pub(crate) fn plan(r: &SceneRenderer, g: &mut FrameGraph<ScenePass>, ids: &FrameIds, submission: usize) {
    for (k, (hair, revision)) in r.staged_hair_updates().into_iter().enumerate() {
        g.pass(format!("update hair {hair} (revision {revision})"))
            .write(ids.hair_uploads[hair], Access::TransferWrite)
            .submission(submission)
            .add(ScenePass::UpdateHair(k));
    }
}

pub(crate) fn record(r: &SceneRenderer, rec: &mut Recorder<'_>, k: usize) -> gen_gpu::Result<()> {
    r.record_hair_update(rec, k);
    Ok(())
}
