//! The frame's render target: linear RGBA16F colour (alpha = coverage) and D32 depth, optionally
//! multisampled and resolved, read back as a [`LinearFrame`]. PNG output encodes it to sRGB;
//! EXR output keeps it linear.

use gen_gpu::{
    Attachments, Binding, Buffer, BufferDesc, Context, GraphicsPipelineDesc, GraphicsStages, Image,
    ImageDesc, MemoryLocation, Pipeline, Recorder, vk,
};

use crate::RgbaImage;
use crate::graph::TransientPool;

/// Colour format of the scene passes: linear, enough range for highlights, no banding.
pub const SCENE_COLOR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;

/// A pass that blends premultiplied colour over the (single-sample) scene target and writes the
/// hair's depth from its fragment stage (`gl_FragDepth`; the depth test keeps a nearer
/// occluder's), reading storage buffers at `bindings`: the OIT resolve and the compute
/// rasterizer's resolve.
pub(crate) fn composite_pipeline(
    ctx: &Context,
    name: &str,
    vertex: &'static shader_build::ShaderSpirv,
    fragment: &'static shader_build::ShaderSpirv,
    bindings: &[u32],
    push_constant_size: u32,
) -> gen_gpu::Result<Pipeline> {
    Pipeline::graphics(
        ctx,
        &GraphicsPipelineDesc {
            name,
            stages: GraphicsStages::Vertex(vertex),
            fragment,
            bindings: &Binding::storage_buffers(bindings, vk::ShaderStageFlags::FRAGMENT),
            push_constant_size,
            specialization: &[],
            color_format: SCENE_COLOR_FORMAT,
            depth_format: Some(gen_gpu::DEPTH_FORMAT),
            blend: gen_gpu::Blend::Over,
            depth_write: true,
            color_write: true,
            samples: 1,
            depth_compare: vk::CompareOp::LESS,
        },
    )
}

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
/// and their readback buffers. Layouts and barriers are the frame graph's: the target only
/// begins rendering and copies out.
#[derive(Debug)]
pub struct SceneTarget {
    pub color: Image,
    pub depth: Image,
    /// Single-sample resolves of a multisampled target.
    pub resolve: Option<(Image, Image)>,
    pub color_readback: Buffer,
    pub depth_readback: Buffer,
    width: u32,
    height: u32,
}

impl SceneTarget {
    /// Takes the target's images and buffers from `pool` (created the first time).
    pub fn new(
        ctx: &Context,
        pool: &mut TransientPool,
        width: u32,
        height: u32,
        samples: u32,
    ) -> gen_gpu::Result<Self> {
        let color_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let depth_usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let samples = samples.max(1);
        let color = pool.image(
            ctx,
            "scene colour",
            ImageDesc::d2(width, height, SCENE_COLOR_FORMAT, color_usage).with_samples(samples),
        )?;
        let depth = pool.image(
            ctx,
            "scene depth",
            ImageDesc::d2(width, height, gen_gpu::DEPTH_FORMAT, depth_usage).with_samples(samples),
        )?;
        let resolve = if samples > 1 {
            Some((
                pool.image(
                    ctx,
                    "scene colour (resolved)",
                    ImageDesc::d2(width, height, SCENE_COLOR_FORMAT, color_usage),
                )?,
                pool.image(
                    ctx,
                    "scene depth (resolved)",
                    ImageDesc::d2(width, height, gen_gpu::DEPTH_FORMAT, depth_usage),
                )?,
            ))
        } else {
            None
        };
        let pixels = u64::from(width) * u64::from(height);
        let mut readback = |name, bytes| {
            pool.buffer(
                ctx,
                name,
                BufferDesc {
                    size: pixels * bytes,
                    // Storage too: the compute rasterizer's resolve writes the frame into them.
                    usage: vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::STORAGE_BUFFER,
                    location: MemoryLocation::GpuToCpu,
                },
            )
        };
        let color_readback = readback("scene colour readback", 8)?;
        let depth_readback = readback("scene depth readback", 4)?;
        Ok(Self { color, depth, resolve, color_readback, depth_readback, width, height })
    }

    /// Returns everything to `pool` for the next frame (after the frame's submissions).
    pub fn give_back(self, pool: &mut TransientPool) {
        pool.give_back_image(self.color);
        pool.give_back_image(self.depth);
        if let Some((c, d)) = self.resolve {
            pool.give_back_image(c);
            pool.give_back_image(d);
        }
        pool.give_back_buffer(self.color_readback);
        pool.give_back_buffer(self.depth_readback);
    }

    /// Begins rendering into colour and depth (and their resolves); `clear` clears them to the
    /// background (alpha 0, so alpha ends up as the coverage) and depth to 1, `None` keeps them.
    pub fn begin_rendering(&self, rec: &Recorder<'_>, clear: Option<[f32; 3]>) {
        rec.begin_rendering_to(&Attachments {
            color: &self.color,
            color_resolve: self.resolve.as_ref().map(|r| &r.0),
            clear: clear.map(|[r, g, b]| [r, g, b, 0.0]),
            depth: Some(&self.depth),
            depth_resolve: self.resolve.as_ref().map(|r| &r.1),
            clear_depth: clear.is_some(),
        });
    }

    /// The single-sample colour and depth images the frame is read from.
    pub fn output_images(&self) -> (&Image, &Image) {
        match &self.resolve {
            Some((c, d)) => (c, d),
            None => (&self.color, &self.depth),
        }
    }

    /// Copies the (resolved) colour and depth to the readback buffers; both images must be in
    /// TRANSFER_SRC layout (the graph's `copy out` pass declares it).
    pub fn copy_out(&self, rec: &Recorder<'_>) {
        let (color, depth) = self.output_images();
        rec.copy_image_to_buffer(color, &self.color_readback);
        rec.copy_image_to_buffer(depth, &self.depth_readback);
    }

    /// The frame in the readback buffers (after the submission): copied by [`Self::copy_out`],
    /// or with `only` = `Some((rect, background))` written by the compute rasterizer's resolve
    /// in the pixels of `rect` alone (x0, y0, x1, y1; exclusive ends), the others being the
    /// background (alpha 0, depth 1) as a cleared image would hold them.
    pub fn read(&self, ctx: &Context, only: Option<([u32; 4], [f32; 3])>) -> gen_gpu::Result<LinearFrame> {
        let color = ctx.read_buffer(&self.color_readback, self.color_readback.size())?;
        let depth = ctx.read_buffer(&self.depth_readback, self.depth_readback.size())?;
        // Each pixel once: from the buffers where they hold it, else the background as the
        // attachment's clear stores it (the colour in half floats).
        let written = |i: usize| {
            only.is_none_or(|([x0, y0, x1, y1], _)| {
                let (x, y) = (i as u32 % self.width, i as u32 / self.width);
                (x0..x1).contains(&x) && (y0..y1).contains(&y)
            })
        };
        let [r, g, b] =
            only.map_or([0.0; 3], |(_, background)| background.map(|c| half::f16::from_f32(c).to_f32()));
        let rgba = color
            .chunks_exact(8)
            .enumerate()
            .flat_map(|(i, texel)| {
                if written(i) {
                    [0, 2, 4, 6].map(|c| half::f16::from_le_bytes([texel[c], texel[c + 1]]).to_f32())
                } else {
                    [r, g, b, 0.0]
                }
            })
            .collect();
        let depth = depth
            .chunks_exact(4)
            .enumerate()
            .map(|(i, d)| if written(i) { f32::from_le_bytes([d[0], d[1], d[2], d[3]]) } else { 1.0 })
            .collect();
        Ok(LinearFrame { width: self.width, height: self.height, rgba, depth })
    }
}
