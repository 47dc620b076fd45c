//! Self-shadowing by deep opacity maps (Yuksel & Keyser 2008), one set per shadow-casting
//! light: the hair is generated again in the light's view — orthographic for a directional
//! light (orthographic LOD: the view height stands in for d·tan(θ/2)), perspective from a point
//! light outside the casters — a depth pass keeps the nearest
//! hair per texel, an opacity pass accumulates opacity into three layers behind it, and an
//! occluder depth pass keeps the nearest occluder (scalp, body), which shadows everything behind
//! it. The maps of all lights share three buffers (`lighting.glsl` indexes them per light, and
//! blends the answers of the four texels around a point). A static scene's maps are computed
//! once and cached. The passes are in [`crate::passes::shadow`].
//!
//! With the compute rasterizer the hair's two passes are compute kernels ([`ComputeShadow`]:
//! `hair_shadow.comp` with generation fused, `hair_shadow_stored.comp` for strand files) that walk
//! segments as the hair's raster kernel does: the depth pass keeps each texel's nearest depth with
//! an atomic minimum, the opacity pass adds coverage × [`STRAND_OPACITY`] to each layer in fixed
//! point ([`SHADOW_OPACITY_SCALE`]), and `shadow_resolve.comp` writes the float layers. Their CPU
//! port is [`crate::cpu::raster::shadow_strand`].

use gen_gpu::{Blend, Buffer, Context, FragmentStage, FrameInputs, Generator, GeneratorOptions, vk};
use glam::{Mat4, Vec3};
use hairmesh::reference::{LodParams, Projection, ViewParams};

use crate::shaders;

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
}

/// The two generators of the shadow passes, and with the compute rasterizer its shadow kernels.
pub struct ShadowPipelines {
    pub depth: Generator,
    pub opacity: Generator,
    /// Set when the scene draws its hair with the compute rasterizer: the maps are then
    /// rasterized by the same segment walker ([`ComputeShadow`]).
    pub compute: Option<ComputeShadow>,
}

/// Fixed-point units per unit of opacity in the compute kernels' sums (`SHADOW_OPACITY_SCALE`).
pub const SHADOW_OPACITY_SCALE: f32 = 4096.0;
/// Nothing is added to a layer's sum once it holds this much (`SHADOW_OPACITY_LIMIT`): no sum
/// wraps around, however dense the hair.
pub const SHADOW_OPACITY_LIMIT: u32 = 1 << 24;
/// Opacity of one strand fragment before coverage (`STRAND_OPACITY` of both paths).
pub const STRAND_OPACITY: f32 = 0.5;

/// Which map a compute shadow dispatch fills (`SHADOW_MODE_*` of `shadow_raster.glsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum ShadowMode {
    /// The nearest hair depth per texel.
    Depth = 0,
    /// Opacity summed into the three layers behind it (fixed point).
    Opacity = 1,
}

/// The push constants of the compute shadow kernels (`ShadowRasterParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadowRasterPush {
    pub model: [f32; 16],
    pub slots: u32,
    pub mode: u32,
    pub first_texel: u32,
    pub max_half_width: f32,
    /// xyz layer ends (world units), w the map size.
    pub ends: [f32; 4],
    /// Near, far, 1 = perspective.
    pub depth: [f32; 4],
}

impl ShadowRasterPush {
    pub fn new(shadow: &LightShadow, size: u32, model: Mat4, mode: ShadowMode, slots: u32) -> Self {
        let [near, far, perspective, _] = shadow.depth_params;
        let e = shadow.layer_ends;
        Self {
            model: model.to_cols_array(),
            slots,
            mode: mode as u32,
            first_texel: shadow.first_texel as u32,
            max_half_width: crate::raster::MAX_HALF_WIDTH_PIXELS,
            ends: [e[0], e[1], e[2], size as f32],
            depth: [near, far, perspective, 0.0],
        }
    }
}

/// The deep opacity maps through the compute rasterizer: the fused kernel (generation in the
/// light's view), the stored-strand kernel and the pass turning the fixed-point opacity sums
/// into the float layers the shading reads.
pub struct ComputeShadow {
    pub(crate) fused: gen_gpu::Pipeline,
    pub(crate) stored: gen_gpu::Pipeline,
    pub(crate) resolve: gen_gpu::Pipeline,
}

impl std::fmt::Debug for ComputeShadow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ComputeShadow").finish()
    }
}

impl ComputeShadow {
    pub fn new(ctx: &Context) -> gen_gpu::Result<Self> {
        use crate::contract::binding;
        let compute = |name, shader, bindings: &[gen_gpu::Binding], push| {
            gen_gpu::Pipeline::compute(ctx, &gen_gpu::ComputePipelineDesc::new(name, shader, bindings, push))
        };
        let maps = [binding::SHADOW_DEPTH, binding::SHADOW_OPACITY];
        let strand = gen_gpu::strand_bindings(&maps);
        let push = size_of::<ShadowRasterPush>() as u32;
        Ok(Self {
            fused: compute(
                "deep opacity maps (compute raster, fused generation)",
                &shaders::HAIR_SHADOW_COMP,
                &strand,
                push,
            )?,
            stored: compute(
                "deep opacity maps (compute raster, stored strands)",
                &shaders::HAIR_SHADOW_STORED_COMP,
                &strand,
                push,
            )?,
            resolve: compute(
                "deep opacity maps: opacity sums to floats",
                &shaders::SHADOW_RESOLVE_COMP,
                &gen_gpu::Binding::storage_buffers(&[binding::SHADOW_OPACITY], vk::ShaderStageFlags::COMPUTE),
                16,
            )?,
        })
    }

    /// Workgroup size of the stored-strand kernel (from its SPIR-V).
    pub(crate) fn stored_group_size() -> u32 {
        shaders::HAIR_SHADOW_STORED_COMP.workgroup_size[0]
    }

    /// Records the pass turning light `shadow`'s opacity sums into floats.
    pub(crate) fn record_resolve(
        &self,
        rec: &gen_gpu::Recorder<'_>,
        opacity: &Buffer,
        shadow: &LightShadow,
        size: u32,
    ) {
        let texels = size * size;
        rec.bind_pipeline(&self.resolve);
        rec.push_storage_buffers(&self.resolve, &[(crate::contract::binding::SHADOW_OPACITY, opacity)]);
        let push = [shadow.first_texel as u32, texels, (1.0 / SHADOW_OPACITY_SCALE).to_bits(), 0];
        rec.push_constants(&self.resolve, &push);
        rec.dispatch(texels.div_ceil(shaders::SHADOW_RESOLVE_COMP.workgroup_size[0]), 1, 1);
    }

    /// Rasterizes `stored` strands alone into fresh maps of `size`² texels for `shadow` (one
    /// light, first texel 0) in `mode` and reads them back: the nearest depth bits per texel,
    /// then (with [`ShadowMode::Opacity`], over the depth map from `depth_bits`) the fixed-point
    /// opacity sums, before the float resolve. What the tests compare with the CPU port
    /// ([`crate::cpu::raster::shadow_strand`]).
    pub fn rasterize_stored(
        &self,
        ctx: &Context,
        stored: &gen_gpu::StoredStrands,
        inputs: &FrameInputs,
        shadow: &LightShadow,
        mode: ShadowMode,
        depth_bits: Option<&[u32]>,
    ) -> gen_gpu::Result<(Vec<u32>, Vec<[u32; 4]>)> {
        use crate::contract::binding;
        let size = inputs.viewport[0];
        let texels = u64::from(size) * u64::from(size);
        let transfer = vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
        let mut depth = Buffer::new(
            ctx,
            "shadow depth (test)",
            gen_gpu::BufferDesc::storage(texels * 4).usage(transfer),
        )?;
        let opacity = Buffer::new(
            ctx,
            "shadow opacity (test)",
            gen_gpu::BufferDesc::storage(texels * 16).usage(transfer),
        )?;
        if let Some(bits) = depth_bits {
            ctx.write_buffer(&mut depth, 0, bytemuck::cast_slice(bits))?;
        }
        let params = stored.frame_params(ctx, inputs)?;
        let extra = [(binding::SHADOW_DEPTH, &depth), (binding::SHADOW_OPACITY, &opacity)];
        ctx.submit("deep opacity maps (stored strands, test)", |rec| {
            if depth_bits.is_none() {
                rec.fill_buffer(&depth, 1f32.to_bits());
            }
            rec.fill_buffer(&opacity, 0);
            crate::raster::fills_to_compute(rec);
            stored.record_compute(
                rec,
                &self.stored,
                &params,
                &extra,
                Self::stored_group_size(),
                gen_gpu::SlotSubset::All,
                |rec, chunk| {
                    rec.push_constants(
                        &self.stored,
                        &ShadowRasterPush::new(shadow, size, Mat4::IDENTITY, mode, chunk.slots),
                    );
                },
            );
            crate::raster::compute_writes_to_readback(rec);
            Ok(())
        })?;
        let depth = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&depth, texels * 4)?);
        let sums: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&opacity, texels * 16)?);
        Ok((depth, sums.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()))
    }
}

impl std::fmt::Debug for ShadowPipelines {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShadowPipelines").finish()
    }
}

pub const OPACITY_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

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
                    specialization: None,
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
                    extra_bindings: &[crate::contract::binding::SHADOW_DEPTH],
                    specialization: None,
                }),
                color_format: Some(OPACITY_FORMAT),
                ..GeneratorOptions::default()
            },
        )?;
        Ok(Self { depth, opacity, compute: None })
    }
}

pub fn light_inputs(
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
