//! Choices made after set-up: which rasterizer draws shadows, the compute rasterizer's phases,
//! slot order, clipping and loads, volumes everywhere, batch size, stale shadow maps.

use super::*;

impl SceneRenderer {
    /// Whether the deep opacity maps are rasterized by the compute rasterizer's kernels (with
    /// the compute rasterizer and shadows) rather than the triangle pipeline.
    pub fn compute_shadows(&self) -> bool {
        self.shadow.as_ref().is_some_and(|s| s.compute.is_some())
    }

    /// Renders the deep opacity maps through the triangle pipeline from now on, whatever the
    /// rasterizer (the reference the compute maps are tested and benchmarked against); maps
    /// already cached are made again on the next frame.
    pub fn use_triangle_shadows(&mut self) {
        if let Some(s) = &mut self.shadow {
            s.compute = None;
        }
        self.forget_shadow_maps();
    }

    /// Drops the cached shadow maps: the next frame makes them again (benchmarks time them so).
    pub fn forget_shadow_maps(&self) {
        *self.shadow_cache.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }

    /// The rasterizer this renderer draws hair with.
    pub fn raster(&self) -> RasterPath {
        if self.compute_raster.is_some() { RasterPath::Compute } else { RasterPath::Triangles }
    }

    /// Whether the compute rasterizer's front phase draws each character's strand segments
    /// that reached the last frame's image ([`Self::with_slot_order`]): with occlusion tiles
    /// and more than one visibility slot per pixel (OIT). With one slot (opaque and blended
    /// scenes) it is no faster than every eighth strand: their front phase closes the
    /// tiles already, and the rest then generates the marked strands a second time.
    pub(crate) fn raster_slot_order(&self) -> bool {
        let several_slots =
            self.compute_raster.as_ref().and_then(ComputeRaster::slots).is_some_and(|k| k > 1);
        several_slots && self.occlusion_tiles && self.slot_order
    }

    /// Compute rasterizer: `false` draws every strand in one dispatch instead of the front
    /// strands, the occlusion tiles and the rest (the image is the same; tests compare them).
    pub fn with_occlusion_tiles(mut self, on: bool) -> Self {
        self.occlusion_tiles = on;
        self
    }

    /// Compute rasterizer with occlusion tiles and OIT: `false` makes the front phase every
    /// eighth strand slot of each character in every frame, instead of the strand segments that
    /// reached the last frame's image (the image is the same; tests compare them).
    pub fn with_slot_order(mut self, on: bool) -> Self {
        self.slot_order = on;
        self
    }

    /// Compute rasterizer: `true` draws every character with the raster kernels' variant that
    /// clips segments to the view volume's depth, where by default a character whose bounds lie
    /// wholly inside it goes through the one without ([`crate::raster::DepthClipping`]; the
    /// image is the same: tests compare them).
    pub fn with_depth_clipping_everywhere(mut self, on: bool) -> Self {
        self.depth_clipping_everywhere = on;
        self
    }

    /// Compute rasterizer: `false` has its raster and shade kernels read the pixel words,
    /// occlusion tiles and shadow maps through their bindings instead of buffer references (the
    /// image is the same; tests compare them). References are the default where the device has
    /// buffer device addresses: CPU devices gather loads through them with vector instructions.
    /// The kernels are specialized for one or the other ([`crate::raster::LoadPath`]), so a
    /// change makes the compute rasterizer's pipelines again.
    pub fn with_buffer_references(mut self, ctx: &Context, on: bool) -> Result<Self, RenderError> {
        self.buffer_references = on;
        self.remake_compute_raster(ctx)?;
        Ok(self)
    }

    /// Compute rasterizer: what its fused-generation kernel draws of each strand. The default,
    /// [`FusedStrands::Styled`], is the frames' strands; [`FusedStrands::Straight`] draws each
    /// as a straight line from its root to its tip through the same walk — a different image,
    /// for benchmarks that measure what generation costs inside the kernel (`hair-bench --only
    /// raster`); its raster passes say so in their names. The kernels are specialized for one
    /// or the other, so a change makes the compute rasterizer's pipelines again.
    pub fn with_fused_strands(mut self, ctx: &Context, strands: FusedStrands) -> Result<Self, RenderError> {
        self.fused_strands = strands;
        self.remake_compute_raster(ctx)?;
        Ok(self)
    }

    /// The compute rasterizer's pipelines made again for the renderer's settings (when it has
    /// them).
    pub(super) fn remake_compute_raster(&mut self, ctx: &Context) -> Result<(), RenderError> {
        if self.compute_raster.is_some() {
            let (lights, materials) = (self.scene.lights().len(), self.raster_materials.len());
            self.compute_raster = Some(ComputeRaster::new(
                ctx,
                lights,
                materials,
                self.compute_raster_loads(),
                Some(self.frame_slots(ctx)),
                self.fused_strands,
            )?);
        }
        Ok(())
    }

    /// With `"volume_lod"`: `true` raymarches every character, whatever its projected size (the
    /// camera inside its hair too), for comparisons and benchmarks of the volume path.
    pub fn with_volumes_everywhere(mut self, on: bool) -> Self {
        self.volumes_everywhere = on;
        self
    }

    /// Caps the strand-buffer bytes of one submission (default [`BATCH_BYTES`]); at least one
    /// character goes into each batch.
    pub fn with_batch_bytes(mut self, bytes: u64) -> Self {
        self.batch_bytes = bytes;
        self
    }

    /// While `reuse` is true, frames show the cached shadow maps even when the hair, the
    /// placements or the LOD changed since they were made (an editor's drafts while a slider or
    /// a vertex is dragged: the maps cost more than the rest of such a frame); the first frame
    /// with it false makes them again if they are stale. Without cached maps a frame makes them
    /// either way.
    pub fn reuse_stale_shadow_maps(&self, reuse: bool) {
        self.stale_shadows_ok.store(reuse, std::sync::atomic::Ordering::Relaxed);
    }
}
