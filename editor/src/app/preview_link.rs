//! The link to the preview worker: what a frame of the preview is made from, sending requests
//! when it changes, and taking the frames and errors the worker sends back.

use super::*;

impl EditorApp {
    /// The request the preview should be drawing now.
    pub(super) fn request_key(&self) -> Option<RequestKey> {
        let doc = self.doc.as_ref()?;
        if self.viewport_size[0] < 8 || self.viewport_size[1] < 8 {
            return None;
        }
        let mut scene = self.scene.clone();
        scene.color = doc.color();
        Some(RequestKey {
            generation: doc.generation,
            revision: doc.asset().revision(),
            camera: self.camera,
            size: self.viewport_size,
            scene,
        })
    }

    /// Sends a draft while interacting and the full frame after, once per state.
    pub(super) fn update_preview(&mut self) {
        let (Some(key), Some(doc)) = (self.request_key(), self.doc.as_ref()) else { return };
        let draft = self.interacting;
        let key_changed = self.requested.as_ref().is_none_or(|(k, _)| *k != key);
        let refine = self.requested.as_ref().is_some_and(|(k, d)| *k == key && *d && !draft);
        if !(key_changed || refine) {
            return;
        }
        let Some(worker) = self.preview.as_mut() else { return };
        let id =
            worker.request(PreviewRequest::for_document(doc, key.scene.clone(), key.camera, key.size, draft));
        self.preview_requests += 1;
        self.last_request_id = Some(id);
        self.requested = Some((key, draft));
    }

    pub(super) fn poll_preview(&mut self, ctx: &egui::Context) {
        let events = self.preview.as_ref().map(PreviewWorker::poll).unwrap_or_default();
        for event in events {
            self.apply_preview_event(ctx, event);
        }
    }

    /// Waits up to `timeout` for the next preview event and applies it (tests and
    /// `--screenshot`); `false` on timeout.
    pub fn wait_for_preview(&mut self, ctx: &egui::Context, timeout: std::time::Duration) -> bool {
        let Some(event) = self.preview.as_ref().and_then(|w| w.wait(timeout)) else { return false };
        self.apply_preview_event(ctx, event);
        true
    }

    /// Applies one event of the preview worker (frames become the viewport texture).
    pub(super) fn apply_preview_event(&mut self, ctx: &egui::Context, event: PreviewEvent) {
        match event {
            PreviewEvent::Ready { device, path } => {
                self.device = Some(format!("{device} · {path} generation"));
            }
            PreviewEvent::Unavailable { message } | PreviewEvent::Failed { message, .. } => {
                self.preview_error = Some(message);
            }
            PreviewEvent::Frame(frame) => {
                self.preview_error = None;
                let image = egui::ColorImage::from_rgba_unmultiplied(
                    [frame.image.width as usize, frame.image.height as usize],
                    &frame.image.pixels,
                );
                let options = egui::TextureOptions::LINEAR;
                match &mut self.texture {
                    Some(t) => t.set(image, options),
                    None => self.texture = Some(ctx.load_texture("hair preview", image, options)),
                }
                self.shown = Some(ShownFrame {
                    id: frame.id,
                    draft: frame.draft,
                    ms: frame.ms,
                    strands: frame.strands,
                    vertices: frame.vertices,
                    raster: frame.raster,
                    size: [frame.image.width, frame.image.height],
                    image: Arc::new(frame.image),
                });
            }
        }
    }

    /// The preview frame shown (sRGB RGBA).
    pub fn shown_image(&self) -> Option<&gen_gpu::RgbaImage> {
        self.shown.as_ref().map(|s| &*s.image)
    }

    /// Whether the preview shows a full-quality frame of the current state.
    pub fn preview_is_final(&self) -> bool {
        // The frame answers the latest request, which was for the current state.
        self.shown.as_ref().is_some_and(|s| !s.draft && Some(s.id) == self.last_request_id)
            && self.requested.as_ref().is_some_and(|(k, _)| Some(k) == self.request_key().as_ref())
    }
}
