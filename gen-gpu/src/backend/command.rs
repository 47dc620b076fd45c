use std::ffi::CString;
use std::time::Instant;

use ash::vk;

use crate::error::VkResultExt;
use crate::{Buffer, BufferDesc, Context, GpuError, Image, ImageDesc, MemoryLocation, Pipeline, Result};

/// Most timestamp scopes one submission records (a crowd frame has a few per character); later
/// scopes are labelled but untimed.
const MAX_SCOPES: u32 = 2048;
/// Queries of a submission's pool: each scope's begin and end, then as many settling writes
/// (see `Recorder::write_timestamp`).
const POOL_QUERIES: u32 = 4 * MAX_SCOPES;

/// GPU time of one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTiming {
    pub name: String,
    /// Nesting depth (0 for top-level passes).
    pub depth: u32,
    /// GPU time in milliseconds; `None` when the device has no timestamps.
    pub gpu_ms: Option<f64>,
}

/// What one submission cost.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameTimings {
    pub passes: Vec<PassTiming>,
    /// Wall-clock time from submit to fence, milliseconds.
    pub cpu_wait_ms: f64,
}

impl FrameTimings {
    /// GPU time of the first pass named `name`.
    pub fn pass_ms(&self, name: &str) -> Option<f64> {
        self.passes.iter().find(|p| p.name == name).and_then(|p| p.gpu_ms)
    }
}

impl std::fmt::Display for FrameTimings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for p in &self.passes {
            let indent = "  ".repeat(p.depth as usize);
            match p.gpu_ms {
                Some(ms) => writeln!(f, "  {indent}{:<28} {ms:9.3} ms", p.name)?,
                None => writeln!(f, "  {indent}{:<28}       n/a", p.name)?,
            }
        }
        write!(f, "  {:<28} {:9.3} ms (wall, submit to fence)", "total", self.cpu_wait_ms)
    }
}

/// One pass's GPU time over several frames of the same graph (`TimingSummary`).
#[derive(Clone, Debug, PartialEq)]
pub struct PassSummary {
    pub name: String,
    /// Nesting depth (0 for top-level passes).
    pub depth: u32,
    /// Frames that timed the pass (fewer than the summary's when a pass ran in some frames only,
    /// such as shadow maps made once and cached).
    pub frames: usize,
    /// Median, first and third quartile of its GPU time, milliseconds.
    pub median_ms: f64,
    pub q1_ms: f64,
    pub q3_ms: f64,
}

/// Per-pass GPU times over several frames: what a single frame's timings cannot tell on a
/// device whose frames vary (on a CPU device by 5–10 % from frame to frame). Passes are matched
/// from frame to frame by name, depth and occurrence (a crowd frame has a pass per character
/// under one name), in the order they first appear; untimed passes are left out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimingSummary {
    /// Frames summarized.
    pub frames: usize,
    pub passes: Vec<PassSummary>,
    /// Median wall-clock time from submit to fence, milliseconds.
    pub wall_median_ms: f64,
}

/// The p-quantile (0 ≤ p ≤ 1) of sorted values, interpolated between the two nearest ranks
/// (0 for none).
fn quantile(sorted: &[f64], p: f64) -> f64 {
    let Some(last) = sorted.len().checked_sub(1) else { return 0.0 };
    let h = last as f64 * p.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(last);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

impl TimingSummary {
    /// The summary of `frames` (in any order).
    pub fn of(frames: &[FrameTimings]) -> Self {
        // (name, depth, occurrence) -> its index in `keys` and `times`, in order of first
        // appearance.
        let mut index: std::collections::HashMap<(&str, u32, usize), usize> =
            std::collections::HashMap::new();
        let mut keys: Vec<(&str, u32)> = Vec::new();
        let mut times: Vec<Vec<f64>> = Vec::new();
        for frame in frames {
            let mut seen: std::collections::HashMap<(&str, u32), usize> = std::collections::HashMap::new();
            for pass in &frame.passes {
                let occurrence = seen.entry((pass.name.as_str(), pass.depth)).or_insert(0);
                let key = (pass.name.as_str(), pass.depth, *occurrence);
                *occurrence += 1;
                let Some(ms) = pass.gpu_ms.filter(|ms| ms.is_finite()) else { continue };
                let i = *index.entry(key).or_insert_with(|| {
                    keys.push((key.0, key.1));
                    times.push(Vec::new());
                    keys.len() - 1
                });
                times[i].push(ms);
            }
        }
        let passes = keys
            .into_iter()
            .zip(times)
            .map(|((name, depth), mut t)| {
                t.sort_by(f64::total_cmp);
                PassSummary {
                    name: name.to_owned(),
                    depth,
                    frames: t.len(),
                    median_ms: quantile(&t, 0.5),
                    q1_ms: quantile(&t, 0.25),
                    q3_ms: quantile(&t, 0.75),
                }
            })
            .collect();
        let mut wall: Vec<f64> = frames.iter().map(|f| f.cpu_wait_ms).filter(|ms| ms.is_finite()).collect();
        wall.sort_by(f64::total_cmp);
        Self { frames: frames.len(), passes, wall_median_ms: quantile(&wall, 0.5) }
    }
}

impl std::fmt::Display for TimingSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "  GPU time over {} frames: median (first to third quartile)", self.frames)?;
        for p in &self.passes {
            let indent = "  ".repeat(p.depth as usize);
            let partial = match p.frames {
                n if n == self.frames => String::new(),
                1 => ", 1 frame".to_owned(),
                n => format!(", {n} frames"),
            };
            writeln!(
                f,
                "  {indent}{:<28} {:9.3} ms ({:.3}–{:.3}{partial})",
                p.name, p.median_ms, p.q1_ms, p.q3_ms
            )?;
        }
        write!(f, "  {:<28} {:9.3} ms (wall, submit to fence, median)", "total", self.wall_median_ms)
    }
}

struct Scope {
    name: String,
    depth: u32,
    begin: u32,
    end: Option<u32>,
}

/// Records one command buffer. Every pass is wrapped in a debug label and a timestamp scope.
pub struct Recorder<'a> {
    ctx: &'a Context,
    pub cmd: vk::CommandBuffer,
    query_pool: vk::QueryPool,
    scopes: Vec<Scope>,
    depth: u32,
    next_query: u32,
    /// Whether the submission has begun rendering (`write_timestamp`).
    rendered: std::cell::Cell<bool>,
}

impl std::fmt::Debug for Recorder<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder").field("scopes", &self.scopes.len()).finish()
    }
}

impl<'a> Recorder<'a> {
    pub fn ctx(&self) -> &'a Context {
        self.ctx
    }

    fn device(&self) -> &ash::Device {
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
        // end, and every pass after the first draw measured ~0 ms. A second write right after
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

    /// Raw push-constant bytes at `offset` (nothing for an empty slice).
    pub fn push_constant_bytes(&self, pipeline: &Pipeline, offset: u32, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
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

    pub fn push_constants<T: bytemuck::Pod>(&self, pipeline: &Pipeline, data: &T) {
        // SAFETY: recording; the layout declares a push-constant range at offset 0 that the
        // caller sized for `T`.
        unsafe {
            self.device().cmd_push_constants(
                self.cmd,
                pipeline.layout,
                pipeline.push_constant_stages,
                0,
                bytemuck::bytes_of(data),
            );
        }
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

    /// Fills a whole buffer with a repeated 32-bit value.
    pub fn fill_buffer(&self, buffer: &Buffer, value: u32) {
        // SAFETY: recording outside rendering; the buffer is live and was created with
        // TRANSFER_DST (storage buffers here are).
        unsafe { self.device().cmd_fill_buffer(self.cmd, buffer.raw, 0, vk::WHOLE_SIZE, value) };
    }

    /// Fills `size` bytes of a buffer from byte `offset` with a repeated 32-bit value. Offset
    /// and size must be multiples of 4, the range non-empty and within the buffer; anything
    /// else is refused with [`GpuError::BadFill`] before it reaches the driver.
    pub fn fill_buffer_range(&self, buffer: &Buffer, offset: u64, size: u64, value: u32) -> Result<()> {
        if let Some(why) = transfer_range_problem(buffer, offset, size, false) {
            return Err(GpuError::BadFill { name: buffer.name().into(), offset, size, why });
        }
        // SAFETY: recording outside rendering; the buffer is live and was created with
        // TRANSFER_DST (storage buffers here are); offset and size were checked above
        // (multiples of 4, inside the buffer), as vkCmdFillBuffer requires.
        unsafe { self.device().cmd_fill_buffer(self.cmd, buffer.raw, offset, size, value) };
        Ok(())
    }

    /// Writes up to 64 KiB of data into a buffer (vkCmdUpdateBuffer). Offset and size must be
    /// multiples of 4, the data non-empty and within the buffer; anything else is refused with
    /// [`GpuError::BadUpload`] before it reaches the driver.
    pub fn update_buffer(&self, buffer: &Buffer, offset: u64, data: &[u8]) -> Result<()> {
        let size = data.len() as u64;
        if let Some(why) = transfer_range_problem(buffer, offset, size, true) {
            return Err(GpuError::BadUpload { name: buffer.name().into(), offset, size, why });
        }
        // SAFETY: recording outside rendering; offset and size were checked above (multiples of
        // 4, at most 64 KiB, inside the buffer), as vkCmdUpdateBuffer requires.
        unsafe { self.device().cmd_update_buffer(self.cmd, buffer.raw, offset, data) };
        Ok(())
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

    /// Copies `copies` from a staging buffer into `image`, which is in `from.0` before (its
    /// earlier use `from.1`) and in SHADER_READ_ONLY_OPTIMAL after, visible to every later read.
    pub(crate) fn copy_into_image(
        &self,
        staging: &Buffer,
        image: &Image,
        from: (vk::ImageLayout, (vk::PipelineStageFlags2, vk::AccessFlags2)),
        copies: &[vk::BufferImageCopy],
    ) {
        let copy = (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE);
        self.image_barrier(image, (from.0, vk::ImageLayout::TRANSFER_DST_OPTIMAL), from.1, copy);
        // SAFETY: the copies lie inside the image and the staging buffer (the callers'
        // contract: GpuHair::stage_update builds them from texels checked to lie in the slice of
        // a layout equal to the one the image was created with, through the image's depth, and
        // packs the staging data from them; create_image_with_data copies the whole image from
        // its tightly packed data), and the barrier above put the image in TRANSFER_DST_OPTIMAL.
        unsafe {
            self.device().cmd_copy_buffer_to_image(
                self.cmd,
                staging.raw,
                image.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                copies,
            );
        }
        self.image_barrier(
            image,
            (vk::ImageLayout::TRANSFER_DST_OPTIMAL, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
            copy,
            (vk::PipelineStageFlags2::ALL_COMMANDS, vk::AccessFlags2::SHADER_SAMPLED_READ),
        );
    }

    /// [`Self::copy_into_image`] for a sampled image between reads (SHADER_READ_ONLY before and
    /// after); nothing is recorded without copies.
    pub(crate) fn update_sampled_image(
        &self,
        staging: &Buffer,
        image: &Image,
        copies: &[vk::BufferImageCopy],
    ) {
        if copies.is_empty() {
            return;
        }
        let reads = (vk::PipelineStageFlags2::ALL_COMMANDS, vk::AccessFlags2::SHADER_SAMPLED_READ);
        self.copy_into_image(staging, image, (vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL, reads), copies);
    }

    /// Copies byte ranges between buffers, then makes them visible to later shader reads.
    pub(crate) fn copy_buffer_regions(&self, src: &Buffer, dst: &Buffer, regions: &[vk::BufferCopy]) {
        if regions.is_empty() {
            return;
        }
        let inside = |r: &vk::BufferCopy, size: u64, offset: u64| {
            offset.checked_add(r.size).is_some_and(|e| e <= size)
        };
        if !regions.iter().all(|r| inside(r, src.size(), r.src_offset) && inside(r, dst.size(), r.dst_offset))
        {
            log::error!(
                "copy_buffer_regions: a region lies outside {} or {}; nothing copied",
                src.name(),
                dst.name()
            );
            return;
        }
        let before = (vk::PipelineStageFlags2::ALL_COMMANDS, vk::AccessFlags2::SHADER_STORAGE_READ);
        let copy = (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE);
        self.memory_barrier(before, copy);
        // SAFETY: every region was checked to lie inside both buffers just above.
        unsafe { self.device().cmd_copy_buffer(self.cmd, src.raw, dst.raw, regions) };
        self.memory_barrier(
            copy,
            (vk::PipelineStageFlags2::ALL_COMMANDS, vk::AccessFlags2::SHADER_STORAGE_READ),
        );
    }

    pub fn copy_buffer(&self, src: &Buffer, dst: &Buffer, size: u64) {
        let region = vk::BufferCopy { src_offset: 0, dst_offset: 0, size };
        // SAFETY: recording; both buffers are live and at least `size` bytes.
        unsafe { self.device().cmd_copy_buffer(self.cmd, src.raw, dst.raw, &[region]) };
    }

    /// Copies a whole image in TRANSFER_SRC layout into a tightly packed buffer.
    pub fn copy_image_to_buffer(&self, src: &Image, dst: &Buffer) {
        self.copy_image_to_buffer_at(src, dst, 0);
    }

    /// Copies a whole image in TRANSFER_SRC layout into a tightly packed buffer from byte
    /// `offset` on (a multiple of the texel size).
    pub fn copy_image_to_buffer_at(&self, src: &Image, dst: &Buffer, offset: u64) {
        let region = vk::BufferImageCopy::default()
            .buffer_offset(offset)
            .image_subresource(src.layers())
            .image_extent(src.desc.extent);
        // SAFETY: recording; the image is in TRANSFER_SRC_OPTIMAL and the buffer large enough.
        unsafe {
            self.device().cmd_copy_image_to_buffer(
                self.cmd,
                src.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.raw,
                &[region],
            );
        }
    }
}

/// What vkCmdUpdateBuffer writes at most.
const UPDATE_BUFFER_MAX_BYTES: u64 = 65_536;

/// Why a fill or (`update`) an update may not write `size` bytes of `buffer` from byte
/// `offset`: the range must be non-empty, start and end on multiples of 4, lie inside the
/// buffer, and for an update hold at most [`UPDATE_BUFFER_MAX_BYTES`]. `None` when it may.
fn transfer_range_problem(buffer: &Buffer, offset: u64, size: u64, update: bool) -> Option<&'static str> {
    if size == 0 {
        Some("nothing to write")
    } else if !offset.is_multiple_of(4) || !size.is_multiple_of(4) {
        Some("offset and size must be multiples of 4")
    } else if update && size > UPDATE_BUFFER_MAX_BYTES {
        Some("more than 65536 bytes (use a staging copy)")
    } else if offset.checked_add(size).is_none_or(|end| end > buffer.size()) {
        Some("past the end of the buffer")
    } else {
        None
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

/// Owns the per-submission objects and frees them whatever happens.
struct Submission<'a> {
    ctx: &'a Context,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    query_pool: vk::QueryPool,
}

impl Drop for Submission<'_> {
    fn drop(&mut self) {
        let d = self.ctx.device();
        {
            let pool = self.ctx.shared.command_pool.lock().unwrap_or_else(|e| e.into_inner());
            // SAFETY: the fence was waited on (or never submitted), so nothing is in flight.
            unsafe {
                if self.fence != vk::Fence::null() {
                    d.destroy_fence(self.fence, None);
                }
                if self.query_pool != vk::QueryPool::null() {
                    d.destroy_query_pool(self.query_pool, None);
                }
                d.free_command_buffers(*pool, &[self.cmd]);
            }
        }
        // Resources dropped while this submission was recorded or in flight go now.
        self.ctx.shared.close_submission();
    }
}

impl Context {
    /// Records commands with `f`, submits them, waits, and returns `f`'s result with the
    /// per-pass GPU times. Synchronous, so resources may be dropped as soon as it returns; a
    /// buffer or image dropped inside `f` (after a command using it was recorded) is destroyed
    /// only once the submission has completed.
    pub fn submit<R>(
        &self,
        name: &str,
        f: impl FnOnce(&mut Recorder<'_>) -> Result<R>,
    ) -> Result<(R, FrameTimings)> {
        let device = self.device();
        let cmd = {
            let pool = self.shared.command_pool.lock().unwrap_or_else(|e| e.into_inner());
            let info = vk::CommandBufferAllocateInfo::default()
                .command_pool(*pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            // SAFETY: valid pool, externally synchronized by the mutex.
            unsafe { device.allocate_command_buffers(&info) }.call("vkAllocateCommandBuffers")?[0]
        };
        // From here until the Submission drops (after its fence, or on any error), resources
        // dropped by the caller are kept alive for the commands that may use them.
        self.shared.open_submission();
        let mut sub =
            Submission { ctx: self, cmd, fence: vk::Fence::null(), query_pool: vk::QueryPool::null() };
        self.set_name(cmd, name);
        if self.capabilities().timestamp_period_ns.is_some() {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(POOL_QUERIES);
            // SAFETY: valid device.
            sub.query_pool = unsafe { device.create_query_pool(&info, None) }.call("vkCreateQueryPool")?;
            // SAFETY: host query reset is enabled at device creation.
            unsafe { device.reset_query_pool(sub.query_pool, 0, POOL_QUERIES) };
        }
        let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: freshly allocated command buffer.
        unsafe { device.begin_command_buffer(cmd, &begin) }.call("vkBeginCommandBuffer")?;
        let mut rec = Recorder {
            ctx: self,
            cmd,
            query_pool: sub.query_pool,
            scopes: Vec::new(),
            depth: 0,
            next_query: 0,
            rendered: std::cell::Cell::new(false),
        };
        let result = rec.pass(name, f);
        // Make every write visible to the host before the fence signals.
        rec.memory_barrier(
            (vk::PipelineStageFlags2::ALL_COMMANDS, vk::AccessFlags2::MEMORY_WRITE),
            (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
        );
        let scopes = std::mem::take(&mut rec.scopes);
        // SAFETY: recording state.
        unsafe { device.end_command_buffer(cmd) }.call("vkEndCommandBuffer")?;
        let value = result?;

        // SAFETY: valid device.
        sub.fence =
            unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }.call("vkCreateFence")?;
        let cmds = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&cmds);
        let start = Instant::now();
        {
            let queue = self.queue();
            // SAFETY: the queue is externally synchronized by its mutex; the command buffer is
            // executable.
            unsafe { device.queue_submit(*queue, &[submit], sub.fence) }.call("vkQueueSubmit")?;
        }
        // SAFETY: the fence belongs to this submission.
        unsafe { device.wait_for_fences(&[sub.fence], true, u64::MAX) }.call("vkWaitForFences")?;
        let cpu_wait_ms = start.elapsed().as_secs_f64() * 1e3;

        let mut timings = FrameTimings { passes: Vec::new(), cpu_wait_ms };
        let period = self.capabilities().timestamp_period_ns;
        let used = scopes.iter().filter_map(|s| s.end).max().map_or(0, |m| m + 1);
        let mut stamps = vec![0u64; used as usize];
        let have_stamps = used > 0
            // SAFETY: every query below `used` was written in the submission we waited for.
            && unsafe {
                device.get_query_pool_results(sub.query_pool, 0, &mut stamps, vk::QueryResultFlags::TYPE_64)
            }
            .is_ok();
        for s in scopes {
            let gpu_ms = match (have_stamps, s.end, period) {
                (true, Some(end), Some(p)) => {
                    let ticks = stamps[end as usize].saturating_sub(stamps[s.begin as usize]);
                    Some(ticks as f64 * f64::from(p) * 1e-6)
                }
                _ => None,
            };
            timings.passes.push(PassTiming { name: s.name, depth: s.depth, gpu_ms });
        }
        Ok((value, timings))
    }

    /// A host-visible transfer source holding `data`.
    pub(crate) fn upload_staging(&self, name: &str, data: &[u8]) -> Result<Buffer> {
        let mut staging = Buffer::new(
            self,
            &format!("{name} (upload)"),
            BufferDesc {
                size: data.len().max(1) as u64,
                usage: vk::BufferUsageFlags::TRANSFER_SRC,
                location: MemoryLocation::CpuToGpu,
            },
        )?;
        if let Some(m) = staging.mapped_mut() {
            m[..data.len()].copy_from_slice(data);
        }
        Ok(staging)
    }

    /// A host-visible transfer destination of `size` bytes for reading `name` back.
    fn readback_staging(&self, name: &str, size: u64) -> Result<Buffer> {
        Buffer::new(
            self,
            &format!("{name} (readback)"),
            BufferDesc {
                size: size.max(1),
                usage: vk::BufferUsageFlags::TRANSFER_DST,
                location: MemoryLocation::GpuToCpu,
            },
        )
    }

    /// An image filled with tightly packed `data` and left in SHADER_READ_ONLY_OPTIMAL layout.
    pub fn create_image_with_data(&self, name: &str, desc: ImageDesc, data: &[u8]) -> Result<Image> {
        let image = Image::new(
            self,
            name,
            desc.with_usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::SAMPLED),
        )?;
        let whole =
            vk::BufferImageCopy::default().image_subresource(image.layers()).image_extent(image.desc.extent);
        self.copy_to_sampled_image(
            &format!("upload {name}"),
            &image,
            (vk::ImageLayout::UNDEFINED, (vk::PipelineStageFlags2::TOP_OF_PIPE, vk::AccessFlags2::NONE)),
            data,
            &[whole],
        )?;
        Ok(image)
    }

    /// Stages `data`, then in one submission moves `image` from `from` (its layout and the
    /// scope of its last use) to TRANSFER_DST_OPTIMAL, records `copies` from the staging
    /// buffer, and leaves it SHADER_READ_ONLY_OPTIMAL for any later sampling. Every copy must lie
    /// inside the image and inside `data` (the callers' contract).
    fn copy_to_sampled_image(
        &self,
        label: &str,
        image: &Image,
        from: (vk::ImageLayout, (vk::PipelineStageFlags2, vk::AccessFlags2)),
        data: &[u8],
        copies: &[vk::BufferImageCopy],
    ) -> Result<()> {
        let staging = self.upload_staging(image.name(), data)?;
        self.submit(label, |rec| {
            rec.copy_into_image(&staging, image, from, copies);
            Ok(())
        })?;
        Ok(())
    }

    /// Overwrites `data.len()` bytes of a buffer at `offset` (directly where it is mapped, else
    /// through a staging copy); past its end is refused.
    pub fn write_buffer(&self, buffer: &mut Buffer, offset: u64, data: &[u8]) -> Result<()> {
        let size = data.len() as u64;
        if offset.checked_add(size).is_none_or(|end| end > buffer.size()) {
            return Err(GpuError::BadUpload {
                name: buffer.name().into(),
                offset,
                size,
                why: "past the end of the buffer",
            });
        }
        if size == 0 {
            return Ok(());
        }
        if let Some(mapped) = buffer.mapped_mut() {
            mapped[offset as usize..(offset + size) as usize].copy_from_slice(data);
            return Ok(());
        }
        let staging = self.upload_staging(buffer.name(), data)?;
        self.submit(&format!("update {}", buffer.name()), |rec| {
            let region = vk::BufferCopy { src_offset: 0, dst_offset: offset, size };
            // SAFETY: recording; the staging buffer holds `size` bytes and the destination
            // range was checked to lie inside the buffer.
            unsafe { self.device().cmd_copy_buffer(rec.cmd, staging.raw, buffer.raw, &[region]) };
            Ok(())
        })?;
        Ok(())
    }

    /// A device-local buffer filled with `data` (mapped directly where the memory is
    /// host-visible, as on lavapipe; through a staging copy elsewhere).
    pub fn create_buffer_with_data(&self, name: &str, desc: BufferDesc, data: &[u8]) -> Result<Buffer> {
        let mut buffer = Buffer::new(self, name, desc)?;
        self.write_buffer(&mut buffer, 0, data)?;
        Ok(buffer)
    }

    /// Reads the first `len` bytes of a buffer back (after all submitted work, since
    /// submissions are synchronous).
    pub fn read_buffer(&self, buffer: &Buffer, len: u64) -> Result<Vec<u8>> {
        if len > buffer.size() {
            return Err(GpuError::OutOfRange {
                name: buffer.name().into(),
                size: buffer.size(),
                requested: len,
            });
        }
        if let Some(mapped) = buffer.mapped() {
            return Ok(mapped[..len as usize].to_vec());
        }
        let staging = self.readback_staging(buffer.name(), len)?;
        self.submit(&format!("read back {}", buffer.name()), |rec| {
            rec.copy_buffer(buffer, &staging, len);
            Ok(())
        })?;
        Ok(staging.mapped().map(|m| m[..len as usize].to_vec()).unwrap_or_default())
    }

    /// Reads a whole image (in TRANSFER_SRC_OPTIMAL layout) back as tightly packed texels.
    pub fn read_image(&self, image: &Image, bytes_per_texel: u64) -> Result<Vec<u8>> {
        let e = image.desc.extent;
        let len = u64::from(e.width) * u64::from(e.height) * u64::from(e.depth) * bytes_per_texel;
        let staging = self.readback_staging(image.name(), len)?;
        self.submit(&format!("read back {}", image.name()), |rec| {
            rec.copy_image_to_buffer(image, &staging);
            Ok(())
        })?;
        Ok(staging.mapped().map(|m| m.to_vec()).unwrap_or_default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pass(name: &str, depth: u32, gpu_ms: Option<f64>) -> PassTiming {
        PassTiming { name: name.into(), depth, gpu_ms }
    }

    fn frame(passes: Vec<PassTiming>, wall: f64) -> FrameTimings {
        FrameTimings { passes, cpu_wait_ms: wall }
    }

    #[test]
    fn quantiles_interpolate_between_ranks() {
        assert_eq!(quantile(&[], 0.5), 0.0);
        assert_eq!(quantile(&[3.0], 0.25), 3.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.5), 3.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.25), 2.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), 2.5);
        assert_eq!(quantile(&[1.0, 2.0], 1.5), 2.0);
    }

    #[test]
    fn passes_are_matched_by_name_depth_and_occurrence() {
        // A crowd frame: one pass name per character, nested under the frame; a shadow pass
        // only in the first frame; an untimed pass.
        let frames: Vec<FrameTimings> = [(10.0, 1.0, 3.0), (30.0, 2.0, 5.0), (20.0, 3.0, 4.0)]
            .into_iter()
            .enumerate()
            .map(|(i, (total, a, b))| {
                let mut passes = vec![pass("scene frame", 0, Some(total))];
                if i == 0 {
                    passes.push(pass("shadow map", 1, Some(7.0)));
                }
                passes.push(pass("raster", 1, Some(a)));
                passes.push(pass("raster", 1, Some(b)));
                passes.push(pass("untimed", 1, None));
                frame(passes, total + 1.0)
            })
            .collect();
        let s = TimingSummary::of(&frames);
        assert_eq!(s.frames, 3);
        let names: Vec<(&str, u32, usize)> =
            s.passes.iter().map(|p| (p.name.as_str(), p.depth, p.frames)).collect();
        assert_eq!(names, [("scene frame", 0, 3), ("shadow map", 1, 1), ("raster", 1, 3), ("raster", 1, 3)]);
        assert_eq!(s.passes[0].median_ms, 20.0);
        assert_eq!((s.passes[0].q1_ms, s.passes[0].q3_ms), (15.0, 25.0));
        // The first character's raster pass is not mixed with the second's.
        assert_eq!((s.passes[2].median_ms, s.passes[3].median_ms), (2.0, 4.0));
        assert_eq!(s.wall_median_ms, 21.0);
        let text = s.to_string();
        assert!(text.contains("over 3 frames") && text.contains("7.000–7.000, 1 frame)"), "{text}");
    }

    #[test]
    fn no_frames_summarize_to_nothing() {
        let s = TimingSummary::of(&[]);
        assert_eq!((s.frames, s.passes.len(), s.wall_median_ms), (0, 0, 0.0));
    }
}
