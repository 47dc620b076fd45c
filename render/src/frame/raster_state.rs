//! What the compute rasterizer reads of the renderer: its slots, materials, depth clipping,
//! load path, pass names and the strand orders it keeps between frames.

use super::*;

impl SceneRenderer {
    /// Compute rasterizer with a slot order (OIT scenes): generated character `character`'s
    /// marks after the last frame — per strand slot the mask of its segments that reached the
    /// image, which the next frame draws first — or `None` without a slot order or before the
    /// first frame.
    pub fn strand_marks(&self, ctx: &Context, character: usize) -> Result<Option<Vec<u32>>, RenderError> {
        let history = self.slot_history.lock().unwrap_or_else(|e| e.into_inner());
        let Some(Some(c)) = history.characters.get(character) else { return Ok(None) };
        let bytes = ctx.read_buffer(&c.marks, c.capacity * 4)?;
        Ok(Some(bytemuck::pod_collect_to_vec(&bytes)))
    }

    /// Compute rasterizer with a slot order: the order generated character `character`'s
    /// strands were drawn in the last frame ([`crate::raster::StrandOrder`]), or `None`.
    pub fn strand_order(
        &self,
        ctx: &Context,
        character: usize,
    ) -> Result<Option<crate::raster::StrandOrder>, RenderError> {
        let history = self.slot_history.lock().unwrap_or_else(|e| e.into_inner());
        let Some(Some(c)) = history.characters.get(character) else { return Ok(None) };
        let header: Vec<u32> =
            bytemuck::pod_collect_to_vec(&ctx.read_buffer(&c.order, crate::raster::SLOT_ORDER_HEADER)?);
        let (front, rest) = (u64::from(header[6]), u64::from(header[7]));
        // The counts come from the GPU: never past the buffer (2 × capacity entries).
        if front + rest > 2 * c.capacity {
            return Err(RenderError::Gpu(gen_gpu::GpuError::OutOfRange {
                name: "strand slot order".into(),
                size: c.order.size(),
                requested: crate::raster::SLOT_ORDER_HEADER
                    + (front + rest) * crate::raster::SLOT_ORDER_ENTRY_BYTES,
            }));
        }
        let bytes = ctx.read_buffer(
            &c.order,
            crate::raster::SLOT_ORDER_HEADER + (front + rest) * crate::raster::SLOT_ORDER_ENTRY_BYTES,
        )?;
        let entries: Vec<[u32; 2]> =
            bytemuck::pod_collect_to_vec(&bytes[crate::raster::SLOT_ORDER_HEADER as usize..]);
        let (front, rest) = entries.split_at(front as usize);
        Ok(Some(crate::raster::StrandOrder { front: front.to_vec(), rest: rest.to_vec() }))
    }

    /// The strand opacity of compute-raster material `material`.
    pub(crate) fn raster_opacity(&self, material: u32) -> f32 {
        self.raster_materials.get(material as usize).map_or(1.0, |m| m.opacity[0])
    }

    /// Compute rasterizer: visibility slots per pixel the scene asks for (the K nearest
    /// fragments: `oit_k` with OIT, else 1).
    pub(super) fn raster_slots(&self) -> u32 {
        let effects = self.effects;
        if effects.transparency == Transparency::Oit { effects.oit_k } else { 1 }
    }

    /// The compute rasterizer's visibility slots per pixel in every frame: the scene's
    /// ([`Self::raster_slots`]) as many as one storage buffer holds at its output size
    /// ([`crate::raster::slots_within`]). Views are at most the output ([`Self::render_view`]),
    /// so each frame's buffers hold exactly these, and the kernels are specialized for them.
    pub(super) fn frame_slots(&self, ctx: &Context) -> u32 {
        let output = self.scene.scene.output;
        let pixels = u64::from(output.width) * u64::from(output.height);
        crate::raster::slots_within(self.raster_slots(), pixels, ctx.capabilities().max_storage_buffer_range)
    }

    /// The compute rasterizer's kernel variant for each character seen through `view`: the
    /// generated characters in scene order, then the stored ones. The raster pass binds these.
    pub fn raster_depth_clipping(&self, view: &FrameView) -> Vec<DepthClipping> {
        let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
        self.volume_characters()
            .map(|(c, source)| {
                if self.depth_clipping_everywhere {
                    DepthClipping::Clip
                } else {
                    // The matrix the kernels multiply positions by (camera::character_inputs).
                    DepthClipping::for_bounds(view_proj * c.transform, self.volume_bounds(source))
                }
            })
            .collect()
    }

    /// How the compute rasterizer's kernels are to read ([`Self::with_buffer_references`]).
    pub(super) fn compute_raster_loads(&self) -> LoadPath {
        if self.buffer_references { LoadPath::BufferReferences } else { LoadPath::Bindings }
    }

    /// The address the triangle OIT's shaders reach `buffer` through: its device address with
    /// buffer references on (0 where the device has none), else 0 (the binding).
    pub(crate) fn load_address(&self, buffer: &Buffer) -> u64 {
        if self.buffer_references { buffer.device_address() } else { 0 }
    }

    /// `raster hair (compute, opaque)` / `(…, blended)` on the triangle raster; on the compute
    /// rasterizer `raster hair (compute raster, …)` with what its kernels draw: `fused
    /// generation`, `stored strands` or both, and `straight lines` where the fused kernel draws
    /// them ([`Self::with_fused_strands`]).
    pub(crate) fn raster_pass_name(&self) -> String {
        if self.compute_raster.is_some() {
            let generated = self.slots.iter().any(|s| !s.stored);
            let stored = self.slots.iter().any(|s| s.stored);
            let drawn = match (generated, stored) {
                (true, true) => "fused generation + stored strands",
                (false, true) => "stored strands",
                _ => "fused generation",
            };
            let straight = match self.fused_strands {
                FusedStrands::Straight if generated => ", straight lines",
                _ => "",
            };
            return format!("raster hair (compute raster, {drawn}{straight})");
        }
        let mode = if self.depth_prepass.is_some() { "blended" } else { "opaque" };
        format!("raster hair ({}, {mode})", self.path)
    }

    /// The compute rasterizer's materials for a frame: with AO each names its character's volume
    /// (grid and placement).
    pub(super) fn frame_materials(&self, plan: &FramePlan) -> Vec<RasterMaterial> {
        let mut materials = self.raster_materials.clone();
        let flags = self.effects.volume_flags();
        let (Some(volumes), Some(ids), true) = (&self.volumes, &plan.ids.volumes, flags != 0) else {
            return materials;
        };
        // Generated characters, then stored ones, as the materials are numbered.
        for ((c, v), &m) in self.volume_characters().zip(&self.character_materials) {
            if let (Some(Some(p)), Some(material)) = (ids.hairs.get(v), materials.get_mut(m as usize)) {
                let address = volumes.store.address(v, &p.grid);
                material.world_to_voxel = p.grid.world_to_voxel(c.transform).to_cols_array();
                material.volume = address.dims;
                material.volume_info = [address.first_brick, flags, 0, 0];
            }
        }
        materials
    }
}
