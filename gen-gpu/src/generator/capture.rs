//! Reading generated strands back (tests and tools) and counting what a frame generated.

use super::*;

/// One generated strand read back from the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct CapturedStrand {
    pub bundle: u32,
    pub index: u32,
    pub positions: Vec<Vec3>,
    pub tangents: Vec<Vec3>,
    pub widths: Vec<f32>,
}

/// What a capture produced.
#[derive(Clone, Debug)]
pub struct Capture {
    pub strands: Vec<CapturedStrand>,
    pub stats: GenerationStats,
    pub timings: FrameTimings,
}

/// Counts of one generation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GenerationStats {
    pub bundles: u32,
    pub bundles_culled: u32,
    pub strands: u64,
    pub vertices: u64,
}

impl std::ops::AddAssign for GenerationStats {
    /// Totals over several characters.
    fn add_assign(&mut self, other: Self) {
        self.bundles += other.bundles;
        self.bundles_culled += other.bundles_culled;
        self.strands += other.strands;
        self.vertices += other.vertices;
    }
}

pub(super) fn read_strands(ctx: &Context, frame: &FrameBuffers) -> Result<Vec<CapturedStrand>> {
    let header: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.offsets, 8)?);
    let count = u64::from(header[0]).min(frame.capacity);
    let info: Vec<[u32; 4]> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.strand_info, count * 16)?);
    let vertices: Vec<[f32; 8]> = bytemuck::pod_collect_to_vec(
        &ctx.read_buffer(&frame.strand_vertices, count * MAX_VERTICES * VERTEX_BYTES)?,
    );
    Ok(info
        .iter()
        .enumerate()
        .map(|(slot, &[bundle, index, n, _])| {
            let v = &vertices[slot * MAX_VERTICES as usize..][..(n as usize).min(MAX_VERTICES as usize)];
            CapturedStrand {
                bundle,
                index,
                positions: v.iter().map(|x| Vec3::new(x[0], x[1], x[2])).collect(),
                widths: v.iter().map(|x| x[3]).collect(),
                tangents: v.iter().map(|x| Vec3::new(x[4], x[5], x[6])).collect(),
            }
        })
        .collect())
}

impl Generator {
    /// Generates through `path`, drawing into a small offscreen target, and reads back every
    /// generated strand (the mesh path under its capture specialization).
    pub fn capture(
        &self,
        ctx: &Context,
        hair: &GpuHair,
        inputs: &FrameInputs,
        path: GenerationPath,
    ) -> Result<Capture> {
        let frame = self.prepare(ctx, hair, inputs)?;
        let target = crate::RenderTarget::new(ctx, 64, 64)?;
        let ((), timings) = ctx.submit(&format!("capture ({path})"), |rec| {
            self.record_lod(rec, hair, &frame);
            Self::barrier_after_lod(rec);
            if path == GenerationPath::Compute {
                self.record_generate(rec, hair, &frame);
                Self::barrier_after_generate(rec);
            }
            target.begin(rec);
            let drawn =
                rec.pass(&format!("draw ({path})"), |rec| self.record_draw(rec, hair, &frame, path, true));
            rec.end_rendering();
            drawn
        })?;
        let strands = read_strands(ctx, &frame)?;
        let stats = self.stats(ctx, hair, &frame)?;
        Ok(Capture { strands, stats, timings })
    }

    /// Counts of the last generation into `frame`.
    pub fn stats(&self, ctx: &Context, hair: &GpuHair, frame: &FrameBuffers) -> Result<GenerationStats> {
        let header: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.offsets, 8)?);
        let lods: Vec<[u32; 4]> =
            bytemuck::pod_collect_to_vec(&ctx.read_buffer(&frame.lods, u64::from(hair.bundle_count) * 16)?);
        let vertices = lods.iter().map(|l| u64::from(l[0]) * ((1u64 << l[1]) + 1)).sum();
        Ok(GenerationStats {
            bundles: hair.bundle_count,
            bundles_culled: lods.iter().filter(|l| l[0] == 0).count() as u32,
            strands: u64::from(header[0]),
            vertices,
        })
    }
}
