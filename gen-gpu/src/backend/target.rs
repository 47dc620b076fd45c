//! Render targets and what is read back from them: the colour + depth target of the default
//! formats, and 8-bit RGBA images.

use ash::vk;

use super::command::Recorder;
use super::context::Context;
use super::resource::{Buffer, BufferDesc, Image, ImageDesc};
use crate::{MemoryLocation, Result};

/// Colour and depth formats of [`RenderTarget`] (and the generator's draws by default).
pub const COLOR_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// An 8-bit RGBA image read back from the GPU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbaImage {
    pub width: u32,
    pub height: u32,
    /// Row-major, 4 bytes per pixel, no padding.
    pub pixels: Vec<u8>,
}

/// A colour + depth target of the generator's formats with a readback buffer.
#[derive(Debug)]
pub struct RenderTarget {
    pub color: Image,
    pub depth: Image,
    readback: Buffer,
}

impl RenderTarget {
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<Self> {
        Ok(Self {
            color: Image::new(
                ctx,
                "render target colour",
                ImageDesc::d2(
                    width,
                    height,
                    COLOR_FORMAT,
                    vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
                ),
            )?,
            depth: Image::new(
                ctx,
                "render target depth",
                ImageDesc::d2(width, height, DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT),
            )?,
            readback: Buffer::new(
                ctx,
                "render target readback",
                BufferDesc {
                    size: u64::from(width) * u64::from(height) * 4,
                    usage: vk::BufferUsageFlags::TRANSFER_DST,
                    location: MemoryLocation::GpuToCpu,
                },
            )?,
        })
    }

    /// Transitions both images for rendering and begins rendering with a dark clear colour.
    pub fn begin(&self, rec: &Recorder<'_>) {
        let top = (vk::PipelineStageFlags2::TOP_OF_PIPE, vk::AccessFlags2::NONE);
        rec.image_barrier(
            &self.color,
            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
            top,
            COLOR_ATTACHMENT,
        );
        rec.image_barrier(
            &self.depth,
            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL),
            top,
            DEPTH_ATTACHMENT,
        );
        rec.begin_rendering(&self.color, [0.02, 0.02, 0.03, 1.0], Some(&self.depth));
    }

    /// After rendering ended: copies the colour image to the readback buffer.
    pub fn copy_out(&self, rec: &Recorder<'_>) {
        rec.image_barrier(
            &self.color,
            (vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
            COLOR_ATTACHMENT,
            (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_READ),
        );
        rec.copy_image_to_buffer(&self.color, &self.readback);
    }

    /// The image copied by [`Self::copy_out`] (after the submission).
    pub fn read(&self, ctx: &Context) -> Result<RgbaImage> {
        let e = self.color.desc.extent;
        Ok(RgbaImage {
            width: e.width,
            height: e.height,
            pixels: ctx.read_buffer(&self.readback, self.readback.size())?,
        })
    }
}

const COLOR_ATTACHMENT: (vk::PipelineStageFlags2, vk::AccessFlags2) =
    (vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT, vk::AccessFlags2::COLOR_ATTACHMENT_WRITE);
const DEPTH_ATTACHMENT: (vk::PipelineStageFlags2, vk::AccessFlags2) = (
    vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS.as_raw()
            | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS.as_raw(),
    ),
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
            | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ.as_raw(),
    ),
);
