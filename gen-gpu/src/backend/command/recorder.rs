//! Recording a command buffer: passes with timestamp scopes, pipelines and descriptors, push
//! constants, dispatches and draws, barriers, dynamic rendering.

use super::*;

pub(super) struct Scope {
    pub(super) name: String,
    pub(super) depth: u32,
    pub(super) begin: u32,
    pub(super) end: Option<u32>,
}

/// Records one command buffer. Every pass is wrapped in a debug label and a timestamp scope.
pub struct Recorder<'a> {
    pub(super) ctx: &'a Context,
    pub cmd: vk::CommandBuffer,
    pub(super) query_pool: vk::QueryPool,
    pub(super) scopes: Vec<Scope>,
    pub(super) depth: u32,
    pub(super) next_query: u32,
    /// Whether the submission has begun rendering (`write_timestamp`).
    pub(super) rendered: std::cell::Cell<bool>,
}

impl std::fmt::Debug for Recorder<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder").field("scopes", &self.scopes.len()).finish()
    }
}

/// The attachments of [`Recorder::begin_rendering_to`].
#[derive(Clone, Copy, Debug)]
pub struct Attachments<'a> {
    pub color: &'a Image,
    /// A single-sample image the multisampled `color` resolves into (average).
    pub color_resolve: Option<&'a Image>,
    /// `Some(colour)` clears the colour image, `None` keeps its contents.
    pub clear: Option<[f32; 4]>,
    pub depth: Option<&'a Image>,
    /// A single-sample image the multisampled `depth` resolves into (sample 0).
    pub depth_resolve: Option<&'a Image>,
    /// Clear depth to 1 (else keep it).
    pub clear_depth: bool,
}

impl<'a> Recorder<'a> {
    pub fn ctx(&self) -> &'a Context {
        self.ctx
    }

    pub(super) fn device(&self) -> &ash::Device {
        self.ctx.device()
    }

    /// Runs `f` inside a debug label and a timestamp scope named `name`.
    pub fn pass<R>(&mut self, name: &str, f: impl FnOnce(&mut Self) -> R) -> R {
        let label = CString::new(name).unwrap_or_default();
        if let Some(du) = &self.ctx.shared.debug_utils {
            let info = vk::DebugUtilsLabelEXT::default().label_name(&label);
            // SAFETY: recording command buffer; label outlives the call.
            unsafe { du.cmd_begin_debug_utils_label(self.cmd, &info) };
        }
        // Both queries are reserved now, so an outer scope always gets its end even when the
        // scopes inside it use up the pool.
        let scope = self.reserve_queries().map(|begin| {
            self.write_timestamp(begin);
            self.scopes.push(Scope { name: name.into(), depth: self.depth, begin, end: None });
            self.scopes.len() - 1
        });
        self.depth += 1;
        let result = f(self);
        self.depth -= 1;
        if let Some(i) = scope {
            let end = self.scopes[i].begin + 1;
            self.write_timestamp(end);
            self.scopes[i].end = Some(end);
        }
        if let Some(du) = &self.ctx.shared.debug_utils {
            // SAFETY: matches the begin above.
            unsafe { du.cmd_end_debug_utils_label(self.cmd) };
        }
        result
    }

    /// Two consecutive queries of the pool (begin, end), if any are left.
    fn reserve_queries(&mut self) -> Option<u32> {
        if self.query_pool == vk::QueryPool::null() || self.next_query + 2 > 2 * MAX_SCOPES {
            return None;
        }
        self.next_query += 2;
        Some(self.next_query - 2)
    }

    fn write_timestamp(&mut self, index: u32) {
        let write = |index| {
            // SAFETY: the pool was reset before recording, and each index is written once: the
            // scopes' in [0, 2 * MAX_SCOPES) as reserved, their settling ones above.
            unsafe {
                self.device().cmd_write_timestamp2(
                    self.cmd,
                    vk::PipelineStageFlags2::ALL_COMMANDS,
                    self.query_pool,
                    index,
                );
            }
        };
        write(index);
        // llvmpipe (lavapipe) reads the clock for a timestamp written while a framebuffer is
        // bound — after any rendering, until the submission ends — only when its rasterizer
        // runs the binned commands, at the next flush; lavapipe flushes before each timestamp
        // write. So such a timestamp took the time of the next one: a pass's begin that of its
        // end, and every pass after the first draw seemed to take no time. A second write right after
        // flushes the first at its own time (its value is never read). Before any rendering
        // a timestamp reads the clock when written: no second write.
        if self.rendered.get() && self.ctx.capabilities().is_cpu() {
            write(2 * MAX_SCOPES + index);
        }
    }

    pub fn bind_pipeline(&self, pipeline: &Pipeline) {
        // SAFETY: recording; the pipeline outlives the synchronous submission.
        unsafe { self.device().cmd_bind_pipeline(self.cmd, pipeline.bind_point, pipeline.raw) };
    }

    /// Binds whole storage buffers to set 0 with push descriptors.
    pub fn push_storage_buffers(&self, pipeline: &Pipeline, buffers: &[(u32, &Buffer)]) {
        self.push_descriptors(pipeline, buffers, &[]);
    }

    /// Binds whole storage buffers and combined image samplers of set 0 with push descriptors.
    pub fn push_descriptors(
        &self,
        pipeline: &Pipeline,
        buffers: &[(u32, &Buffer)],
        images: &[(u32, &Image, &crate::Sampler)],
    ) {
        let ranged: Vec<(u32, &Buffer, u64, u64)> =
            buffers.iter().map(|(b, buf)| (*b, *buf, 0, vk::WHOLE_SIZE)).collect();
        self.push_descriptors_ranged(pipeline, &ranged, images);
    }

    /// Like [`Self::push_descriptors`], with `(binding, buffer, offset, range)` windows of
    /// buffers larger than one descriptor may address.
    pub fn push_descriptors_ranged(
        &self,
        pipeline: &Pipeline,
        buffers: &[(u32, &Buffer, u64, u64)],
        images: &[(u32, &Image, &crate::Sampler)],
    ) {
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|(_, b, offset, range)| {
                [vk::DescriptorBufferInfo { buffer: b.raw, offset: *offset, range: *range }]
            })
            .collect();
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = images
            .iter()
            .map(|(_, i, s)| {
                [vk::DescriptorImageInfo {
                    sampler: s.raw,
                    image_view: i.view,
                    image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                }]
            })
            .collect();
        let mut writes: Vec<vk::WriteDescriptorSet<'_>> = buffers
            .iter()
            .zip(&buffer_infos)
            .map(|((binding, ..), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_binding(*binding)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(info)
            })
            .collect();
        writes.extend(images.iter().zip(&image_infos).map(|((binding, _, _), info)| {
            vk::WriteDescriptorSet::default()
                .dst_binding(*binding)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .image_info(info)
        }));
        // SAFETY: recording; the writes point at live resources and match the set layout.
        unsafe {
            self.ctx.shared.push_descriptor.cmd_push_descriptor_set(
                self.cmd,
                pipeline.bind_point,
                pipeline.layout,
                0,
                &writes,
            );
        }
    }

    /// `vkCmdDispatchIndirect` with the arguments at `offset`.
    pub fn dispatch_indirect(&self, args: &Buffer, offset: u64) {
        // SAFETY: recording with a compute pipeline bound; `args` holds a dispatch command.
        unsafe { self.device().cmd_dispatch_indirect(self.cmd, args.raw, offset) };
    }

    /// Raw push-constant bytes at `offset` (nothing for an empty slice). In debug builds the
    /// range is checked against the push-constant blocks the pipeline's shaders declare
    /// ([`Pipeline::push_mismatch`]).
    pub fn push_constant_bytes(&self, pipeline: &Pipeline, offset: u32, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        let mismatch = pipeline.push_mismatch(offset, bytes.len() as u32);
        debug_assert!(mismatch.is_none(), "{}", mismatch.unwrap_or_default());
        // SAFETY: recording; the caller keeps offset + len within the layout's range.
        unsafe {
            self.device().cmd_push_constants(
                self.cmd,
                pipeline.layout,
                pipeline.push_constant_stages,
                offset,
                bytes,
            );
        }
    }

    /// Pushes `data` at offset 0 ([`Self::push_constant_bytes`]).
    pub fn push_constants<T: bytemuck::Pod>(&self, pipeline: &Pipeline, data: &T) {
        self.push_constant_bytes(pipeline, 0, bytemuck::bytes_of(data));
    }

    pub fn dispatch(&self, x: u32, y: u32, z: u32) {
        // SAFETY: recording with a compute pipeline bound.
        unsafe { self.device().cmd_dispatch(self.cmd, x, y, z) };
    }

    /// A full memory barrier between two stage/access sets.
    pub fn memory_barrier(
        &self,
        src: (vk::PipelineStageFlags2, vk::AccessFlags2),
        dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
    ) {
        let barrier = vk::MemoryBarrier2::default()
            .src_stage_mask(src.0)
            .src_access_mask(src.1)
            .dst_stage_mask(dst.0)
            .dst_access_mask(dst.1);
        self.pipeline_barrier(&[barrier], &[]);
    }

    /// One `vkCmdPipelineBarrier2` with global memory barriers and image barriers (a frame
    /// graph's derived barriers for one pass). Nothing is recorded for two empty lists.
    pub fn pipeline_barrier(
        &self,
        memory: &[vk::MemoryBarrier2<'_>],
        images: &[vk::ImageMemoryBarrier2<'_>],
    ) {
        if memory.is_empty() && images.is_empty() {
            return;
        }
        let dep = vk::DependencyInfo::default().memory_barriers(memory).image_memory_barriers(images);
        // SAFETY: recording outside a rendering scope (passes begin and end their own); the
        // image barriers name live images of this device with whole-image ranges.
        unsafe { self.device().cmd_pipeline_barrier2(self.cmd, &dep) };
    }

    /// Transitions a whole image between layouts.
    pub fn image_barrier(
        &self,
        image: &Image,
        layouts: (vk::ImageLayout, vk::ImageLayout),
        src: (vk::PipelineStageFlags2, vk::AccessFlags2),
        dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
    ) {
        let barrier = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(src.0)
            .src_access_mask(src.1)
            .dst_stage_mask(dst.0)
            .dst_access_mask(dst.1)
            .old_layout(layouts.0)
            .new_layout(layouts.1)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image.raw)
            .subresource_range(image.full_range());
        self.pipeline_barrier(&[], &[barrier]);
    }

    /// Begins dynamic rendering into `color` (cleared) and an optional depth image (cleared to
    /// 1), both already in attachment layouts; sets viewport and scissor to the full image.
    pub fn begin_rendering(&self, color: &Image, clear: [f32; 4], depth: Option<&Image>) {
        self.begin_rendering_to(&Attachments {
            color,
            color_resolve: None,
            clear: Some(clear),
            depth,
            depth_resolve: None,
            clear_depth: true,
        });
    }

    /// Begins dynamic rendering into `targets` (all already in attachment layouts); sets
    /// viewport and scissor to the full colour image. Depth is stored, so a later pass can
    /// load it or copy it out.
    pub fn begin_rendering_to(&self, targets: &Attachments<'_>) {
        let color = targets.color;
        let extent = vk::Extent2D { width: color.desc.extent.width, height: color.desc.extent.height };
        let mut color_att = vk::RenderingAttachmentInfo::default()
            .image_view(color.view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .store_op(vk::AttachmentStoreOp::STORE);
        color_att = match targets.clear {
            Some(clear) => color_att
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: clear } }),
            None => color_att.load_op(vk::AttachmentLoadOp::LOAD),
        };
        if let Some(resolve) = targets.color_resolve {
            color_att = color_att
                .resolve_mode(vk::ResolveModeFlags::AVERAGE)
                .resolve_image_view(resolve.view)
                .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        }
        let color_atts = [color_att];
        let depth_att = targets.depth.map(|d| {
            let mut att = vk::RenderingAttachmentInfo::default()
                .image_view(d.view)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .store_op(vk::AttachmentStoreOp::STORE);
            att = if targets.clear_depth {
                att.load_op(vk::AttachmentLoadOp::CLEAR).clear_value(vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 },
                })
            } else {
                att.load_op(vk::AttachmentLoadOp::LOAD)
            };
            if let Some(resolve) = targets.depth_resolve {
                // SAMPLE_ZERO is the one depth resolve mode every device supports.
                att = att
                    .resolve_mode(vk::ResolveModeFlags::SAMPLE_ZERO)
                    .resolve_image_view(resolve.view)
                    .resolve_image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL);
            }
            att
        });
        let area = vk::Rect2D { offset: vk::Offset2D::default(), extent };
        let mut info =
            vk::RenderingInfo::default().render_area(area).layer_count(1).color_attachments(&color_atts);
        if let Some(d) = &depth_att {
            info = info.depth_attachment(d);
        }
        self.begin_rendering_with(&info, area);
    }

    /// Begins rendering and sets viewport and scissor to `area`.
    fn begin_rendering_with(&self, info: &vk::RenderingInfo<'_>, area: vk::Rect2D) {
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: area.extent.width as f32,
            height: area.extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        self.rendered.set(true);
        // SAFETY: recording; the caller's attachments are live and in the stated layouts.
        unsafe {
            self.device().cmd_begin_rendering(self.cmd, info);
            self.device().cmd_set_viewport(self.cmd, 0, &[viewport]);
            self.device().cmd_set_scissor(self.cmd, 0, &[area]);
        }
    }

    /// Begins rendering into `color` keeping its contents (no depth attachment).
    pub fn begin_rendering_load(&self, color: &Image) {
        let extent = vk::Extent2D { width: color.desc.extent.width, height: color.desc.extent.height };
        let color_att = [vk::RenderingAttachmentInfo::default()
            .image_view(color.view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let area = vk::Rect2D { offset: vk::Offset2D::default(), extent };
        let info =
            vk::RenderingInfo::default().render_area(area).layer_count(1).color_attachments(&color_att);
        self.begin_rendering_with(&info, area);
    }

    pub fn end_rendering(&self) {
        // SAFETY: matches begin_rendering.
        unsafe { self.device().cmd_end_rendering(self.cmd) };
    }

    pub fn draw(&self, vertex_count: u32, instance_count: u32) {
        // SAFETY: recording inside rendering with a graphics pipeline bound.
        unsafe { self.device().cmd_draw(self.cmd, vertex_count, instance_count, 0, 0) };
    }

    /// `vkCmdDrawIndirect` with one `VkDrawIndirectCommand` at `offset`.
    pub fn draw_indirect(&self, args: &Buffer, offset: u64) {
        // SAFETY: recording inside rendering; `args` holds a draw command at `offset`.
        unsafe { self.device().cmd_draw_indirect(self.cmd, args.raw, offset, 1, 16) };
    }

    /// `vkCmdDrawMeshTasksEXT`; the caller keeps counts within the device's limits.
    pub fn draw_mesh_tasks(&self, x: u32, y: u32, z: u32) -> Result<()> {
        let ext = self.ctx.mesh_shader_ext().ok_or_else(|| GpuError::MeshShaderUnsupported {
            requested: "mesh",
            device: self.ctx.capabilities().device_name.clone(),
        })?;
        // SAFETY: recording inside rendering with a mesh pipeline bound.
        unsafe { ext.cmd_draw_mesh_tasks(self.cmd, x, y, z) };
        Ok(())
    }
}
