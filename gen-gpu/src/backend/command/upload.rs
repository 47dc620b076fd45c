//! Moving data between the host and the device outside a frame: staging uploads and readbacks of
//! buffers and images.

use super::*;

impl Context {
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
