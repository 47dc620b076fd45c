//! A frame's generation inputs and buffers: the view and LOD a frame is generated for, the
//! per-frame buffers, and the parameters and bindings its passes read.

use super::*;

/// What one frame generates for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameInputs {
    /// Object space → clip space (Vulkan clip: z ∈ [0, w]).
    pub view_proj: Mat4,
    /// Camera for LOD, in object space (f64, as the CPU reference takes it).
    pub view: ViewParams,
    pub lod: LodParams,
    pub viewport: [u32; 2],
    /// Frustum-cull bundles against `view_proj` (on by default).
    pub cull: bool,
}

/// The view matrix (right-handed) of an eye at `eye` looking at `target`, with world +Y up on
/// screen. Looking straight up or down, +Y is the viewing direction and cannot be "up": then
/// the screen's up is −Z looking down and +Z looking up (a top view with −Z at the top, as a
/// map). `eye == target` looks down −Z.
pub fn view_matrix(eye: Vec3, target: Vec3) -> Mat4 {
    let forward = (target - eye).try_normalize().unwrap_or(Vec3::NEG_Z);
    let up = if forward.cross(Vec3::Y).length_squared() > 1e-8 {
        Vec3::Y
    } else {
        Vec3::new(0.0, 0.0, -forward.y.signum())
    };
    Mat4::look_to_rh(eye, forward, up)
}

impl FrameInputs {
    /// A perspective camera at `eye` looking at the asset's centre (45° vertical field of view).
    pub fn looking_at(asset: &HairAsset, eye: Vec3, width: u32, height: u32) -> Self {
        let (lo, hi) = asset.bounds();
        let centre = (0.5 * (lo + hi)).as_vec3();
        let fov_y = 45f32.to_radians();
        let far = (eye.distance(centre) + (hi - lo).length() as f32) * 2.0;
        let proj = Mat4::perspective_rh(fov_y, width as f32 / height.max(1) as f32, far * 1e-4, far);
        // Vulkan's y points down in clip space.
        let flip = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
        let view = view_matrix(eye, centre);
        Self {
            view_proj: flip * proj * view,
            view: ViewParams {
                eye: eye.as_dvec3(),
                vertical_resolution: f64::from(height),
                projection: Projection::Perspective { fov_y: f64::from(fov_y) },
            },
            lod: LodParams::default(),
            viewport: [width, height],
            cull: true,
        }
    }
}

/// `GenParams` in `hair_gen.glsl` (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GenParams {
    view_proj: [f32; 16],
    eye: [f32; 4],
    projection: [f32; 4],
    lod: [f32; 4],
    counts: [u32; 4],
    normalization: [f32; 4],
    layout_info: [u32; 4],
    style0: [f32; 4],
    curl: [f32; 4],
    wave_frizz: [f32; 4],
    frizz_clump: [f32; 4],
    /// Stray fraction, stray amplitude, wave coherence, -.
    stray: [f32; 4],
    seed_info: [u32; 4],
    viewport: [f32; 4],
    lod_error: [f32; 4],
    /// The head's distance field: xyz its grid's origin, w its cell (0: no field).
    head_field: [f32; 4],
    /// x: the margin strands keep from the head; yzw: -.
    head_margin: [f32; 4],
}

/// Per-frame buffers, sized from the LOD result.
#[derive(Debug)]
pub struct FrameBuffers {
    pub(super) params: Buffer,
    pub(super) lods: Buffer,
    pub(super) offsets: Buffer,
    pub(super) strand_vertices: Buffer,
    pub(super) strand_info: Buffer,
    pub(super) capacity: u64,
    /// Slots per chunk: one chunk's vertex window fits the device's storage-buffer range.
    pub(super) chunk_slots: u64,
    pub(super) chunks: u64,
}

impl FrameBuffers {
    /// Chunks the strand slots are generated and drawn in.
    pub fn chunks(&self) -> u64 {
        self.chunks
    }
}

/// The per-frame buffers every frame has (parameters, LOD per bundle, offsets and indirect
/// arguments), around the strand buffers the caller sized.
pub(super) fn frame_buffers(
    ctx: &Context,
    hair: &GpuHair,
    params: GenParams,
    strands: (Buffer, Buffer),
    (capacity, chunk_slots, chunks): (u64, u64, u64),
) -> Result<FrameBuffers> {
    let params = ctx.create_buffer_with_data(
        "generation parameters",
        BufferDesc::storage(size_of::<GenParams>() as u64).location(MemoryLocation::CpuToGpu),
        bytemuck::bytes_of(&params),
    )?;
    let bundles = u64::from(hair.bundle_count);
    let indirect = vk::BufferUsageFlags::INDIRECT_BUFFER;
    Ok(FrameBuffers {
        params,
        lods: Buffer::new(ctx, "bundle LOD", BufferDesc::storage(bundles * 16))?,
        offsets: Buffer::new(
            ctx,
            "strand offsets",
            BufferDesc::storage(OFFSETS_HEADER + bundles * 4).usage(indirect),
        )?,
        strand_vertices: strands.0,
        strand_info: strands.1,
        capacity,
        chunk_slots,
        chunks,
    })
}

/// Parameters with only the view filled in (stored strands have no asset).
pub(crate) fn view_only_params(inputs: &FrameInputs, chunk_slots: u64) -> GenParams {
    let e = inputs.view.eye.as_vec3();
    let (tan_half, ortho_half, ortho) = match inputs.view.projection {
        Projection::Perspective { fov_y } => ((0.5 * fov_y).tan() as f32, 0.0, 0.0),
        Projection::Orthographic { height } => (0.0, 0.5 * height as f32, 1.0),
    };
    let mut p: GenParams = bytemuck::Zeroable::zeroed();
    p.view_proj = inputs.view_proj.to_cols_array();
    p.eye = [e.x, e.y, e.z, inputs.view.vertical_resolution as f32];
    p.projection = [tan_half, ortho_half, ortho, 0.0];
    p.seed_info = [0, 0, u32::MAX, chunk_slots as u32];
    p.viewport = [inputs.viewport[0] as f32, inputs.viewport[1] as f32, 0.0, 0.0];
    p
}

pub(super) fn params(hair: &GpuHair, inputs: &FrameInputs, capacity: u64, chunk_slots: u64) -> GenParams {
    let asset = &hair.asset;
    let t = &asset.textures;
    let s = &asset.style;
    let (tan_half, ortho_half, ortho) = match inputs.view.projection {
        Projection::Perspective { fov_y } => ((0.5 * fov_y).tan() as f32, 0.0, 0.0),
        Projection::Orthographic { height } => (0.0, 0.5 * height as f32, 1.0),
    };
    let lod = &inputs.lod;
    let e = inputs.view.eye.as_vec3();
    let n = t.normalization;
    let f = |v: f64| v as f32;
    GenParams {
        view_proj: inputs.view_proj.to_cols_array(),
        eye: [e.x, e.y, e.z, f(inputs.view.vertical_resolution)],
        projection: [tan_half, ortho_half, ortho, if inputs.cull { 1.0 } else { 0.0 }],
        lod: [
            if lod.enabled { 1.0 } else { 0.0 },
            f(lod.strand_alpha),
            f(lod.vertex_alpha),
            f(lod.morph_band),
        ],
        counts: [
            hair.bundle_count,
            lod.max_segments_log2.min(crate::contract::MAX_SEGMENTS_LOG2),
            asset.square_sets.len() as u32,
            asset.triangle_sets.len() as u32,
        ],
        normalization: [f(n.origin.x), f(n.origin.y), f(n.origin.z), f(n.scale)],
        layout_info: [0, t.layout.width, t.layout.height, t.layout.layers],
        style0: [f(s.width), f(s.tip_width), f(s.root_fade), f(s.length_variation)],
        curl: [f(s.curl.radius), f(s.curl.frequency), f(s.curl.phase), 0.0],
        wave_frizz: [f(s.wave.amplitude), f(s.wave.frequency), f(s.frizz.amplitude), f(s.frizz.frequency)],
        frizz_clump: [f(s.frizz.exponent), f(s.clump.strength), f(s.clump.exponent), f(s.twist)],
        stray: [f(s.stray.fraction), f(s.stray.amplitude), f(s.wave.coherence), 0.0],
        seed_info: [
            s.seed,
            asset.square_sets.len() as u32,
            capacity.min(u64::from(u32::MAX)) as u32,
            chunk_slots as u32,
        ],
        viewport: [inputs.viewport[0] as f32, inputs.viewport[1] as f32, 0.0, 0.0],
        lod_error: [f(lod.vertex_error_pixels), 0.0, 0.0, 0.0],
        head_field: asset
            .head_field
            .as_ref()
            .map_or([0.0; 4], |h| [f(h.lo.x), f(h.lo.y), f(h.lo.z), f(h.cell)]),
        head_margin: [asset.head_field.as_ref().map_or(0.0, |h| f(h.margin)), 0.0, 0.0, 0.0],
    }
}

impl Generator {
    /// Allocates the frame buffers for `inputs` and writes the frame parameters.
    pub fn prepare(&self, ctx: &Context, hair: &GpuHair, inputs: &FrameInputs) -> Result<FrameBuffers> {
        let capacity = Self::capacity(hair, inputs);
        let caps = ctx.capabilities();
        let chunk_slots = chunk_slots(caps, self.options.max_chunk_slots);
        let chunks = capacity.div_ceil(chunk_slots);
        let vertex_bytes = capacity * SLOT_BYTES;
        if chunks > MAX_CHUNKS || vertex_bytes > 1 << 31 {
            return Err(GpuError::OverBudget {
                name: "generated strand vertices".into(),
                requested: vertex_bytes,
                budget: (MAX_CHUNKS * chunk_slots * SLOT_BYTES).min(1 << 31),
                why: "at most 16 chunks of the storage-buffer range and 2 GiB per frame buffer; raise the LOD α or split the character",
            });
        }
        let strands = (
            Buffer::new(ctx, "strand vertices", BufferDesc::storage(vertex_bytes))?,
            Buffer::new(ctx, "strand info", BufferDesc::storage(capacity * 16))?,
        );
        let params = params(hair, inputs, capacity, chunk_slots);
        frame_buffers(ctx, hair, params, strands, (capacity, chunk_slots, chunks))
    }

    /// Frame buffers for a consumer that generates inside its own shader (fused generation,
    /// e.g. the compute rasterizer): the parameters, LOD and offsets only — no strand buffer, so
    /// the memory does not grow with the strand count. Every live strand slot is in chunk 0:
    /// [`Self::record_lod`] writes its dispatch (one invocation per strand, 32 per workgroup),
    /// which [`Self::record_fused_dispatch`] runs.
    pub fn prepare_fused(&self, ctx: &Context, hair: &GpuHair, inputs: &FrameInputs) -> Result<FrameBuffers> {
        let capacity = hair.total_strands.max(1);
        // Bound but never written: fused consumers keep vertices in registers.
        let strands = (
            Buffer::new(ctx, "strand vertices (unused)", BufferDesc::storage(SLOT_BYTES))?,
            Buffer::new(ctx, "strand info (unused)", BufferDesc::storage(16))?,
        );
        // All live slots in chunk 0 of the shaders' view (`chunk_slots = capacity`); the host
        // side binds the one-slot windows above.
        frame_buffers(ctx, hair, params(hair, inputs, capacity, capacity), strands, (1, 1, 1))
    }

    /// Binds `frame` and `hair` (set 0, chunk 0) plus `extra` consumer buffers for `pipeline`,
    /// a consumer pipeline created with [`strand_bindings`].
    pub fn bind_frame(
        &self,
        rec: &Recorder<'_>,
        pipeline: &Pipeline,
        hair: &GpuHair,
        frame: &FrameBuffers,
        extra: &[(u32, &Buffer)],
    ) {
        self.push_all(rec, pipeline, hair, frame, 0, extra);
    }

    /// Binds everything, with chunk `chunk`'s windows of the strand buffers and the fragment
    /// stage's own buffers.
    pub(super) fn push_all(
        &self,
        rec: &Recorder<'_>,
        pipeline: &Pipeline,
        hair: &GpuHair,
        frame: &FrameBuffers,
        chunk: u64,
        extra: &[(u32, &Buffer)],
    ) {
        use crate::contract::binding as b;
        let whole = vk::WHOLE_SIZE;
        let first = chunk * frame.chunk_slots;
        let slots = frame.chunk_slots.min(frame.capacity - first.min(frame.capacity)).max(1);
        let mut buffers = vec![
            (b::GEN_PARAMS, &frame.params, 0, whole),
            (b::BUNDLES, &hair.bundles, 0, whole),
            (b::ROOT_SAMPLES, &hair.samples, 0, whole),
            (b::SAMPLE_SETS, &hair.sample_sets, 0, whole),
            (b::BUNDLE_LODS, &frame.lods, 0, whole),
            (b::STRAND_OFFSETS, &frame.offsets, 0, whole),
            (b::STRAND_VERTICES, &frame.strand_vertices, first * SLOT_BYTES, slots * SLOT_BYTES),
            (b::STRAND_INFO, &frame.strand_info, first * 16, slots * 16),
        ];
        buffers.extend(extra.iter().map(|(b, buf)| (*b, *buf, 0, whole)));
        rec.push_descriptors_ranged(
            pipeline,
            &buffers,
            &[
                (b::HAIR_MESH_TEXTURE, &hair.hair_mesh, &hair.sampler),
                (b::U_TEXTURE, &hair.u, &hair.sampler),
                (b::V_TEXTURE, &hair.v, &hair.sampler),
                (b::HEAD_FIELD, &hair.head_field, &hair.sampler),
            ],
        );
    }
}

#[cfg(test)]
mod tests {
    use super::view_matrix;
    use glam::Vec3;

    /// The target lies straight ahead (−Z in view space) from every direction, the poles
    /// included, and the matrix stays a rotation.
    #[test]
    fn the_view_is_well_defined_from_every_direction() {
        let target = Vec3::new(0.0, 1.5, 0.0);
        for dir in
            [Vec3::Y, Vec3::NEG_Y, Vec3::X, Vec3::Z, Vec3::new(1e-6, 1.0, 0.0), Vec3::new(0.0, -1.0, 1e-7)]
        {
            let eye = target + dir * 2.0;
            let view = view_matrix(eye, target);
            assert!(view.is_finite(), "{dir}: {view}");
            let ahead = view.transform_point3(target);
            assert!(ahead.truncate().length() < 1e-4 && (ahead.z + 2.0).abs() < 1e-4, "{dir}: {ahead}");
            assert!((view.determinant() - 1.0).abs() < 1e-4, "{dir}: not a rotation");
        }
        assert!(view_matrix(target, target).is_finite());
    }
}
