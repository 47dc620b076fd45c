//! Transfers inside a command buffer: fills, small updates, copies between buffers and images,
//! each range checked before it is recorded.

use super::*;

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

impl Recorder<'_> {
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
