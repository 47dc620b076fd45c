//! Self-shadowing by deep opacity maps (Yuksel & Keyser 2008) for the first directional light:
//! the hair is generated again in the light's orthographic view (orthographic LOD: the view
//! height stands in for d·tan(θ/2)), a depth pass keeps the nearest hair per texel, an opacity
//! pass accumulates opacity into three layers behind it, and the shading looks the result up.
//! A static scene's maps are computed once and cached.

use gen_gpu::{
    Blend, Buffer, BufferDesc, Context, DrawExtras, FragmentStage, FrameInputs, FrameTimings, GenerationPath,
    Generator, GeneratorOptions, GpuHair, Image, ImageDesc, Recorder, StoredStrands, vk,
};
use glam::{Mat4, Vec3};
use hairmesh::reference::{LodParams, Projection, ViewParams};

use crate::frame::shaders;

/// The maps the shading reads (bindings 15 and 16).
#[derive(Debug)]
pub struct ShadowMaps {
    /// Nearest hair depth per texel (f32).
    pub depth: Buffer,
    /// Cumulative opacity at the end of layers 1–3 per texel (vec4).
    pub opacity: Buffer,
    /// World space → light clip space.
    pub light_view_proj: Mat4,
    pub size: u32,
    /// Layer ends in light depth units.
    pub layer_ends: [f32; 3],
    pub timings: FrameTimings,
}

/// The two generators of the shadow passes.
pub struct ShadowPipelines {
    depth: Generator,
    opacity: Generator,
}

impl std::fmt::Debug for ShadowPipelines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShadowPipelines").finish()
    }
}

const OPACITY_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

impl ShadowPipelines {
    pub fn new(ctx: &Context) -> gen_gpu::Result<Self> {
        let depth = Generator::with_options(
            ctx,
            GeneratorOptions {
                fragment: Some(FragmentStage {
                    shader: &shaders::SHADOW_DEPTH_FRAG,
                    push_constant_bytes: 0,
                    blend: Blend::Replace,
                    depth_write: true,
                    color_write: false,
                    extra_bindings: &[],
                }),
                ..GeneratorOptions::default()
            },
        )?;
        let opacity = Generator::with_options(
            ctx,
            GeneratorOptions {
                fragment: Some(FragmentStage {
                    shader: &shaders::SHADOW_OPACITY_FRAG,
                    push_constant_bytes: 16,
                    blend: Blend::Additive,
                    depth_write: false,
                    color_write: true,
                    extra_bindings: &[15],
                }),
                color_format: Some(OPACITY_FORMAT),
                ..GeneratorOptions::default()
            },
        )?;
        Ok(Self { depth, opacity })
    }
}

/// An orthographic light looking along `-toward_light` at a box `(lo, hi)`: world → clip, and
/// the depth range in world units.
pub fn light_view_proj(toward_light: Vec3, (lo, hi): (Vec3, Vec3)) -> (Mat4, f32) {
    let centre = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-6);
    let dir = toward_light.try_normalize().unwrap_or(Vec3::Y);
    let up = if dir.y.abs() > 0.95 { Vec3::Z } else { Vec3::Y };
    let view = Mat4::look_at_rh(centre + dir * (radius * 2.0), centre, up);
    let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, radius * 0.5, radius * 3.5);
    (proj * view, radius * 3.0)
}

/// What the shadow passes draw: generated characters `(hair, transform)` and stored ones.
#[derive(Debug)]
pub struct ShadowCasters<'a> {
    pub hairs: &'a [GpuHair],
    pub generated: &'a [(usize, Mat4)],
    pub stored: &'a [StoredStrands],
    pub stored_characters: &'a [(usize, Mat4)],
}

fn light_inputs(
    light: Mat4,
    transform: Mat4,
    toward_light: Vec3,
    range: f32,
    size: u32,
    lod: LodParams,
) -> FrameInputs {
    let scale = transform.x_axis.truncate().length().max(1e-6);
    let object_dir = transform.inverse().transform_vector3(toward_light).normalize_or_zero();
    FrameInputs {
        view_proj: light * transform,
        view: ViewParams {
            // Orthographic: the strip faces this direction; LOD uses the view height.
            eye: object_dir.as_dvec3(),
            vertical_resolution: f64::from(size),
            projection: Projection::Orthographic { height: f64::from(range * 2.0 / 3.0 / scale) },
        },
        lod,
        viewport: [size, size],
        cull: true,
    }
}

/// Shadow map resolution, layer ends and the LOD of the light's view.
#[derive(Clone, Copy, Debug)]
pub struct ShadowSettings {
    pub size: u32,
    /// Ends of the three opacity layers behind the nearest hair, as fractions of the light
    /// box's radius.
    pub layer_fractions: [f32; 3],
    pub lod: LodParams,
}

/// Renders the deep opacity maps of the light `toward_light` over the world box `bounds`.
pub fn render_shadow_maps(
    ctx: &Context,
    pipes: &ShadowPipelines,
    casters: &ShadowCasters<'_>,
    toward_light: Vec3,
    bounds: (Vec3, Vec3),
    settings: ShadowSettings,
) -> gen_gpu::Result<ShadowMaps> {
    let ShadowSettings { size, layer_fractions, lod } = settings;
    let (light, range) = light_view_proj(toward_light, bounds);
    let inputs: Vec<FrameInputs> = casters
        .generated
        .iter()
        .map(|(_, m)| light_inputs(light, *m, toward_light, range, size, lod))
        .collect();
    let frames = casters
        .generated
        .iter()
        .zip(&inputs)
        .map(|((h, _), i)| pipes.depth.prepare(ctx, &casters.hairs[*h], i))
        .collect::<gen_gpu::Result<Vec<_>>>()?;
    let stored_params = casters
        .stored_characters
        .iter()
        .map(|(s, m)| {
            let i = light_inputs(light, *m, toward_light, range, size, lod);
            pipes.depth.stored_params(ctx, &casters.stored[*s], &i)
        })
        .collect::<gen_gpu::Result<Vec<_>>>()?;
    let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
    let dummy =
        Image::new(ctx, "shadow depth pass colour", ImageDesc::d2(size, size, gen_gpu::COLOR_FORMAT, usage))?;
    let opacity_image = Image::new(ctx, "shadow opacity", ImageDesc::d2(size, size, OPACITY_FORMAT, usage))?;
    let depth_image = Image::new(
        ctx,
        "shadow depth",
        ImageDesc::d2(
            size,
            size,
            gen_gpu::DEPTH_FORMAT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
        ),
    )?;
    let texels = u64::from(size) * u64::from(size);
    let depth = Buffer::new(ctx, "shadow depth map", BufferDesc::storage(texels * 4))?;
    let opacity = Buffer::new(ctx, "shadow opacity map", BufferDesc::storage(texels * 16))?;
    let layer_ends = layer_fractions.map(|f| f.max(1e-6) / 3.0);
    let layer_constants = [layer_ends[0], layer_ends[1], layer_ends[2], size as f32];

    let top = (vk::PipelineStageFlags2::TOP_OF_PIPE, vk::AccessFlags2::NONE);
    let color_out =
        (vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT, vk::AccessFlags2::COLOR_ATTACHMENT_WRITE);
    let depth_out = (
        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ,
    );
    let copy_read = (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_READ);
    let draw =
        |rec: &mut Recorder<'_>, generator: &Generator, extras: DrawExtras<'_>| -> gen_gpu::Result<()> {
            for ((h, _), frame) in casters.generated.iter().zip(&frames) {
                generator.record_draw_with(
                    rec,
                    &casters.hairs[*h],
                    frame,
                    GenerationPath::Compute,
                    false,
                    extras,
                )?;
            }
            for ((s, _), params) in casters.stored_characters.iter().zip(&stored_params) {
                generator.record_draw_stored(rec, &casters.stored[*s], params, extras);
            }
            Ok(())
        };
    let ((), timings) = ctx.submit("shadow maps", |rec| {
        rec.pass("shadow: generate in the light's view", |rec| {
            for ((h, _), frame) in casters.generated.iter().zip(&frames) {
                pipes.depth.record_lod(rec, &casters.hairs[*h], frame);
                pipes.depth.record_generate(rec, &casters.hairs[*h], frame);
            }
        });
        let drawn = rec.pass("shadow depth", |rec| {
            rec.image_barrier(
                &dummy,
                (vk::ImageLayout::UNDEFINED, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
                top,
                color_out,
            );
            rec.image_barrier(
                &depth_image,
                (vk::ImageLayout::UNDEFINED, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL),
                top,
                depth_out,
            );
            rec.begin_rendering(&dummy, [0.0; 4], Some(&depth_image));
            let drawn = draw(rec, &pipes.depth, DrawExtras::default());
            rec.end_rendering();
            rec.image_barrier(
                &depth_image,
                (vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
                depth_out,
                copy_read,
            );
            rec.copy_image_to_buffer(&depth_image, &depth);
            drawn
        });
        drawn?;
        rec.memory_barrier(
            (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE),
            (vk::PipelineStageFlags2::FRAGMENT_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
        );
        rec.pass("shadow opacity", |rec| {
            rec.image_barrier(
                &opacity_image,
                (vk::ImageLayout::UNDEFINED, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
                top,
                color_out,
            );
            rec.image_barrier(
                &depth_image,
                (vk::ImageLayout::TRANSFER_SRC_OPTIMAL, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL),
                copy_read,
                depth_out,
            );
            rec.begin_rendering(&opacity_image, [0.0; 4], Some(&depth_image));
            let extra = [(15, &depth)];
            let drawn = draw(
                rec,
                &pipes.opacity,
                DrawExtras { fragment_constants: bytemuck::cast_slice(&layer_constants), buffers: &extra },
            );
            rec.end_rendering();
            rec.image_barrier(
                &opacity_image,
                (vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
                color_out,
                copy_read,
            );
            rec.copy_image_to_buffer(&opacity_image, &opacity);
            drawn
        })
    })?;
    Ok(ShadowMaps { depth, opacity, light_view_proj: light, size, layer_ends, timings })
}
