//! Device self-checks: an exact compute pattern and a strip pattern drawn by both generation
//! paths. They prove the plumbing (dispatch, push descriptors, task/mesh pipelines, vertex
//! pulling, readback, timing) on a device before real hair is drawn, and back `hairkit demo`.

use crate::contract::binding::DIAGNOSTIC_OUTPUT;
use ash::vk;

use crate::{
    Binding, Buffer, BufferDesc, COLOR_FORMAT, ComputePipelineDesc, Context, DEPTH_FORMAT, FrameTimings,
    GenerationPath, GpuError, GraphicsPipelineDesc, GraphicsStages, Image, ImageDesc, MemoryLocation,
    Pipeline, RenderTarget, Result, RgbaImage, shaders,
};

/// The hash `pattern.comp` writes, for checking its output exactly on the CPU.
pub fn wang_hash(mut x: u32) -> u32 {
    x = (x ^ 61) ^ (x >> 16);
    x = x.wrapping_mul(9);
    x ^= x >> 4;
    x = x.wrapping_mul(0x27d4_eb2d);
    x ^ (x >> 15)
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PatternParams {
    count: u32,
    seed: u32,
}

/// Runs `pattern.comp` over `count` values and reads them back.
pub fn write_pattern(ctx: &Context, count: u32, seed: u32) -> Result<Vec<u32>> {
    let pipeline = Pipeline::compute(
        ctx,
        &ComputePipelineDesc {
            name: "pattern",
            shader: &shaders::PATTERN_COMP,
            bindings: &[Binding::storage_buffer(DIAGNOSTIC_OUTPUT, vk::ShaderStageFlags::COMPUTE)],
            push_constant_size: size_of::<PatternParams>() as u32,
            specialization: &[],
        },
    )?;
    let bytes = u64::from(count.max(1)) * 4;
    let out = Buffer::new(ctx, "pattern output", BufferDesc::storage(bytes))?;
    let group = shaders::PATTERN_COMP.workgroup_size[0];
    ctx.submit("pattern", |rec| {
        rec.pass("write pattern", |rec| {
            rec.bind_pipeline(&pipeline);
            rec.push_storage_buffers(&pipeline, &[(DIAGNOSTIC_OUTPUT, &out)]);
            rec.push_constants(&pipeline, &PatternParams { count, seed });
            rec.dispatch(count.div_ceil(group), 1, 1);
        });
        Ok(())
    })?;
    let data = ctx.read_buffer(&out, u64::from(count) * 4)?;
    Ok(bytemuck::pod_collect_to_vec(&data))
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TestStripParams {
    strand_count: u32,
    aspect: f32,
    width: f32,
    pad: u32,
}

/// Points per test strand (`TEST_STRIP_POINTS` in `test_strips.glsl`).
pub const TEST_STRIP_POINTS: u32 = 17;
const STRANDS_PER_TASK_GROUP: u32 = 32;

/// Draws `strands` synthetic strips into a `width`×`height` image through `path`.
pub fn draw_test_strips(
    ctx: &Context,
    path: GenerationPath,
    strands: u32,
    width: u32,
    height: u32,
) -> Result<(RgbaImage, FrameTimings)> {
    let caps = ctx.capabilities();
    let params = TestStripParams {
        strand_count: strands,
        aspect: width as f32 / height.max(1) as f32,
        // About 60% coverage across the pattern, whatever the strand count.
        width: (1.2 / strands.max(1) as f32).min(0.02),
        pad: 0,
    };
    let color = Image::new(
        ctx,
        "test strips colour",
        ImageDesc::d2(
            width,
            height,
            COLOR_FORMAT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
        ),
    )?;
    let depth = Image::new(
        ctx,
        "test strips depth",
        ImageDesc::d2(width, height, DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT),
    )?;
    let readback = Buffer::new(
        ctx,
        "test strips readback",
        BufferDesc {
            size: u64::from(width) * u64::from(height) * 4,
            usage: vk::BufferUsageFlags::TRANSFER_DST,
            location: MemoryLocation::GpuToCpu,
        },
    )?;
    let draw_bindings = [Binding::storage_buffer(DIAGNOSTIC_OUTPUT, vk::ShaderStageFlags::VERTEX)];
    let graphics = |name, stages, bindings| {
        Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name,
                stages,
                fragment: &shaders::FLAT_COLOR_FRAG,
                bindings,
                push_constant_size: size_of::<TestStripParams>() as u32,
                specialization: &[],
                color_format: COLOR_FORMAT,
                depth_format: Some(DEPTH_FORMAT),
                blend: crate::Blend::Replace,
                depth_write: true,
                color_write: true,
                samples: 1,
                depth_compare: vk::CompareOp::LESS,
            },
        )
    };

    // Path-specific objects, created before recording.
    enum Prepared {
        Mesh { draw: Pipeline, task_groups: u32 },
        // Boxed: a Buffer is large next to the mesh variant.
        Compute { generate: Pipeline, draw: Pipeline, vertices: Box<Buffer> },
    }
    let prepared = match path {
        GenerationPath::Mesh => {
            let limits = caps.mesh_shader.ok_or_else(|| GpuError::MeshShaderUnsupported {
                requested: "mesh",
                device: caps.device_name.clone(),
            })?;
            let task_groups = strands.div_ceil(STRANDS_PER_TASK_GROUP);
            if task_groups > limits.max_task_work_group_count[0] {
                return Err(GpuError::OverBudget {
                    name: "test strips task groups".into(),
                    requested: u64::from(task_groups),
                    budget: u64::from(limits.max_task_work_group_count[0]),
                    why: "maxTaskWorkGroupCount[0]",
                });
            }
            let draw = graphics(
                "test strips (task+mesh)",
                GraphicsStages::Mesh {
                    task: Some(&shaders::TEST_STRIPS_TASK),
                    mesh: &shaders::TEST_STRIPS_MESH,
                },
                &[],
            )?;
            Prepared::Mesh { draw, task_groups }
        }
        GenerationPath::Compute => {
            let bytes = u64::from(strands) * u64::from(TEST_STRIP_POINTS) * 4 * 16;
            if bytes > u64::from(caps.max_storage_buffer_range) {
                return Err(GpuError::OverBudget {
                    name: "test strip vertices".into(),
                    requested: bytes,
                    budget: u64::from(caps.max_storage_buffer_range),
                    why: "maxStorageBufferRange",
                });
            }
            let generate = Pipeline::compute(
                ctx,
                &ComputePipelineDesc {
                    name: "test strips generate",
                    shader: &shaders::TEST_STRIPS_COMP,
                    bindings: &[Binding::storage_buffer(DIAGNOSTIC_OUTPUT, vk::ShaderStageFlags::COMPUTE)],
                    push_constant_size: size_of::<TestStripParams>() as u32,
                    specialization: &[],
                },
            )?;
            let draw = graphics(
                "test strips (vertex pulling)",
                GraphicsStages::Vertex(&shaders::STRIP_PULL_VERT),
                &draw_bindings,
            )?;
            let vertices = Buffer::new(ctx, "test strip vertices", BufferDesc::storage(bytes.max(16)))?;
            Prepared::Compute { generate, draw, vertices: Box::new(vertices) }
        }
    };

    let attachment =
        (vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT, vk::AccessFlags2::COLOR_ATTACHMENT_WRITE);
    let depth_attachment = (
        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ,
    );
    let top = (vk::PipelineStageFlags2::TOP_OF_PIPE, vk::AccessFlags2::NONE);
    let ((), timings) = ctx.submit(&format!("test strips ({path})"), |rec| {
        rec.image_barrier(
            &color,
            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
            top,
            attachment,
        );
        rec.image_barrier(
            &depth,
            (vk::ImageLayout::UNDEFINED, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL),
            top,
            depth_attachment,
        );
        let clear = [0.02, 0.02, 0.03, 1.0];
        match &prepared {
            Prepared::Mesh { draw, task_groups } => {
                rec.pass("generate+raster (task+mesh)", |rec| {
                    rec.begin_rendering(&color, clear, Some(&depth));
                    rec.bind_pipeline(draw);
                    rec.push_constants(draw, &params);
                    let drawn =
                        if *task_groups > 0 { rec.draw_mesh_tasks(*task_groups, 1, 1) } else { Ok(()) };
                    rec.end_rendering();
                    drawn
                })?;
            }
            Prepared::Compute { generate, draw, vertices } => {
                rec.pass("generate (compute)", |rec| {
                    rec.bind_pipeline(generate);
                    rec.push_storage_buffers(generate, &[(DIAGNOSTIC_OUTPUT, vertices)]);
                    rec.push_constants(generate, &params);
                    let threads = strands * TEST_STRIP_POINTS;
                    rec.dispatch(threads.div_ceil(shaders::TEST_STRIPS_COMP.workgroup_size[0]), 1, 1);
                });
                rec.memory_barrier(
                    (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                    (vk::PipelineStageFlags2::VERTEX_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
                );
                rec.pass("raster (vertex pulling)", |rec| {
                    rec.begin_rendering(&color, clear, Some(&depth));
                    rec.bind_pipeline(draw);
                    rec.push_storage_buffers(draw, &[(DIAGNOSTIC_OUTPUT, vertices)]);
                    rec.push_constants(draw, &params);
                    rec.draw(strands * (TEST_STRIP_POINTS - 1) * 6, 1);
                    rec.end_rendering();
                });
            }
        }
        rec.image_barrier(
            &color,
            (vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
            attachment,
            (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_READ),
        );
        rec.copy_image_to_buffer(&color, &readback);
        Ok(())
    })?;
    let pixels = ctx.read_buffer(&readback, readback.size())?;
    Ok((RgbaImage { width, height, pixels }, timings))
}

/// Generates and draws `hair` through `path` into a `width`×`height` image.
pub fn draw_hair(
    ctx: &Context,
    generator: &crate::Generator,
    hair: &crate::GpuHair,
    inputs: &crate::FrameInputs,
    path: GenerationPath,
) -> Result<(RgbaImage, FrameTimings)> {
    let [width, height] = inputs.viewport;
    let frame = generator.prepare(ctx, hair, inputs)?;
    let target = RenderTarget::new(ctx, width, height)?;
    let ((), timings) = ctx.submit(&format!("hair ({path})"), |rec| {
        if path == GenerationPath::Compute {
            generator.record_lod(rec, hair, &frame);
            crate::Generator::barrier_after_lod(rec);
            generator.record_generate(rec, hair, &frame);
            crate::Generator::barrier_after_generate(rec);
        }
        target.begin(rec);
        let name = match path {
            GenerationPath::Compute => "raster (vertex pulling)",
            GenerationPath::Mesh => "generate+raster (task+mesh)",
        };
        let drawn = rec.pass(name, |rec| generator.record_draw(rec, hair, &frame, path, false));
        rec.end_rendering();
        target.copy_out(rec);
        drawn
    })?;
    Ok((target.read(ctx)?, timings))
}
