//! The compute rasterizer's pipelines and their variants: load path, fused strands, depth
//! clipping.

use super::*;

/// How the compute rasterizer's raster and shade kernels read the buffers they only load
/// from (pixel words, occlusion tiles, scene depth, shadow maps, stored vertices): a
/// specialization of their pipelines (`LOAD_BY_ADDRESS`, `raster_common.glsl`), so each
/// compiles one of the two loads. The image is the same either way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoadPath {
    /// Through buffer references to the device addresses in the push constants, the default
    /// where the device has buffer device addresses: CPU devices gather such loads with vector
    /// instructions, where a binding's load at a per-lane index is a loop over the lanes.
    BufferReferences,
    /// Through the descriptor bindings.
    Bindings,
}

/// What the compute rasterizer's fused-generation kernel draws of each strand: a
/// specialization of its pipelines (`FUSED_STRANDS`, `hair_raster.comp`).
///
/// [`Self::Straight`] is for measuring, not for pictures: it draws each strand as the straight
/// line from its root to its tip on the hair-mesh curve (the unstyled curve's end points, at
/// the strand's length), split into the same vertices and walked by the same rasterizer, so
/// that generating it costs two control-point loads and a lerp per vertex. The difference to a
/// [`Self::Styled`] frame of the same scene is what generating the real strands costs inside
/// the kernel (`hair-bench --only raster`, the far character's row); its CPU port is
/// [`straight_strand`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FusedStrands {
    /// The strands as the generator makes them (every frame).
    #[default]
    Styled,
    /// Straight lines from root to tip through the same walk (benchmarks).
    Straight,
}

impl FusedStrands {
    fn constant(self) -> u32 {
        match self {
            Self::Styled => FUSED_STRANDS_STYLED,
            Self::Straight => FUSED_STRANDS_STRAIGHT,
        }
    }
}

/// The points [`FusedStrands::Straight`] draws for strand `strand` of `bundle` with
/// `segments` segments: from the hair-mesh curve's point at the root (curve parameter 0) to
/// its point at the strand's length (the style's length scale times its bundle's reach), evenly
/// spaced. Object space.
pub fn straight_strand(
    hair: &hairmesh::asset::HairAsset,
    bundle: u32,
    strand: u32,
    segments: u32,
) -> Vec<Vec3> {
    let root = hair.root_parameter(bundle, strand);
    let at = |t: f64| hair.textures.curve_point(hair.curve, bundle, root.x, root.y, t);
    let (start, end) = (at(0.0), at(1.0));
    let scale = hair.style.length_scale(bundle, strand) * hair.reach(bundle);
    (0..=segments).map(|k| start.lerp(end, f64::from(k) / f64::from(segments) * scale).as_vec3()).collect()
}

/// Whether a character's segments need clipping to the view volume's depth (`0 ≤ z ≤ w`):
/// the raster kernels come in both variants (`DEPTH_CLIPPING`, `strand_raster.glsl`), and a
/// character wholly inside that depth range — nearly every character of nearly every frame —
/// is drawn by the one without clipping. That one carries less through its strand loop (faster
/// on CPU devices: `docs/compute-raster-notes.md`) and draws the same pixels
/// for such a character; the other is exact for any strand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthClipping {
    /// Every segment clipped to `0 ≤ z ≤ w` (strands through the near or far plane).
    Clip,
    /// No segment tested: the host found every vertex inside the depth range.
    Skip,
}

impl DepthClipping {
    /// What hair inside the object-space box `bounds` needs when `object_to_clip` (the
    /// matrix the kernels multiply positions by, in f32) takes it to clip space: [`Self::Skip`]
    /// only when every corner — so, clip z and w being linear, every point of the box — has
    /// `z ≥ 0` and `w − z ≥ 0` by a margin that the kernel's f32 rounding of any point of the
    /// box cannot cross, and `w` far from 0. A box that is empty, not finite or reaches
    /// outside by any amount gets [`Self::Clip`].
    pub fn for_bounds(object_to_clip: Mat4, (lo, hi): (Vec3, Vec3)) -> Self {
        if !(lo.cmple(hi).all() && lo.is_finite() && hi.is_finite() && object_to_clip.is_finite()) {
            return Self::Clip;
        }
        let m = object_to_clip.as_dmat4();
        let extent = lo.abs().max(hi.abs()).as_dvec3().extend(1.0);
        // Bounds of the magnitudes the kernel's dot products for z and w add: their f32
        // rounding (and that of the generated positions) errs by a few ulps of these (2^-23,
        // 1.2e-7, each), inside a margin of 4e-6 of them.
        let row = |r: usize| glam::DVec4::new(m.x_axis[r], m.y_axis[r], m.z_axis[r], m.w_axis[r]);
        let scale_z = row(2).abs().dot(extent);
        let scale_w = row(3).abs().dot(extent);
        let margin = 4e-6;
        let inside = crate::camera::box_corners(lo, hi).into_iter().all(|corner| {
            let clip = m * corner.as_dvec3().extend(1.0);
            clip.z >= margin * scale_z && clip.w - clip.z >= margin * (scale_z + scale_w) && clip.w > 1e-15
        });
        if inside { Self::Skip } else { Self::Clip }
    }
}

/// A raster kernel's two pipelines, with and without depth clipping ([`DepthClipping`]).
#[derive(Debug)]
pub(crate) struct ClippingVariants {
    clip: Pipeline,
    skip: Pipeline,
}

impl ClippingVariants {
    pub(crate) fn get(&self, clipping: DepthClipping) -> &Pipeline {
        match clipping {
            DepthClipping::Clip => &self.clip,
            DepthClipping::Skip => &self.skip,
        }
    }
}

/// The compute rasterizer's pipelines.
#[derive(Debug)]
pub struct ComputeRaster {
    pub(crate) raster: ClippingVariants,
    pub(crate) raster_stored: ClippingVariants,
    /// Each character's slot order before its raster phases (`raster_split.comp`).
    pub(crate) split: Pipeline,
    pub(crate) shade: Pipeline,
    pub(crate) tiles: Pipeline,
    pub(crate) resolve: Pipeline,
    /// Bound at the scene-depth binding when there are no occluders, and at the tiles' in
    /// single-phase dispatches (never read then).
    pub(crate) no_scene_depth: Buffer,
    loads: LoadPath,
    /// The visibility slots per pixel the kernels were specialized for (`None`: any).
    slots: Option<u32>,
    /// What the fused-generation kernel draws of each strand.
    fused: FusedStrands,
}

impl ComputeRaster {
    /// The pipelines for a scene of `lights` lights (at most [`crate::scene::MAX_LIGHTS`]) and
    /// `materials` distinct hair materials, reading as `loads` says (buffer references only
    /// where the device has buffer device addresses: else through the bindings): the shade
    /// kernel is specialized for the light count and for a single material; the raster, tile
    /// and shade kernels for `slots` visibility slots per pixel when given (what every frame's
    /// [`RasterBuffers`] then hold: the scene's, [`slots_within`] its output), else they take
    /// it from their push constants (any K: [`Self::rasterize_stored_words`]). The fused
    /// raster kernel compiles the code that takes a slot order and marks segments
    /// (`raster_split.comp`) unless `slots` is 1; it draws the strands as `fused` says.
    pub fn new(
        ctx: &Context,
        lights: usize,
        materials: usize,
        loads: LoadPath,
        slots: Option<u32>,
        fused: FusedStrands,
    ) -> gen_gpu::Result<Self> {
        let loads = if ctx.capabilities().buffer_device_address { loads } else { LoadPath::Bindings };
        let by_address = (LOAD_BY_ADDRESS_CONSTANT_ID, u32::from(loads == LoadPath::BufferReferences));
        let compute = |name: &str, shader, bindings: &[Binding], push, specialization: &[(u32, u32)]| {
            Pipeline::compute(
                ctx,
                &ComputePipelineDesc {
                    specialization,
                    ..ComputePipelineDesc::new(name, shader, bindings, push)
                },
            )
        };
        let push = size_of::<RasterPush>() as u32;
        let slot_count = (VISIBILITY_SLOTS_CONSTANT_ID, slots.unwrap_or(0));
        let variants =
            |name: &str, shader, bindings: &[u32], own: &[(u32, u32)]| -> gen_gpu::Result<ClippingVariants> {
                let strand = gen_gpu::strand_bindings(bindings);
                let variant = |clipping: DepthClipping, suffix| {
                    let clips = (DEPTH_CLIPPING_CONSTANT_ID, u32::from(clipping == DepthClipping::Clip));
                    let constants = [&[by_address, clips, slot_count], own].concat();
                    compute(&format!("{name}{suffix}"), shader, &strand, push, &constants)
                };
                Ok(ClippingVariants {
                    clip: variant(DepthClipping::Clip, ", depth clipping")?,
                    skip: variant(DepthClipping::Skip, "")?,
                })
            };
        let raster = variants(
            "compute raster (fused generation)",
            &shaders::HAIR_RASTER_COMP,
            &GENERATED_RASTER_BINDINGS,
            &[(FUSED_STRANDS_CONSTANT_ID, fused.constant())],
        )?;
        let raster_stored = variants(
            "compute raster (stored strands)",
            &shaders::HAIR_RASTER_STORED_COMP,
            &RASTER_BINDINGS,
            &[],
        )?;
        let split = compute(
            "compute raster slot order",
            &shaders::RASTER_SPLIT_COMP,
            &gen_gpu::strand_bindings(&RASTER_SPLIT_BINDINGS),
            size_of::<SplitPush>() as u32,
            &[],
        )?;
        let stage = vk::ShaderStageFlags::COMPUTE;
        let shade_bindings = Binding::storage_buffers(&RASTER_SHADE_BINDINGS, stage);
        let only_material = if materials == 1 { 0 } else { u32::MAX };
        let specialization = [
            scene_lights_constant(lights),
            (ONLY_MATERIAL_CONSTANT_ID, only_material),
            by_address,
            slot_count,
        ];
        let shade = compute(
            "compute raster shade",
            &shaders::RASTER_SHADE_COMP,
            &shade_bindings,
            size_of::<ShadePush>() as u32,
            &specialization,
        )?;
        let tiles = compute(
            "compute raster tiles",
            &shaders::RASTER_TILES_COMP,
            &Binding::storage_buffers(&RASTER_TILE_BINDINGS, stage),
            size_of::<TilePush>() as u32,
            &[slot_count],
        )?;
        let resolve = compute(
            "compute raster resolve",
            &shaders::RASTER_RESOLVE_COMP,
            &Binding::storage_buffers(&RESOLVE_BINDINGS, stage),
            size_of::<ResolvePush>() as u32,
            &[by_address],
        )?;
        let no_scene_depth = Buffer::new(ctx, "no scene depth", BufferDesc::storage(16))?;
        Ok(Self { raster, raster_stored, split, shade, tiles, resolve, no_scene_depth, loads, slots, fused })
    }

    /// What the fused-generation kernel draws of each strand ([`Self::new`]).
    pub fn fused_strands(&self) -> FusedStrands {
        self.fused
    }

    /// How the kernels read: what [`Self::new`] was asked for where the device allows it.
    pub fn load_path(&self) -> LoadPath {
        self.loads
    }

    /// The visibility slots per pixel the kernels were specialized for ([`Self::new`]; `None`:
    /// any).
    pub fn slots(&self) -> Option<u32> {
        self.slots
    }

    /// `address` (a device address) for a kernel's push constants when the kernels read
    /// through buffer references, else 0 (unused: they read through the bindings).
    pub(crate) fn load_address(&self, address: u64) -> u64 {
        match self.loads {
            LoadPath::BufferReferences => address,
            LoadPath::Bindings => 0,
        }
    }

    /// [`Self::load_address`] of `buffer`'s device address.
    pub(crate) fn buffer_address(&self, buffer: &Buffer) -> u64 {
        self.load_address(buffer.device_address())
    }
}

impl ComputeRaster {
    /// Rasterizes `stored` strands alone (no shading, no occluders) into fresh visibility and
    /// coverage buffers of `inputs.viewport`'s size and reads them back: the kernel as the
    /// tests compare it with its CPU port ([`crate::cpu::raster::raster_strand`]). `model` places the strands
    /// in the world (tangents are stored in world space). The kernel reads as
    /// [`Self::load_path`] says.
    pub fn rasterize_stored(
        &self,
        ctx: &Context,
        stored: &gen_gpu::StoredStrands,
        inputs: &gen_gpu::FrameInputs,
        model: Mat4,
        material: u32,
    ) -> gen_gpu::Result<crate::cpu::raster::RasterBuffers> {
        let [width, height] = inputs.viewport;
        let all = self.rasterize_stored_words(ctx, stored, inputs, model, material, 1, None, None)?;
        Ok(crate::cpu::raster::RasterBuffers {
            width,
            height,
            visibility: all.iter().step_by(2).copied().collect(),
            coverage: all.iter().skip(1).step_by(2).map(|&w| coverage_sum(w)).collect(),
        })
    }

    /// As [`Self::rasterize_stored`] with `k` visibility slots per pixel, returning the pixel
    /// words as the kernel leaves them ([`pixel_stride`] per pixel: the K slots, unordered for
    /// K > 1, the complemented coverage word, the threshold word). The kernel starts from
    /// `initial` when given (that many words: what earlier passes left), else from cleared
    /// words. `clipping` picks the kernel's variant; `None`: the one frames would take for the
    /// strands' bounds ([`DepthClipping::for_bounds`]).
    #[allow(clippy::too_many_arguments)]
    pub fn rasterize_stored_words(
        &self,
        ctx: &Context,
        stored: &gen_gpu::StoredStrands,
        inputs: &gen_gpu::FrameInputs,
        model: Mat4,
        material: u32,
        k: u32,
        initial: Option<&[u64]>,
        clipping: Option<DepthClipping>,
    ) -> gen_gpu::Result<Vec<u64>> {
        let [width, height] = inputs.viewport;
        let pixels = u64::from(width) * u64::from(height);
        let transfer = vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
        let bytes = pixels * pixel_stride(k) * 8;
        if self.slots.is_some_and(|slots| slots != k) {
            return Err(gen_gpu::GpuError::BadUpload {
                name: "visibility + coverage".into(),
                offset: 0,
                size: bytes,
                why: "not the slot count the kernels were specialized for",
            });
        }
        let desc = BufferDesc::storage(bytes).usage(transfer);
        let words = match initial {
            Some(initial) if initial.len() as u64 * 8 != bytes => {
                return Err(gen_gpu::GpuError::BadUpload {
                    name: "visibility + coverage".into(),
                    offset: 0,
                    size: initial.len() as u64 * 8,
                    why: "not the pixel words of the viewport and slots",
                });
            }
            Some(initial) => {
                ctx.create_buffer_with_data("visibility + coverage", desc, bytemuck::cast_slice(initial))?
            }
            None => Buffer::new(ctx, "visibility + coverage", desc)?,
        };
        let params = stored.frame_params(ctx, inputs)?;
        let extra = [
            (crate::contract::binding::VISIBILITY, &words),
            (crate::contract::binding::SCENE_DEPTH, &self.no_scene_depth),
            (crate::contract::binding::RASTER_TILES, &self.no_scene_depth),
        ];
        let clipping = clipping.unwrap_or_else(|| DepthClipping::for_bounds(inputs.view_proj, stored.bounds));
        let pipeline = self.raster_stored.get(clipping);
        ctx.submit("compute raster (stored strands)", |rec| {
            // (Initial words were written before the submission: visible to it.)
            if initial.is_none() {
                rec.fill_buffer(&words, u32::MAX);
                fills_to_compute(rec);
            }
            stored.record_compute(
                rec,
                pipeline,
                &params,
                &extra,
                stored_group_size(),
                SlotSubset::All,
                |rec, chunk| {
                    let mut push =
                        raster_push(model, material, chunk.slots, false, RasterPhase::ALL, 1, k, 1.0);
                    push.words_address = self.buffer_address(&words);
                    push.vertices_address = self.load_address(chunk.vertices_address);
                    // (Neither read with all slots in one phase and no occluders.)
                    let unread = self.buffer_address(&self.no_scene_depth);
                    (push.tiles_address, push.scene_depth_address) = (unread, unread);
                    rec.push_constants(pipeline, &push);
                },
            );
            compute_writes_to_readback(rec);
            Ok(())
        })?;
        let bytes = ctx.read_buffer(&words, bytes)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }
}
