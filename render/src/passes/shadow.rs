//! Deep opacity maps per shadow-casting light (see [`crate::shadow`] for the method): per
//! light, the casters generated in the light's view, an occluder depth pass, a hair depth pass
//! and an opacity pass, each copied into the maps' atlas buffers that the shading reads. The
//! passes run in a submission of their own on the first frame; later frames show them cached.

use std::collections::HashMap;

use gen_gpu::{
    Buffer, BufferDesc, Context, DrawExtras, FrameBuffers, FrameInputs, GenerationPath, Generator, Image,
    ImageDesc, Recorder, vk,
};
use glam::{Mat4, Vec3};

use super::ScenePass;
use crate::RenderError;
use crate::contract::binding;
use crate::frame::{FrameIds, FramePlan, SceneRenderer, transformed_box};
use crate::graph::{Access, FrameGraph, GraphRun, PassNode, Res};
use crate::scene::Light;
use crate::shadow::{
    ComputeShadow, LightShadow, LightView, OPACITY_FORMAT, ShadowAtlas, ShadowLight, ShadowMode,
    ShadowRasterPush, light_inputs,
};

/// One shadow pass of light `light` (its index among the shadow-casting lights).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowPass {
    /// No occluders: every occluder depth texel at the far plane.
    ClearOccluderDepth,
    Generate {
        light: usize,
    },
    OccluderDepth {
        light: usize,
    },
    CopyOccluderDepth {
        light: usize,
    },
    HairDepth {
        light: usize,
    },
    CopyHairDepth {
        light: usize,
    },
    Opacity {
        light: usize,
    },
    CopyOpacity {
        light: usize,
    },
    /// Compute raster: the maps cleared (depth to the far plane, opacity sums to zero).
    ClearMaps,
    /// Compute raster: the casters' LOD in the light's view (the fused kernels generate).
    Lod {
        light: usize,
    },
    /// Compute raster: the nearest hair depth per texel.
    ComputeHairDepth {
        light: usize,
    },
    /// Compute raster: opacity summed into the layers behind it.
    ComputeOpacity {
        light: usize,
    },
    /// Compute raster: the opacity sums into the float layers the shading reads.
    ResolveOpacity {
        light: usize,
    },
}

/// The shadow resources of a frame graph.
#[derive(Clone, Debug)]
pub(crate) struct ShadowIds {
    /// The atlas buffers the shading reads (hair depth, opacity, occluder depth of every light).
    pub(crate) maps: Res,
    depth_image: Res,
    color_image: Res,
    opacity_image: Res,
    light_strands: Vec<Res>,
    hair: Vec<Res>,
    stored: Vec<Res>,
}

pub(crate) fn declare(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    hair: &[Res],
    stored: &[Res],
) -> ShadowIds {
    let lights = r.scene.shadow_lights().len();
    ShadowIds {
        maps: g.external_buffer("shadow maps"),
        depth_image: g.image("shadow depth"),
        color_image: g.image("shadow depth pass colour"),
        opacity_image: g.image("shadow opacity"),
        light_strands: (0..lights).map(|i| g.buffer(format!("light {i} strands"))).collect(),
        hair: hair.to_vec(),
        stored: stored.to_vec(),
    }
}

/// Adds every light's passes to submission 0, marked cached when the maps are reused.
pub(crate) fn plan(
    r: &SceneRenderer,
    g: &mut FrameGraph<ScenePass>,
    ids: &FrameIds,
    s: &ShadowIds,
    cached: bool,
) {
    let occluders = !r.occluders.is_empty() && r.occluder_pipes.is_some();
    let add = |g: &mut FrameGraph<ScenePass>,
               name: String,
               reads: &[(Res, Access)],
               writes: &[(Res, Access)],
               pass: ShadowPass| {
        g.pass(name)
            .cached(cached)
            .reads(reads.iter().copied())
            .writes(writes.iter().copied())
            .add(ScenePass::Shadow(pass));
    };
    if !occluders {
        add(
            g,
            "shadow: no occluders (occluder depth at the far plane)".into(),
            &[],
            &[(s.maps, Access::TransferWrite)],
            ShadowPass::ClearOccluderDepth,
        );
    }
    let depth_pass = [(s.depth_image, Access::DepthAttachment), (s.color_image, Access::ColorAttachment)];
    let compute = r.compute_shadows();
    if compute {
        add(
            g,
            "shadow: clear the maps (compute raster)".into(),
            &[],
            &[(s.maps, Access::TransferWrite)],
            ShadowPass::ClearMaps,
        );
    }
    for (light, &strands) in s.light_strands.iter().enumerate() {
        if compute {
            plan_compute_light(g, s, &add, occluders, ids, light, strands, &depth_pass);
            continue;
        }
        let hair: Vec<(Res, Access)> = s.hair.iter().map(|&h| (h, Access::ComputeRead)).collect();
        add(
            g,
            format!("shadow {light}: generate in the light's view"),
            &hair,
            &[(strands, Access::ComputeWrite)],
            ShadowPass::Generate { light },
        );
        if occluders {
            plan_occluder_depth(g, s, &add, ids, light, &depth_pass);
        }
        let mut strand_reads = vec![(strands, Access::IndirectRead), (strands, Access::PreRasterRead)];
        strand_reads.extend(s.stored.iter().map(|&st| (st, Access::PreRasterRead)));
        add(
            g,
            format!("shadow {light}: hair depth"),
            &strand_reads,
            &depth_pass,
            ShadowPass::HairDepth { light },
        );
        add(
            g,
            format!("shadow {light}: copy hair depth to the atlas"),
            &[(s.depth_image, Access::TransferRead)],
            &[(s.maps, Access::TransferWrite)],
            ShadowPass::CopyHairDepth { light },
        );
        let mut opacity_reads = strand_reads.clone();
        opacity_reads.push((s.maps, Access::FragmentRead));
        add(
            g,
            format!("shadow {light}: opacity"),
            &opacity_reads,
            &[(s.opacity_image, Access::ColorAttachment), (s.depth_image, Access::DepthAttachment)],
            ShadowPass::Opacity { light },
        );
        add(
            g,
            format!("shadow {light}: copy opacity to the atlas"),
            &[(s.opacity_image, Access::TransferRead)],
            &[(s.maps, Access::TransferWrite)],
            ShadowPass::CopyOpacity { light },
        );
    }
}

/// The signature of the plan's pass-adding closure.
type AddPass<'a> =
    dyn Fn(&mut FrameGraph<ScenePass>, String, &[(Res, Access)], &[(Res, Access)], ShadowPass) + 'a;

/// Light `light`'s occluder depth pass (triangles: occluders are meshes) and its copy into the
/// atlas, on either rasterizer.
fn plan_occluder_depth(
    g: &mut FrameGraph<ScenePass>,
    s: &ShadowIds,
    add: &AddPass<'_>,
    ids: &FrameIds,
    light: usize,
    depth_pass: &[(Res, Access)],
) {
    add(
        g,
        format!("shadow {light}: occluder depth"),
        &[(ids.occluder_meshes, Access::PreRasterRead)],
        depth_pass,
        ShadowPass::OccluderDepth { light },
    );
    add(
        g,
        format!("shadow {light}: copy occluder depth to the atlas"),
        &[(s.depth_image, Access::TransferRead)],
        &[(s.maps, Access::TransferWrite)],
        ShadowPass::CopyOccluderDepth { light },
    );
}

/// One light's passes with the compute rasterizer: the LOD in its view, the occluders' depth
/// (triangles, as they are meshes), then the hair's nearest depth and its opacity layers by the
/// compute kernels (generation fused), and the opacity sums to floats.
#[allow(clippy::too_many_arguments, reason = "the plan's shared pieces, passed once per light")]
fn plan_compute_light(
    g: &mut FrameGraph<ScenePass>,
    s: &ShadowIds,
    add: &AddPass<'_>,
    occluders: bool,
    ids: &FrameIds,
    light: usize,
    strands: Res,
    depth_pass: &[(Res, Access)],
) {
    let hair: Vec<(Res, Access)> = s.hair.iter().map(|&h| (h, Access::ComputeRead)).collect();
    add(
        g,
        format!("shadow {light}: LOD in the light's view"),
        &hair,
        &[(strands, Access::ComputeWrite)],
        ShadowPass::Lod { light },
    );
    if occluders {
        plan_occluder_depth(g, s, add, ids, light, depth_pass);
    }
    let mut casters = hair;
    casters.extend([(strands, Access::ComputeRead), (strands, Access::IndirectRead)]);
    casters.extend(s.stored.iter().map(|&st| (st, Access::ComputeRead)));
    add(
        g,
        format!("shadow {light}: hair depth (compute raster, fused generation)"),
        &casters,
        &[(s.maps, Access::ComputeWrite)],
        ShadowPass::ComputeHairDepth { light },
    );
    add(
        g,
        format!("shadow {light}: opacity (compute raster, fused generation)"),
        &casters,
        &[(s.maps, Access::ComputeWrite)],
        ShadowPass::ComputeOpacity { light },
    );
    add(
        g,
        format!("shadow {light}: opacity sums to layers"),
        &[],
        &[(s.maps, Access::ComputeWrite)],
        ShadowPass::ResolveOpacity { light },
    );
}

/// One light's generated casters and draw parameters.
struct PerLight {
    shadow: LightShadow,
    frames: Vec<FrameBuffers>,
    stored_params: Vec<Buffer>,
}

/// Everything the shadow passes of one frame use; becomes the cached [`ShadowAtlas`].
pub(crate) struct ShadowFrame {
    depth: Buffer,
    opacity: Buffer,
    occluder_depth: Buffer,
    depth_image: Image,
    color_image: Image,
    /// The triangle opacity pass's target (none when the compute kernels make the maps).
    opacity_image: Option<Image>,
    lights: Vec<PerLight>,
    size: u32,
}

impl ShadowFrame {
    /// The images behind the graph's image resources.
    pub(crate) fn images(&self, ids: &ShadowIds) -> HashMap<Res, &Image> {
        let mut images =
            HashMap::from([(ids.depth_image, &self.depth_image), (ids.color_image, &self.color_image)]);
        if let Some(opacity) = &self.opacity_image {
            images.insert(ids.opacity_image, opacity);
        }
        images
    }

    pub(crate) fn into_atlas(self) -> ShadowAtlas {
        ShadowAtlas {
            depth: self.depth,
            opacity: self.opacity,
            occluder_depth: self.occluder_depth,
            lights: self.lights.into_iter().map(|l| l.shadow).collect(),
            size: self.size,
        }
    }
}

/// The world box of every caster and occluder, each light's view of it, and the per-light
/// generation buffers.
pub(crate) fn prepare(
    r: &SceneRenderer,
    ctx: &Context,
    plan: &FramePlan,
) -> Result<ShadowFrame, RenderError> {
    let Some(pipes) = &r.shadow else {
        return Err(RenderError::Gpu(gen_gpu::GpuError::OverBudget {
            name: "shadow maps".into(),
            requested: 0,
            budget: 0,
            why: "planned without shadow pipelines",
        }));
    };
    let effects = r.effects;
    let (size, layer_fractions, lod) = (effects.shadow_map_size, effects.shadow_layers, plan.view.lod);
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut add_box = |m: Mat4, bounds: (Vec3, Vec3)| {
        let (a, b) = transformed_box(m, bounds);
        lo = lo.min(a);
        hi = hi.max(b);
    };
    for c in &r.characters {
        for b in &r.hairs[c.hair].asset.bundles {
            add_box(c.transform, (b.bounds_min.as_vec3(), b.bounds_max.as_vec3()));
        }
    }
    for c in &r.stored_characters {
        add_box(c.transform, r.stored[c.hair].bounds);
    }
    for o in &r.occluders {
        add_box(o.transform, r.meshes[o.mesh].bounds);
    }
    let lights = r.scene.lights();
    let texels = u64::from(size) * u64::from(size);
    let shadow_lights = r.scene.shadow_lights();
    let per_light = shadow_lights
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            let light = match lights[i] {
                Light::Directional { direction, .. } => ShadowLight::Directional(Vec3::from_array(direction)),
                Light::Point { position, .. } => ShadowLight::Point(Vec3::from_array(position)),
            };
            let view = LightView::new(light, (lo, hi)).map_err(|message| RenderError::Light {
                path: r.scene.path.clone(),
                light: i,
                message,
            })?;
            let inputs: Vec<FrameInputs> =
                r.characters.iter().map(|c| light_inputs(&view, light, c.transform, size, lod)).collect();
            // With the compute rasterizer the kernels generate the strands themselves: no
            // strand buffers, only the LOD's buffers.
            let frames = r
                .characters
                .iter()
                .zip(&inputs)
                .map(|(c, inputs)| match pipes.compute {
                    Some(_) => r.generator.prepare_fused(ctx, &r.hairs[c.hair], inputs),
                    None => pipes.depth.prepare(ctx, &r.hairs[c.hair], inputs),
                })
                .collect::<gen_gpu::Result<Vec<_>>>()?;
            let stored_params = r
                .stored_characters
                .iter()
                .map(|c| {
                    let inputs = light_inputs(&view, light, c.transform, size, lod);
                    r.stored[c.hair].frame_params(ctx, &inputs)
                })
                .collect::<gen_gpu::Result<Vec<_>>>()?;
            Ok(PerLight {
                shadow: LightShadow {
                    light_view_proj: view.view_proj,
                    depth_params: view.depth_params(),
                    layer_ends: layer_fractions.map(|f| f.max(1e-6) * view.radius),
                    first_texel: texels * k as u64,
                    // Three texels' worth (a texel spans about 2r / size at the casters).
                    occluder_bias: 6.0 * view.radius / size as f32,
                },
                frames,
                stored_params,
            })
        })
        .collect::<Result<Vec<_>, RenderError>>()?;
    let light_count = per_light.len().max(1) as u64;
    let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
    let depth_desc = ImageDesc::d2(
        size,
        size,
        gen_gpu::DEPTH_FORMAT,
        vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
    );
    Ok(ShadowFrame {
        depth: Buffer::new(ctx, "shadow depth maps", BufferDesc::storage(texels * 4 * light_count))?,
        opacity: Buffer::new(ctx, "shadow opacity maps", BufferDesc::storage(texels * 16 * light_count))?,
        occluder_depth: Buffer::new(
            ctx,
            "occluder depth maps",
            BufferDesc::storage(texels * 4 * light_count),
        )?,
        depth_image: Image::new(ctx, "shadow depth", depth_desc)?,
        color_image: Image::new(
            ctx,
            "shadow depth pass colour",
            ImageDesc::d2(size, size, gen_gpu::COLOR_FORMAT, usage),
        )?,
        opacity_image: match pipes.compute {
            Some(_) => None,
            None => {
                Some(Image::new(ctx, "shadow opacity", ImageDesc::d2(size, size, OPACITY_FORMAT, usage))?)
            }
        },
        lights: per_light,
        size,
    })
}

/// Draws every caster of `light` with `generator`'s fragment stage.
fn draw_casters(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    generator: &Generator,
    light: &PerLight,
    extras: DrawExtras<'_>,
) -> gen_gpu::Result<()> {
    for (c, frame) in r.characters.iter().zip(&light.frames) {
        generator.record_draw_with(rec, &r.hairs[c.hair], frame, GenerationPath::Compute, false, extras)?;
    }
    for (c, params) in r.stored_characters.iter().zip(&light.stored_params) {
        r.stored[c.hair].record_draw(rec, generator, params, extras);
    }
    Ok(())
}

pub(crate) fn record(
    r: &SceneRenderer,
    rec: &mut Recorder<'_>,
    pass: &PassNode<ScenePass>,
    s: &ShadowFrame,
    _run: &GraphRun<'_, ScenePass>,
) -> gen_gpu::Result<()> {
    let (ScenePass::Shadow(pass), Some(pipes)) = (pass.payload, &r.shadow) else { return Ok(()) };
    let light = |i: usize| &s.lights[i];
    match pass {
        ShadowPass::ClearOccluderDepth => rec.fill_buffer(&s.occluder_depth, 1f32.to_bits()),
        ShadowPass::Generate { light: i } => {
            for (c, frame) in r.characters.iter().zip(&light(i).frames) {
                pipes.depth.record_lod(rec, &r.hairs[c.hair], frame);
            }
            // Inside the pass: every character's LOD before any generation reads it.
            Generator::barrier_after_lod(rec);
            for (c, frame) in r.characters.iter().zip(&light(i).frames) {
                pipes.depth.record_generate(rec, &r.hairs[c.hair], frame);
            }
        }
        ShadowPass::OccluderDepth { light: i } => {
            let Some(occluder_pipes) = &r.occluder_pipes else { return Ok(()) };
            rec.begin_rendering(&s.color_image, [0.0; 4], Some(&s.depth_image));
            for o in &r.occluders {
                let push = crate::occluder::occluder_push(
                    o.transform,
                    light(i).shadow.light_view_proj,
                    Vec3::ZERO,
                    0,
                    [0.0; 3],
                );
                r.meshes[o.mesh].record_draw(rec, &occluder_pipes.shadow, &push, &[]);
            }
            rec.end_rendering();
        }
        ShadowPass::CopyOccluderDepth { light: i } => {
            rec.copy_image_to_buffer_at(&s.depth_image, &s.occluder_depth, light(i).shadow.first_texel * 4);
        }
        ShadowPass::HairDepth { light: i } => {
            rec.begin_rendering(&s.color_image, [0.0; 4], Some(&s.depth_image));
            let drawn = draw_casters(r, rec, &pipes.depth, light(i), DrawExtras::default());
            rec.end_rendering();
            drawn?;
        }
        ShadowPass::CopyHairDepth { light: i } => {
            rec.copy_image_to_buffer_at(&s.depth_image, &s.depth, light(i).shadow.first_texel * 4);
        }
        ShadowPass::Opacity { light: i } => {
            let l = light(i);
            // Depth is cleared again: every fragment adds its opacity (no depth test culls it).
            let Some(opacity_image) = &s.opacity_image else { return Ok(()) };
            rec.begin_rendering(opacity_image, [0.0; 4], Some(&s.depth_image));
            let extra = [(binding::SHADOW_DEPTH, &s.depth)];
            let ends = l.shadow.layer_ends;
            let [near, far, perspective, _] = l.shadow.depth_params;
            let constants: [u32; 12] = [
                ends[0].to_bits(),
                ends[1].to_bits(),
                ends[2].to_bits(),
                (s.size as f32).to_bits(),
                l.shadow.first_texel as u32,
                0,
                0,
                0,
                near.to_bits(),
                far.to_bits(),
                perspective.to_bits(),
                0,
            ];
            let extras = DrawExtras { fragment_constants: bytemuck::cast_slice(&constants), buffers: &extra };
            let drawn = draw_casters(r, rec, &pipes.opacity, l, extras);
            rec.end_rendering();
            drawn?;
        }
        ShadowPass::CopyOpacity { light: i } => {
            if let Some(opacity_image) = &s.opacity_image {
                rec.copy_image_to_buffer_at(opacity_image, &s.opacity, light(i).shadow.first_texel * 16);
            }
        }
        ShadowPass::ClearMaps => {
            rec.fill_buffer(&s.depth, 1f32.to_bits());
            rec.fill_buffer(&s.opacity, 0);
        }
        ShadowPass::Lod { light: i } => {
            for (c, frame) in r.characters.iter().zip(&light(i).frames) {
                r.generator.record_lod(rec, &r.hairs[c.hair], frame);
            }
        }
        ShadowPass::ComputeHairDepth { light: i } => {
            record_compute_maps(r, rec, s, light(i), ShadowMode::Depth);
        }
        ShadowPass::ComputeOpacity { light: i } => {
            record_compute_maps(r, rec, s, light(i), ShadowMode::Opacity);
        }
        ShadowPass::ResolveOpacity { light: i } => {
            if let Some(compute) = &pipes.compute {
                compute.record_resolve(rec, &s.opacity, &light(i).shadow, s.size);
            }
        }
    }
    Ok(())
}

/// One compute shadow dispatch per caster of `light`: the fused kernel over each character's
/// live strands (the LOD pass's indirect arguments), the stored kernel over each strand file.
fn record_compute_maps(
    r: &SceneRenderer,
    rec: &Recorder<'_>,
    s: &ShadowFrame,
    light: &PerLight,
    mode: ShadowMode,
) {
    let Some(compute) = r.shadow.as_ref().and_then(|p| p.compute.as_ref()) else { return };
    let extra = [(binding::SHADOW_DEPTH, &s.depth), (binding::SHADOW_OPACITY, &s.opacity)];
    if !r.characters.is_empty() {
        rec.bind_pipeline(&compute.fused);
    }
    for (c, frame) in r.characters.iter().zip(&light.frames) {
        r.generator.bind_frame(rec, &compute.fused, &r.hairs[c.hair], frame, &extra);
        rec.push_constants(
            &compute.fused,
            &ShadowRasterPush::new(&light.shadow, s.size, c.transform, mode, 0),
        );
        Generator::record_fused_dispatch(rec, frame);
    }
    for (c, params) in r.stored_characters.iter().zip(&light.stored_params) {
        let pipeline = &compute.stored;
        let group = ComputeShadow::stored_group_size();
        r.stored[c.hair].record_compute(
            rec,
            pipeline,
            params,
            &extra,
            group,
            gen_gpu::SlotSubset::All,
            |rec, chunk| {
                rec.push_constants(
                    pipeline,
                    &ShadowRasterPush::new(&light.shadow, s.size, c.transform, mode, chunk.slots),
                );
            },
        );
    }
}
