//! Explicit strands (an artist's groom from a strand file, or strands captured once) drawn by
//! the same vertex-pulling pipeline and fragment stage as generated hair: the stored-strand
//! path of the renderer and the baseline of the benchmarks.

use glam::Vec3;

use crate::generator::{
    DRAW_ARGS_OFFSET, FRAGMENT_PUSH_OFFSET, MAX_CHUNKS, MAX_VERTICES, SLOT_BYTES, chunk_slots,
};
use crate::{Buffer, BufferDesc, Context, DrawExtras, FrameInputs, GpuError, Recorder, Result, SlotSubset};

/// One chunk of [`StoredStrands::record_compute`]'s dispatches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StoredChunk {
    /// Strand slots in the chunk (the bound window of the strand buffers).
    pub slots: u32,
    /// Device address of the chunk's first vertex (0 where the device has no buffer device
    /// addresses): kernels may load the vertices through a buffer reference.
    pub vertices_address: u64,
}

/// Strands uploaded once, in the generator's strand-buffer layout.
#[derive(Debug)]
pub struct StoredStrands {
    pub(crate) vertices: Buffer,
    pub(crate) info: Buffer,
    pub(crate) offsets: Buffer,
    pub(crate) chunk_slots: u64,
    pub(crate) chunks: u64,
    pub strands: u64,
    pub vertices_total: u64,
    /// Object-space bounds of all points.
    pub bounds: (Vec3, Vec3),
    /// Bytes on the GPU.
    pub bytes: u64,
}

impl StoredStrands {
    /// Uploads strands given as consecutive points (`strand_points[i]` points each). Strands
    /// of more than 33 points are resampled to 33 (evenly by index); strands of fewer than 2
    /// are skipped. `width` is the root width, tapering to `tip_width` × width.
    pub fn upload(
        ctx: &Context,
        points: &[Vec3],
        strand_points: &[u32],
        width: f32,
        tip_width: f32,
    ) -> Result<Self> {
        let mut vertex_data: Vec<[f32; 8]> = Vec::new();
        let mut info: Vec<[u32; 4]> = Vec::new();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let mut at = 0usize;
        for &n in strand_points {
            let n = n as usize;
            let strand = points
                .get(at..at + n)
                .ok_or_else(|| GpuError::Mismatch("strand point counts exceed the points".into()))?;
            at += n;
            if n < 2 {
                continue;
            }
            let keep = n.min(MAX_VERTICES as usize);
            let resampled: Vec<Vec3> = (0..keep).map(|k| strand[k * (n - 1) / (keep - 1)]).collect();
            // The reference generator's Eq. 5–6, so stored and generated strands agree.
            let as_f64: Vec<glam::DVec3> = resampled.iter().map(|p| p.as_dvec3()).collect();
            let t: Vec<Vec3> = hairmesh::reference::tangents(&as_f64).iter().map(|t| t.as_vec3()).collect();
            let slot = info.len() as u32;
            for k in 0..MAX_VERTICES as usize {
                let v = if k < keep {
                    let tau = k as f32 / (keep - 1) as f32;
                    let p = resampled[k];
                    lo = lo.min(p);
                    hi = hi.max(p);
                    [p.x, p.y, p.z, width * (1.0 + (tip_width - 1.0) * tau), t[k].x, t[k].y, t[k].z, tau]
                } else {
                    [0.0; 8]
                };
                vertex_data.push(v);
            }
            info.push([slot, 0, keep as u32, 1f32.to_bits()]);
        }
        let strands = info.len() as u64;
        if strands == 0 {
            return Err(GpuError::Mismatch("no strand has two or more points".into()));
        }
        let chunk_slots = chunk_slots(ctx.capabilities(), None);
        let chunks = strands.div_ceil(chunk_slots);
        if chunks > MAX_CHUNKS || strands * SLOT_BYTES > 1 << 31 {
            return Err(GpuError::OverBudget {
                name: "stored strands".into(),
                requested: strands * SLOT_BYTES,
                budget: (MAX_CHUNKS * chunk_slots * SLOT_BYTES).min(1 << 31),
                why: "16 chunks of the storage-buffer range, 2 GiB in all",
            });
        }
        // The draw records the generator's pulling pass reads, one per chunk.
        let mut offsets = vec![0u32; (DRAW_ARGS_OFFSET / 4 + MAX_CHUNKS * 4) as usize];
        offsets[0] = strands as u32;
        offsets[1] = strands as u32;
        for c in 0..chunks {
            let slots = (strands - c * chunk_slots).min(chunk_slots);
            let base = (DRAW_ARGS_OFFSET / 4 + 4 * c) as usize;
            offsets[base] = (MAX_VERTICES as u32 - 1) * 6;
            offsets[base + 1] = slots as u32;
        }
        let indirect = ash::vk::BufferUsageFlags::INDIRECT_BUFFER;
        let vbytes: &[u8] = bytemuck::cast_slice(&vertex_data);
        let ibytes: &[u8] = bytemuck::cast_slice(&info);
        let obytes: &[u8] = bytemuck::cast_slice(&offsets);
        Ok(Self {
            vertices: ctx.create_buffer_with_data(
                "stored strand vertices",
                BufferDesc::storage(vbytes.len() as u64),
                vbytes,
            )?,
            info: ctx.create_buffer_with_data(
                "stored strand info",
                BufferDesc::storage(ibytes.len() as u64),
                ibytes,
            )?,
            offsets: ctx.create_buffer_with_data(
                "stored strand draws",
                BufferDesc::storage(obytes.len() as u64).usage(indirect),
                obytes,
            )?,
            chunk_slots,
            chunks,
            strands,
            vertices_total: vertex_data.len() as u64,
            bounds: (lo, hi),
            bytes: (vbytes.len() + ibytes.len() + obytes.len()) as u64,
        })
    }
}

impl StoredStrands {
    /// The frame parameters for drawing these strands (view, viewport; no hair asset).
    pub fn frame_params(&self, ctx: &Context, inputs: &FrameInputs) -> Result<Buffer> {
        let params = crate::generator::view_only_params(inputs, self.chunk_slots);
        ctx.create_buffer_with_data(
            "stored strand parameters",
            BufferDesc::storage(size_of_val(&params) as u64).location(crate::MemoryLocation::CpuToGpu),
            bytemuck::bytes_of(&params),
        )
    }

    /// Runs `pipeline` (a compute consumer created with [`crate::strand_bindings`]) over these
    /// strands, one chunk window at a time: binds `params`, the chunk's vertices and info and
    /// `extra`, calls `per_chunk` with the chunk (its slot count and vertices' address, to push
    /// constants), then
    /// dispatches one invocation per slot of `subset` in workgroups of `group_size`: with
    /// [`SlotSubset::All`] invocation i draws slot i; otherwise the shader takes its slot
    /// (relative to the chunk window) from `subset_slot(subset, gl_GlobalInvocationID.x)`
    /// (`hair_outputs.glsl`) and skips slots past the chunk's count.
    #[allow(
        clippy::too_many_arguments,
        reason = "the binding inputs, the dispatch shape and the push callback"
    )]
    pub fn record_compute(
        &self,
        rec: &Recorder<'_>,
        pipeline: &crate::Pipeline,
        params: &Buffer,
        extra: &[(u32, &Buffer)],
        group_size: u32,
        subset: SlotSubset,
        mut per_chunk: impl FnMut(&Recorder<'_>, StoredChunk),
    ) {
        use crate::contract::binding as b;
        let whole = ash::vk::WHOLE_SIZE;
        rec.bind_pipeline(pipeline);
        for chunk in 0..self.chunks {
            let first = chunk * self.chunk_slots;
            let slots = self.chunk_slots.min(self.strands - first);
            let mut buffers = vec![
                (b::GEN_PARAMS, params, 0, whole),
                (b::STRAND_OFFSETS, &self.offsets, 0, whole),
                (b::STRAND_VERTICES, &self.vertices, first * SLOT_BYTES, slots * SLOT_BYTES),
                (b::STRAND_INFO, &self.info, first * 16, slots * 16),
            ];
            buffers.extend(extra.iter().map(|(b, buf)| (*b, *buf, 0, whole)));
            rec.push_descriptors_ranged(pipeline, &buffers, &[]);
            let base = self.vertices.device_address();
            let vertices_address = if base == 0 { 0 } else { base + first * SLOT_BYTES };
            per_chunk(rec, StoredChunk { slots: slots as u32, vertices_address });
            rec.dispatch(subset.count(slots as u32).div_ceil(group_size.max(1)), 1, 1);
        }
    }

    /// Draws these strands with `generator`'s pulling pipeline and fragment stage (the same
    /// draw as generated hair), inside a rendering scope begun by the caller.
    pub fn record_draw(
        &self,
        rec: &mut Recorder<'_>,
        generator: &crate::Generator,
        params: &Buffer,
        extras: DrawExtras<'_>,
    ) {
        let stored = self;
        let pipeline = generator.pull_pipeline();
        rec.bind_pipeline(pipeline);
        let whole = ash::vk::WHOLE_SIZE;
        for chunk in 0..stored.chunks {
            let first = chunk * stored.chunk_slots;
            let slots = stored.chunk_slots.min(stored.strands - first);
            use crate::contract::binding as b;
            let mut buffers = vec![
                (b::GEN_PARAMS, params, 0, whole),
                (b::STRAND_OFFSETS, &stored.offsets, 0, whole),
                (b::STRAND_VERTICES, &stored.vertices, first * SLOT_BYTES, slots * SLOT_BYTES),
                (b::STRAND_INFO, &stored.info, first * 16, slots * 16),
            ];
            buffers.extend(extras.buffers.iter().map(|(b, buf)| (*b, *buf, 0, whole)));
            rec.push_descriptors_ranged(pipeline, &buffers, &[]);
            rec.push_constants(pipeline, &(chunk as u32));
            rec.push_constant_bytes(pipeline, FRAGMENT_PUSH_OFFSET, extras.fragment_constants);
            rec.draw_indirect(&stored.offsets, DRAW_ARGS_OFFSET + 16 * chunk);
        }
    }
}
