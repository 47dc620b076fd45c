//! The frame's render target: linear RGBA16F colour (alpha = coverage) and D32 depth, optionally
//! multisampled and resolved, read back as a [`LinearFrame`]. PNG output encodes it to sRGB;
//! EXR output keeps it linear.

use gen_gpu::{Attachments, Buffer, BufferDesc, Context, Image, ImageDesc, MemoryLocation, Recorder, vk};

use crate::RgbaImage;

/// Colour format of the scene passes: linear, enough range for highlights, no banding.
pub const SCENE_COLOR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;

/// A frame read back: linear premultiplied RGBA over the background (alpha is the coverage of
/// hair and occluders) and the depth buffer (Vulkan NDC depth in [0, 1], 1 = nothing).
#[derive(Clone, Debug, PartialEq)]
pub struct LinearFrame {
    pub width: u32,
    pub height: u32,
    /// RGBA per pixel, rows top to bottom.
    pub rgba: Vec<f32>,
    pub depth: Vec<f32>,
}

/// sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
    // The clamp catches the curve's rounding just above 1.
    if x <= 0.003_130_8 { 12.92 * x } else { (1.055 * x.powf(1.0 / 2.4) - 0.055).min(1.0) }
}

impl LinearFrame {
    /// The frame as 8-bit sRGB with opaque alpha (the colour is already composited over the
    /// scene's background).
    pub fn to_srgb8(&self) -> RgbaImage {
        let mut pixels = Vec::with_capacity(self.rgba.len());
        for p in self.rgba.chunks_exact(4) {
            for &c in &p[..3] {
                pixels.push((linear_to_srgb(c) * 255.0 + 0.5) as u8);
            }
            pixels.push(255);
        }
        RgbaImage { width: self.width, height: self.height, pixels }
    }

    /// View-space distance per pixel of a perspective camera with planes `near`, `far`
    /// (`f32::INFINITY` where nothing was drawn).
    pub fn linear_depth(&self, near: f32, far: f32) -> Vec<f32> {
        self.depth
            .iter()
            .map(|&z| if z >= 1.0 { f32::INFINITY } else { near * far / (far - z * (far - near)) })
            .collect()
    }
}

/// Colour + depth attachments (multisampled with single-sample resolves when `samples > 1`)
/// and their readback buffers.
#[derive(Debug)]
pub struct SceneTarget {
    color: Image,
    depth: Image,
    /// Single-sample resolves of a multisampled target.
    resolve: Option<(Image, Image)>,
    color_readback: Buffer,
    depth_readback: Buffer,
    width: u32,
    height: u32,
}

const COLOR: (vk::PipelineStageFlags2, vk::AccessFlags2) = (
    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw() | vk::AccessFlags2::COLOR_ATTACHMENT_READ.as_raw(),
    ),
);
const DEPTH: (vk::PipelineStageFlags2, vk::AccessFlags2) = (
    vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS.as_raw()
            | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS.as_raw()
            // Depth resolves happen in the colour-attachment-output stage.
            | vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT.as_raw(),
    ),
    vk::AccessFlags2::from_raw(
        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
            | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ.as_raw(),
    ),
);
const COPY_READ: (vk::PipelineStageFlags2, vk::AccessFlags2) =
    (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_READ);
const TOP: (vk::PipelineStageFlags2, vk::AccessFlags2) =
    (vk::PipelineStageFlags2::TOP_OF_PIPE, vk::AccessFlags2::NONE);

impl SceneTarget {
    pub fn new(ctx: &Context, width: u32, height: u32, samples: u32) -> gen_gpu::Result<Self> {
        let color_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let depth_usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let samples = samples.max(1);
        let color = Image::new(
            ctx,
            "scene colour",
            ImageDesc::d2(width, height, SCENE_COLOR_FORMAT, color_usage).with_samples(samples),
        )?;
        let depth = Image::new(
            ctx,
            "scene depth",
            ImageDesc::d2(width, height, gen_gpu::DEPTH_FORMAT, depth_usage).with_samples(samples),
        )?;
        let resolve = if samples > 1 {
            Some((
                Image::new(
                    ctx,
                    "scene colour (resolved)",
                    ImageDesc::d2(width, height, SCENE_COLOR_FORMAT, color_usage),
                )?,
                Image::new(
                    ctx,
                    "scene depth (resolved)",
                    ImageDesc::d2(width, height, gen_gpu::DEPTH_FORMAT, depth_usage),
                )?,
            ))
        } else {
            None
        };
        let pixels = u64::from(width) * u64::from(height);
        let readback = |name, bytes| {
            Buffer::new(
                ctx,
                name,
                BufferDesc {
                    size: pixels * bytes,
                    usage: vk::BufferUsageFlags::TRANSFER_DST,
                    location: MemoryLocation::GpuToCpu,
                },
            )
        };
        Ok(Self {
            color,
            depth,
            resolve,
            color_readback: readback("scene colour readback", 8)?,
            depth_readback: readback("scene depth readback", 4)?,
            width,
            height,
        })
    }

    fn images(&self) -> impl Iterator<Item = (&Image, bool)> {
        let resolved = self.resolve.iter().flat_map(|(c, d)| [(c, false), (d, true)]);
        [(&self.color, false), (&self.depth, true)].into_iter().chain(resolved)
    }

    /// Moves every image to its attachment layout and begins rendering cleared to `background`
    /// (alpha 0, so alpha ends up as the coverage).
    pub fn begin(&self, rec: &Recorder<'_>, background: [f32; 3]) {
        for (image, is_depth) in self.images() {
            let (layout, access) = if is_depth {
                (vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL, DEPTH)
            } else {
                (vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, COLOR)
            };
            rec.image_barrier(image, (vk::ImageLayout::UNDEFINED, layout), TOP, access);
        }
        let [r, g, b] = background;
        rec.begin_rendering_to(&Attachments {
            color: &self.color,
            color_resolve: self.resolve.as_ref().map(|r| &r.0),
            clear: Some([r, g, b, 0.0]),
            depth: Some(&self.depth),
            depth_resolve: self.resolve.as_ref().map(|r| &r.1),
            clear_depth: true,
        });
    }

    /// Begins rendering again over what is there (the OIT resolve, later batches of a crowd).
    pub fn begin_load(&self, rec: &Recorder<'_>) {
        rec.begin_rendering_to(&Attachments {
            color: &self.color,
            color_resolve: self.resolve.as_ref().map(|r| &r.0),
            clear: None,
            depth: Some(&self.depth),
            depth_resolve: self.resolve.as_ref().map(|r| &r.1),
            clear_depth: false,
        });
    }

    /// After rendering ended: copies the (resolved) colour and depth to the readback buffers.
    pub fn copy_out(&self, rec: &Recorder<'_>) {
        let (color, depth) = match &self.resolve {
            Some((c, d)) => (c, d),
            None => (&self.color, &self.depth),
        };
        rec.image_barrier(
            color,
            (vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
            COLOR,
            COPY_READ,
        );
        rec.image_barrier(
            depth,
            (vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
            DEPTH,
            COPY_READ,
        );
        rec.copy_image_to_buffer(color, &self.color_readback);
        rec.copy_image_to_buffer(depth, &self.depth_readback);
    }

    /// The frame copied by [`Self::copy_out`] (after the submission).
    pub fn read(&self, ctx: &Context) -> gen_gpu::Result<LinearFrame> {
        let color = ctx.read_buffer(&self.color_readback, self.color_readback.size())?;
        let depth = ctx.read_buffer(&self.depth_readback, self.depth_readback.size())?;
        let rgba = color.chunks_exact(2).map(|h| half::f16::from_le_bytes([h[0], h[1]]).to_f32()).collect();
        let depth = depth.chunks_exact(4).map(|d| f32::from_le_bytes([d[0], d[1], d[2], d[3]])).collect();
        Ok(LinearFrame { width: self.width, height: self.height, rgba, depth })
    }
}
