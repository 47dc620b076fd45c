//! `--screenshot`: waiting for the full-quality preview, then saving the window.

use super::*;

impl ScreenshotRequest {
    /// A screenshot of the window titled `title`, to `out`.
    pub fn new(out: PathBuf, title: &str) -> Self {
        Self { out, title: title.to_owned(), asked: false, ready_frames: 0, result: Arc::default() }
    }
}

impl EditorApp {
    /// `--screenshot`: once the final preview has been shown for a frame, capture the window
    /// from outside ([`crate::xwd`]) in a thread and report through [`ScreenshotRequest::result`].
    pub(super) fn screenshot_step(&mut self, ctx: &egui::Context) {
        let ready = self.preview_is_final() && self.conversion.is_none();
        let Some(shot) = &mut self.screenshot else { return };
        if shot.asked || !ready {
            shot.ready_frames = 0;
            return;
        }
        // This frame draws the final preview; capture after it has been presented.
        shot.ready_frames += 1;
        if shot.ready_frames < 3 {
            ctx.request_repaint_after(std::time::Duration::from_millis(300));
            return;
        }
        shot.asked = true;
        let (out, result, title, waker) =
            (shot.out.clone(), shot.result.clone(), shot.title.clone(), ctx.clone());
        std::thread::spawn(move || {
            let r = crate::xwd::screenshot(&title, &out);
            *result.lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
            waker.request_repaint();
        });
    }
}
