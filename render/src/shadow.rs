//! Self-shadowing by deep opacity maps (Yuksel & Keyser 2008), one set per shadow-casting
//! light: the hair is generated again in the light's view — orthographic for a directional
//! light (orthographic LOD: the view height stands in for d·tan(θ/2)), perspective from a point
//! light outside the casters — a depth pass keeps the nearest
//! hair per texel, an opacity pass accumulates opacity into three layers behind it, and an
//! occluder depth pass keeps the nearest occluder (scalp, body), which shadows everything behind
//! it. The maps of all lights share three buffers (`lighting.glsl` indexes them per light). A
//! static scene's maps are computed once and cached.

use gen_gpu::{
    Blend, Buffer, BufferDesc, Context, DrawExtras, FragmentStage, FrameInputs, FrameTimings, GenerationPath,
    Generator, GeneratorOptions, GpuHair, Image, ImageDesc, Recorder, StoredStrands, vk,
};
use glam::{Mat4, Vec3};
use hairmesh::reference::{LodParams, Projection, ViewParams};

use crate::frame::shaders;
use crate::occluder::{OccluderMesh, OccluderPipelines};

/// A shadow-casting light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadowLight {
    /// Direction toward a light at infinity: an orthographic view.
    Directional(Vec3),
    /// A point light's position: a perspective view of the casters from outside them.
    Point(Vec3),
}

/// A light's view of the casters' bounding sphere. Depths are compared linearly, in world
/// units, for both projections.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightView {
    /// World space → light clip space.
    pub view_proj: Mat4,
    pub near: f32,
    pub far: f32,
    pub perspective: bool,
    /// Radius of the casters' bounding sphere.
    pub radius: f32,
    /// Perspective: the vertical (= horizontal) field of view.
    pub fov: f32,
}

impl LightView {
    /// The light's view of the box `(lo, hi)`; a point light inside the box's bounding sphere
    /// would need a cube map and is refused.
    pub fn new(light: ShadowLight, (lo, hi): (Vec3, Vec3)) -> Result<Self, String> {
        let centre = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-6);
        let up_for = |dir: Vec3| if dir.y.abs() > 0.95 { Vec3::Z } else { Vec3::Y };
        match light {
            ShadowLight::Directional(toward) => {
                let dir = toward.try_normalize().unwrap_or(Vec3::Y);
                let view = Mat4::look_at_rh(centre + dir * (radius * 2.0), centre, up_for(dir));
                let (near, far) = (radius * 0.5, radius * 3.5);
                let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, near, far);
                Ok(Self { view_proj: proj * view, near, far, perspective: false, radius, fov: 0.0 })
            }
            ShadowLight::Point(position) => {
                let distance = position.distance(centre);
                if distance.is_nan() || distance <= radius * 1.05 {
                    return Err(format!(
                        "the point light at {position} is inside the shadow casters' bounds (centre {centre}, radius {radius}); shadows from there need a cube map, which is not supported yet"
                    ));
                }
                let fov = 2.0 * (radius / distance).asin() * 1.02;
                let dir = (position - centre) / distance;
                let view = Mat4::look_at_rh(position, centre, up_for(dir));
                let (near, far) = ((distance - radius) * 0.98, distance + radius);
                let proj = Mat4::perspective_rh(fov, 1.0, near, far);
                Ok(Self { view_proj: proj * view, near, far, perspective: true, radius, fov })
            }
        }
    }

    /// `[near, far, 1 if perspective, 0]`, as the shaders take it.
    pub fn depth_params(&self) -> [f32; 4] {
        [self.near, self.far, if self.perspective { 1.0 } else { 0.0 }, 0.0]
    }
}

/// One light's part of a [`ShadowAtlas`].
#[derive(Clone, Copy, Debug)]
pub struct LightShadow {
    /// World space → light clip space.
    pub light_view_proj: Mat4,
    /// Near and far plane and projection (see [`LightView::depth_params`]).
    pub depth_params: [f32; 4],
    /// Layer ends behind the nearest hair, in world units.
    pub layer_ends: [f32; 3],
    /// First texel of this light's maps in the atlas buffers.
    pub first_texel: u64,
    /// World distance an occluder must lie in front of a point to shadow it (against acne).
    pub occluder_bias: f32,
}

/// The maps the shading reads (bindings 15, 16 and 18), every shadow-casting light's in turn.
#[derive(Debug)]
pub struct ShadowAtlas {
    /// Nearest hair depth per texel (f32).
    pub depth: Buffer,
    /// Cumulative opacity at the end of layers 1–3 per texel (vec4).
    pub opacity: Buffer,
    /// Nearest occluder depth per texel (f32; 1 where there is none).
    pub occluder_depth: Buffer,
    /// Per shadow-casting light, in the order they were given.
    pub lights: Vec<LightShadow>,
    pub size: u32,
    pub timings: FrameTimings,
}

/// The passes [`render_shadow_maps`] records for shadow-casting light `i`.
pub fn light_pass_names(i: usize, occluders: bool) -> Vec<String> {
    let mut names = vec![format!("shadow {i}: generate in the light's view")];
    if occluders {
        names.push(format!("shadow {i}: occluder depth"));
    }
    names.push(format!("shadow {i}: hair depth"));
    names.push(format!("shadow {i}: opacity"));
    names
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
                    depth_compare: vk::CompareOp::LESS,
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
                    push_constant_bytes: 48,
                    blend: Blend::Additive,
                    depth_write: false,
                    depth_compare: vk::CompareOp::LESS,
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

/// What the shadow passes draw: generated characters `(hair, transform)`, stored ones and
/// occluders `(mesh, transform)`.
#[derive(Debug)]
pub struct ShadowCasters<'a> {
    pub hairs: &'a [GpuHair],
    pub generated: &'a [(usize, Mat4)],
    pub stored: &'a [StoredStrands],
    pub stored_characters: &'a [(usize, Mat4)],
    pub meshes: &'a [OccluderMesh],
    pub occluders: &'a [(usize, Mat4)],
    pub occluder_pipelines: Option<&'a OccluderPipelines>,
}

fn light_inputs(
    view: &LightView,
    light: ShadowLight,
    transform: Mat4,
    size: u32,
    lod: LodParams,
) -> FrameInputs {
    let scale = transform.x_axis.truncate().length().max(1e-6);
    let to_object = transform.inverse();
    let (eye, projection) = match light {
        // Orthographic: the strip faces this direction; LOD uses the view height.
        ShadowLight::Directional(toward) => (
            to_object.transform_vector3(toward).normalize_or_zero(),
            Projection::Orthographic { height: f64::from(2.0 * view.radius / scale) },
        ),
        ShadowLight::Point(position) => {
            (to_object.transform_point3(position), Projection::Perspective { fov_y: f64::from(view.fov) })
        }
    };
    FrameInputs {
        view_proj: view.view_proj * transform,
        view: ViewParams { eye: eye.as_dvec3(), vertical_resolution: f64::from(size), projection },
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

/// Renders the deep opacity maps and occluder depth maps of every light in `lights` over the
/// world box `bounds`, in one submission. `views` are the lights' [`LightView`]s.
pub fn render_shadow_maps(
    ctx: &Context,
    pipes: &ShadowPipelines,
    casters: &ShadowCasters<'_>,
    lights: &[(ShadowLight, LightView)],
    settings: ShadowSettings,
) -> gen_gpu::Result<ShadowAtlas> {
    let ShadowSettings { size, layer_fractions, lod } = settings;
    let texels = u64::from(size) * u64::from(size);
    let light_count = lights.len().max(1) as u64;
    let depth = Buffer::new(ctx, "shadow depth maps", BufferDesc::storage(texels * 4 * light_count))?;
    let opacity = Buffer::new(ctx, "shadow opacity maps", BufferDesc::storage(texels * 16 * light_count))?;
    let occluder_depth =
        Buffer::new(ctx, "occluder depth maps", BufferDesc::storage(texels * 4 * light_count))?;
    let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
    let dummy =
        Image::new(ctx, "shadow depth pass colour", ImageDesc::d2(size, size, gen_gpu::COLOR_FORMAT, usage))?;
    let opacity_image = Image::new(ctx, "shadow opacity", ImageDesc::d2(size, size, OPACITY_FORMAT, usage))?;
    let depth_desc = ImageDesc::d2(
        size,
        size,
        gen_gpu::DEPTH_FORMAT,
        vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
    );
    let depth_image = Image::new(ctx, "shadow depth", depth_desc)?;
    let has_occluders = !casters.occluders.is_empty() && casters.occluder_pipelines.is_some();

    struct PerLight {
        shadow: LightShadow,
        frames: Vec<gen_gpu::FrameBuffers>,
        stored_params: Vec<Buffer>,
    }
    let per_light = lights
        .iter()
        .enumerate()
        .map(|(i, &(light, view))| {
            let inputs: Vec<FrameInputs> =
                casters.generated.iter().map(|(_, m)| light_inputs(&view, light, *m, size, lod)).collect();
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
                    let i = light_inputs(&view, light, *m, size, lod);
                    pipes.depth.stored_params(ctx, &casters.stored[*s], &i)
                })
                .collect::<gen_gpu::Result<Vec<_>>>()?;
            Ok(PerLight {
                shadow: LightShadow {
                    light_view_proj: view.view_proj,
                    depth_params: view.depth_params(),
                    layer_ends: layer_fractions.map(|f| f.max(1e-6) * view.radius),
                    first_texel: texels * i as u64,
                    // Three texels' worth (a texel spans about 2r / size at the casters).
                    occluder_bias: 6.0 * view.radius / size as f32,
                },
                frames,
                stored_params,
            })
        })
        .collect::<gen_gpu::Result<Vec<_>>>()?;

    let top = (vk::PipelineStageFlags2::TOP_OF_PIPE, vk::AccessFlags2::NONE);
    let color_out =
        (vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT, vk::AccessFlags2::COLOR_ATTACHMENT_WRITE);
    let depth_out = (
        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ,
    );
    let copy_read = (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_READ);
    let copy_write = (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE);
    let draw = |rec: &mut Recorder<'_>,
                generator: &Generator,
                light: &PerLight,
                extras: DrawExtras<'_>|
     -> gen_gpu::Result<()> {
        for ((h, _), frame) in casters.generated.iter().zip(&light.frames) {
            generator.record_draw_with(
                rec,
                &casters.hairs[*h],
                frame,
                GenerationPath::Compute,
                false,
                extras,
            )?;
        }
        for ((s, _), params) in casters.stored_characters.iter().zip(&light.stored_params) {
            generator.record_draw_stored(rec, &casters.stored[*s], params, extras);
        }
        Ok(())
    };
    // The depth image is written by each depth pass and copied out; these move it between the
    // two uses (it starts undefined).
    let to_attachment = |rec: &Recorder<'_>, first: bool| {
        let (from, src) = if first {
            (vk::ImageLayout::UNDEFINED, top)
        } else {
            (vk::ImageLayout::TRANSFER_SRC_OPTIMAL, copy_read)
        };
        rec.image_barrier(&depth_image, (from, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL), src, depth_out);
    };
    let to_copy = |rec: &Recorder<'_>| {
        rec.image_barrier(
            &depth_image,
            (vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
            depth_out,
            copy_read,
        );
    };
    let ((), timings) = ctx.submit("shadow maps", |rec| {
        rec.image_barrier(
            &dummy,
            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
            top,
            color_out,
        );
        if !has_occluders {
            // Nothing occludes: every texel at the far plane.
            rec.fill_buffer(&occluder_depth, 1f32.to_bits());
        }
        let mut depth_first_use = true;
        for (i, light) in per_light.iter().enumerate() {
            let names = light_pass_names(i, has_occluders);
            let mut names = names.iter();
            let mut next_name = || names.next().map(String::as_str).unwrap_or("shadow");
            rec.pass(next_name(), |rec| {
                for ((h, _), frame) in casters.generated.iter().zip(&light.frames) {
                    pipes.depth.record_lod(rec, &casters.hairs[*h], frame);
                    pipes.depth.record_generate(rec, &casters.hairs[*h], frame);
                }
            });
            let offset = light.shadow.first_texel * 4;
            if let (true, Some(occluder_pipes)) = (has_occluders, casters.occluder_pipelines) {
                rec.pass(next_name(), |rec| {
                    to_attachment(rec, depth_first_use);
                    depth_first_use = false;
                    rec.begin_rendering(&dummy, [0.0; 4], Some(&depth_image));
                    for (mesh, model) in casters.occluders {
                        let push = crate::occluder::occluder_push(
                            *model,
                            light.shadow.light_view_proj,
                            Vec3::ZERO,
                            0,
                            [0.0; 3],
                        );
                        casters.meshes[*mesh].record_draw(rec, &occluder_pipes.shadow, &push, &[]);
                    }
                    rec.end_rendering();
                    to_copy(rec);
                    rec.copy_image_to_buffer_at(&depth_image, &occluder_depth, offset);
                });
            }
            rec.pass(next_name(), |rec| {
                to_attachment(rec, depth_first_use);
                depth_first_use = false;
                rec.begin_rendering(&dummy, [0.0; 4], Some(&depth_image));
                let drawn = draw(rec, &pipes.depth, light, DrawExtras::default());
                rec.end_rendering();
                to_copy(rec);
                rec.copy_image_to_buffer_at(&depth_image, &depth, offset);
                drawn
            })?;
            rec.memory_barrier(
                copy_write,
                (vk::PipelineStageFlags2::FRAGMENT_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
            );
            rec.pass(next_name(), |rec| {
                let first = i == 0;
                rec.image_barrier(
                    &opacity_image,
                    (
                        if first {
                            vk::ImageLayout::UNDEFINED
                        } else {
                            vk::ImageLayout::TRANSFER_SRC_OPTIMAL
                        },
                        vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                    ),
                    if first { top } else { copy_read },
                    color_out,
                );
                to_attachment(rec, false);
                rec.begin_rendering(&opacity_image, [0.0; 4], Some(&depth_image));
                let extra = [(15, &depth)];
                let ends = light.shadow.layer_ends;
                let [near, far, perspective, _] = light.shadow.depth_params;
                let constants: [u32; 12] = [
                    ends[0].to_bits(),
                    ends[1].to_bits(),
                    ends[2].to_bits(),
                    (size as f32).to_bits(),
                    light.shadow.first_texel as u32,
                    0,
                    0,
                    0,
                    near.to_bits(),
                    far.to_bits(),
                    perspective.to_bits(),
                    0,
                ];
                let drawn = draw(
                    rec,
                    &pipes.opacity,
                    light,
                    DrawExtras { fragment_constants: bytemuck::cast_slice(&constants), buffers: &extra },
                );
                rec.end_rendering();
                rec.image_barrier(
                    &opacity_image,
                    (vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
                    color_out,
                    copy_read,
                );
                rec.copy_image_to_buffer_at(&opacity_image, &opacity, light.shadow.first_texel * 16);
                to_copy(rec);
                drawn
            })?;
        }
        Ok(())
    })?;
    Ok(ShadowAtlas {
        depth,
        opacity,
        occluder_depth,
        lights: per_light.into_iter().map(|l| l.shadow).collect(),
        size,
        timings,
    })
}
