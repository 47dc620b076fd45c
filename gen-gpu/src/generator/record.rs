//! Recording generation: the LOD and generate passes, the barriers after them for callers
//! without a frame graph, and the draws of generated strands.

use super::*;

impl Generator {
    /// Dispatches the bound compute pipeline over every live strand slot of a
    /// [`Self::prepare_fused`] frame (32 strands per workgroup, rows of `DISPATCH_ROW`
    /// workgroups), with the arguments [`Self::record_lod`] wrote.
    pub fn record_fused_dispatch(rec: &Recorder<'_>, frame: &FrameBuffers) {
        rec.dispatch_indirect(&frame.offsets, DISPATCH_ARGS_OFFSET);
    }

    /// [`Self::record_fused_dispatch`] over one [`SlotSubset`] of the live slots: the shader
    /// takes its slot from `invocation_subset_slot(subset, slot)` (`hair_outputs.glsl`) with the
    /// same `subset` (as `uint(SlotSubset)`, e.g. in a push constant).
    pub fn record_fused_subset_dispatch(rec: &Recorder<'_>, frame: &FrameBuffers, subset: SlotSubset) {
        match subset {
            SlotSubset::All => Self::record_fused_dispatch(rec, frame),
            SlotSubset::Sparse => rec.dispatch_indirect(&frame.offsets, SUBSET_DISPATCH_OFFSET),
            SlotSubset::Remainder => rec.dispatch_indirect(&frame.offsets, SUBSET_DISPATCH_OFFSET + 12),
        }
    }

    /// Compute path pass 1: LOD per bundle and the prefix sum with indirect arguments. What reads
    /// them must be ordered after it: by a frame graph, or by [`Self::barrier_after_lod`].
    pub fn record_lod(&self, rec: &mut Recorder<'_>, hair: &GpuHair, frame: &FrameBuffers) {
        let compute = (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE);
        let read = vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        rec.pass("LOD + cull", |rec| {
            rec.bind_pipeline(&self.lod);
            self.push_all(rec, &self.lod, hair, frame, 0, &[]);
            rec.dispatch(hair.bundle_count.div_ceil(shaders::LOD_COMP.workgroup_size[0]), 1, 1);
        });
        rec.memory_barrier(compute, (vk::PipelineStageFlags2::COMPUTE_SHADER, read));
        rec.pass("prefix sum", |rec| {
            rec.bind_pipeline(&self.scan);
            self.push_all(rec, &self.scan, hair, frame, 0, &[]);
            rec.dispatch(1, 1, 1);
        });
    }

    /// Makes [`Self::record_lod`]'s outputs (LOD, offsets, indirect arguments) visible to the
    /// generate pass and to draws. For callers without a frame graph (a graph derives this from
    /// the passes' declared reads and writes).
    pub fn barrier_after_lod(rec: &Recorder<'_>) {
        rec.memory_barrier(
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
            (
                vk::PipelineStageFlags2::DRAW_INDIRECT
                    | vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::VERTEX_SHADER
                    | vk::PipelineStageFlags2::TASK_SHADER_EXT
                    | vk::PipelineStageFlags2::MESH_SHADER_EXT,
                vk::AccessFlags2::INDIRECT_COMMAND_READ
                    | vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
    }

    /// Compute path pass 2: every strand's vertices into the strand buffer (ordered before its
    /// readers by a frame graph or [`Self::barrier_after_generate`]).
    pub fn record_generate(&self, rec: &mut Recorder<'_>, hair: &GpuHair, frame: &FrameBuffers) {
        rec.pass("generate (compute)", |rec| {
            rec.bind_pipeline(&self.generate);
            for chunk in 0..frame.chunks {
                self.push_all(rec, &self.generate, hair, frame, chunk, &[]);
                rec.push_constants(&self.generate, &(chunk as u32));
                rec.dispatch_indirect(&frame.offsets, DISPATCH_ARGS_OFFSET + 12 * chunk);
            }
        });
    }

    /// Makes [`Self::record_generate`]'s strands visible to vertex pulling and copies. For
    /// callers without a frame graph.
    pub fn barrier_after_generate(rec: &Recorder<'_>) {
        rec.memory_barrier(
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
            (
                vk::PipelineStageFlags2::VERTEX_SHADER
                    | vk::PipelineStageFlags2::COPY
                    | vk::PipelineStageFlags2::HOST,
                vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::TRANSFER_READ
                    | vk::AccessFlags2::HOST_READ,
            ),
        );
    }

    /// Draws the strands inside a rendering scope begun by the caller (colour
    /// [`COLOR_FORMAT`], depth [`DEPTH_FORMAT`]). The compute path expects
    /// [`Self::record_lod`] and [`Self::record_generate`] earlier in the command buffer; the
    /// mesh path generates here.
    pub fn record_draw(
        &self,
        rec: &mut Recorder<'_>,
        hair: &GpuHair,
        frame: &FrameBuffers,
        path: GenerationPath,
        capture: bool,
    ) -> Result<()> {
        self.record_draw_with(rec, hair, frame, path, capture, DrawExtras::default())
    }

    /// [`Self::record_draw`] with the fragment stage's push constants (at
    /// [`FRAGMENT_PUSH_OFFSET`]) and buffers.
    pub fn record_draw_with(
        &self,
        rec: &mut Recorder<'_>,
        hair: &GpuHair,
        frame: &FrameBuffers,
        path: GenerationPath,
        capture: bool,
        extras: DrawExtras<'_>,
    ) -> Result<()> {
        let fragment_constants = extras.fragment_constants;
        match path {
            GenerationPath::Compute => {
                rec.bind_pipeline(&self.pull);
                for chunk in 0..frame.chunks {
                    self.push_all(rec, &self.pull, hair, frame, chunk, extras.buffers);
                    rec.push_constants(&self.pull, &(chunk as u32));
                    rec.push_constant_bytes(&self.pull, FRAGMENT_PUSH_OFFSET, fragment_constants);
                    rec.draw_indirect(&frame.offsets, DRAW_ARGS_OFFSET + 16 * chunk);
                }
                Ok(())
            }
            GenerationPath::Mesh => {
                let pipeline = if capture { self.mesh_capture.as_ref() } else { self.mesh.as_ref() };
                let pipeline = pipeline.ok_or_else(|| GpuError::MeshShaderUnsupported {
                    requested: "mesh",
                    device: self.mesh_unavailable.clone().unwrap_or_default(),
                })?;
                let limits = rec
                    .ctx()
                    .capabilities()
                    .mesh_shader
                    .ok_or(GpuError::MeshShaderUnsupported { requested: "mesh", device: String::new() })?;
                // One task workgroup per bundle, in rows within maxTaskWorkGroupCount
                // (lavapipe does not check it; real GPUs fail).
                let per_row = hair.bundle_count.clamp(1, limits.max_task_work_group_count[0]);
                let rows = hair.bundle_count.div_ceil(per_row);
                if rows > limits.max_task_work_group_count[1]
                    || u64::from(per_row) * u64::from(rows)
                        > u64::from(limits.max_task_work_group_total_count)
                {
                    return Err(GpuError::OverBudget {
                        name: "task workgroups".into(),
                        requested: u64::from(hair.bundle_count),
                        budget: u64::from(limits.max_task_work_group_total_count),
                        why: "maxTaskWorkGroupCount",
                    });
                }
                if capture && frame.chunks > 1 {
                    return Err(GpuError::OverBudget {
                        name: "mesh-path capture".into(),
                        requested: frame.capacity,
                        budget: frame.chunk_slots,
                        why: "the mesh path captures one chunk of strand slots; use the compute path",
                    });
                }
                rec.bind_pipeline(pipeline);
                self.push_all(rec, pipeline, hair, frame, 0, extras.buffers);
                rec.push_constants(pipeline, &per_row);
                rec.push_constant_bytes(pipeline, FRAGMENT_PUSH_OFFSET, fragment_constants);
                rec.draw_mesh_tasks(per_row, rows, 1)
            }
        }
    }
}
