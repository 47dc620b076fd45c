//! GPU tests on the real device (lavapipe here), validation layer on. See `hairkit_tests::harness`.

use std::process::ExitCode;

use anyhow::{Context as _, ensure};
use gen_gpu::diagnostics::{draw_test_strips, wang_hash, write_pattern};
use gen_gpu::{GenerationPath, shaders};
use hairkit_tests::harness::{GpuTest, Requirements, run_checked, run_gpu_tests};
use hairkit_tests::image_compare::{Tolerance, compare, differing_pixels};

/// A check inside a `submit` closure (which returns gen-gpu's error type).
fn ensure_gpu(ok: bool, what: &str) -> gen_gpu::Result<()> {
    if ok { Ok(()) } else { Err(gen_gpu::GpuError::Mismatch(what.to_owned())) }
}

fn main() -> ExitCode {
    run_gpu_tests(vec![
        GpuTest::new("compute_pattern_reads_back_exactly", Requirements::NONE, |ctx| {
            // 1000 is not a multiple of the workgroup size: the tail guard is exercised too.
            for (count, seed) in [(1000u32, 0u32), (64, 0xdead_beef), (1, 7)] {
                let values = write_pattern(ctx, count, seed)?;
                ensure!(values.len() == count as usize);
                for (i, v) in values.iter().enumerate() {
                    ensure!(*v == wang_hash(i as u32 ^ seed), "value {i} of {count} (seed {seed}) is {v:#x}");
                }
            }
            Ok(())
        }),
        GpuTest::new("push_constants_are_checked_against_the_shaders", Requirements::NONE, |ctx| {
            // pattern.comp declares two uints: build-time reflection gives the range, and the
            // recorder's check (debug builds) refuses pushes that miss it.
            ensure!(shaders::PATTERN_COMP.push_constants == Some([0, 8]), "{:?}", shaders::PATTERN_COMP);
            let pipeline = gen_gpu::Pipeline::compute(
                ctx,
                &gen_gpu::ComputePipelineDesc {
                    name: "pattern",
                    shader: &shaders::PATTERN_COMP,
                    bindings: &[gen_gpu::Binding::storage_buffer(
                        gen_gpu::contract::binding::DIAGNOSTIC_OUTPUT,
                        gen_gpu::vk::ShaderStageFlags::COMPUTE,
                    )],
                    push_constant_size: 16,
                    specialization: &[],
                },
            )?;
            ensure!(pipeline.push_mismatch(0, 8).is_none());
            let short = pipeline.push_mismatch(0, 4).context("a struct missing a field")?;
            ensure!(short.contains("reads push constants 0..8, but 0..4 is pushed"), "{short}");
            let long = pipeline.push_mismatch(0, 20).context("a struct with a field too many")?;
            ensure!(long.contains("0..20 is pushed, but the kernel declares 0..8"), "{long}");
            // Every shader that has push constants has its range reflected.
            for s in shaders::ALL.iter().chain(render::shaders::ALL) {
                let words = s.words();
                let declares = words.windows(4).any(|w| w[0] >> 16 == 4 && w[0] & 0xffff == 59 && w[3] == 9);
                ensure!(declares == s.push_constants.is_some(), "{}: {:?}", s.name, s.push_constants);
            }
            Ok(())
        }),
        GpuTest::new("a_pipeline_is_made_once_per_device_and_desc", Requirements::NONE, |ctx| {
            // write_pattern asks for its pipeline at every call: the device makes it once, and
            // the shared pipeline keeps working after the earlier calls' handles are gone.
            write_pattern(ctx, 64, 1)?;
            let made = ctx.pipelines_made();
            let values = write_pattern(ctx, 64, 2)?;
            ensure!(ctx.pipelines_made() == made, "the same desc made another pipeline");
            ensure!(values.iter().enumerate().all(|(i, v)| *v == wang_hash(i as u32 ^ 2)), "{values:?}");
            // Another specialization constant (the dispatch order's worker count) is another
            // pipeline, on the same device.
            let other = ctx.with_dispatch_workers(ctx.dispatch_workers() + 1);
            let values = write_pattern(&other, 64, 3)?;
            ensure!(other.pipelines_made() == made + 1, "{} pipelines after {made}", other.pipelines_made());
            ensure!(values.iter().enumerate().all(|(i, v)| *v == wang_hash(i as u32 ^ 3)), "{values:?}");
            Ok(())
        }),
        GpuTest::new(
            "a_buffer_dropped_while_recording_lives_until_its_submission_ends",
            Requirements::NONE,
            |ctx| {
                // Safe code records a fill into a buffer, drops the buffer and a second one, then
                // submits: both must stay alive until the fence (the validation layer would report a
                // destroyed buffer in a submitted command), and be freed right after.
                let kept = gen_gpu::Buffer::new(ctx, "kept", gen_gpu::BufferDesc::storage(256))?;
                let ((), _) = ctx.submit("drop while recording", |rec| {
                    let doomed = gen_gpu::Buffer::new(ctx, "doomed", gen_gpu::BufferDesc::storage(256))?;
                    rec.fill_buffer(&doomed, 7);
                    rec.fill_buffer(&kept, 9);
                    drop(doomed);
                    ensure_gpu(ctx.resources_awaiting_submissions() == 1, "the dropped buffer waits")?;
                    // An update with a bad offset is refused before it reaches the driver.
                    ensure_gpu(rec.update_buffer(&kept, 2, &[0u8; 4]).is_err(), "misaligned update refused")?;
                    ensure_gpu(
                        rec.update_buffer(&kept, 252, &[0u8; 8]).is_err(),
                        "update past the end refused",
                    )?;
                    let transfer = (
                        gen_gpu::vk::PipelineStageFlags2::ALL_TRANSFER,
                        gen_gpu::vk::AccessFlags2::TRANSFER_WRITE,
                    );
                    // So is a ranged fill that is misaligned, empty or past the end.
                    for (offset, size) in [(2, 4), (4, 6), (4, 0), (252, 8)] {
                        ensure_gpu(
                            rec.fill_buffer_range(&kept, offset, size, 3).is_err(),
                            "bad ranged fill refused",
                        )?;
                    }
                    rec.memory_barrier(transfer, transfer);
                    rec.update_buffer(&kept, 0, &[1u8, 0, 0, 0])?;
                    rec.fill_buffer_range(&kept, 4, 4, 5)
                })?;
                ensure!(ctx.resources_awaiting_submissions() == 0, "freed after the fence");
                let bytes = ctx.read_buffer(&kept, 12)?;
                let words: Vec<u32> =
                    bytes.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect();
                ensure!(words == [1, 5, 9], "the commands ran in order: {words:?}");
                Ok(())
            },
        ),
        GpuTest::new("every_shader_module_is_valid", Requirements::NONE, |ctx| {
            let dir = std::env::temp_dir().join(format!("hairkit-spirv-{}", std::process::id()));
            std::fs::create_dir_all(&dir)?;
            for shader in shaders::ALL {
                let path = dir.join(format!("{}.spv", shader.name));
                std::fs::write(&path, shader.spirv)?;
                let out = std::process::Command::new("spirv-val")
                    .args(["--target-env", "vulkan1.3"])
                    .arg(&path)
                    .output()
                    .context("running spirv-val (package spirv-tools)")?;
                ensure!(out.status.success(), "{}: {}", shader.name, String::from_utf8_lossy(&out.stderr));
                // Mesh-stage modules need the mesh extension enabled to be created.
                let mesh_stage =
                    matches!(shader.stage, shaders::ShaderStage::Task | shaders::ShaderStage::Mesh);
                if !mesh_stage || ctx.capabilities().mesh_shader.is_some() {
                    let words = shader.words();
                    let info = gen_gpu::vk::ShaderModuleCreateInfo::default().code(&words);
                    // SAFETY: valid SPIR-V (just validated); the module is destroyed at once.
                    unsafe {
                        let m = ctx.device().create_shader_module(&info, None)?;
                        ctx.device().destroy_shader_module(m, None);
                    }
                }
            }
            let _ = std::fs::remove_dir_all(&dir);
            ensure!(!shaders::ALL.is_empty());
            Ok(())
        }),
        GpuTest::new("strips_compute_path_draws", Requirements::NONE, |ctx| {
            let (image, timings) = draw_test_strips(ctx, GenerationPath::Compute, 48, 128, 96)?;
            let background = [5u8, 5, 8, 255];
            let covered = image.pixels.chunks_exact(4).filter(|p| *p != background).count();
            let total = (image.width * image.height) as usize;
            // 48 strands 2.5 px wide and ~80 px tall cover roughly 10–40% of the image.
            ensure!(covered > total / 20 && covered < total / 2, "{covered} of {total} pixels covered");
            ensure!(timings.pass_ms("generate (compute)").is_some(), "timings: {timings:?}");
            Ok(())
        }),
        GpuTest::new("strips_mesh_path_matches_compute_path", Requirements::MESH_SHADER, |ctx| {
            // Both paths evaluate the same included GLSL for every vertex and emit the same
            // triangles in the same order, and strands have distinct depths, so the images
            // should be identical. The tolerance only allows for a compiler contracting a
            // multiply-add differently in the mesh and compute stages, which moves an edge
            // by at most a pixel on a few pixels: mean FLIP ≤ 0.005, 99th percentile ≤ 0.05.
            let (mesh, mesh_t) = draw_test_strips(ctx, GenerationPath::Mesh, 100, 160, 120)?;
            let (compute, compute_t) = draw_test_strips(ctx, GenerationPath::Compute, 100, 160, 120)?;
            let stats = compare(
                "strips_mesh_vs_compute",
                &mesh,
                &compute,
                Tolerance { mean: 0.005, percentile: (0.99, 0.05) },
            )
            .map_err(anyhow::Error::msg)?;
            let differing = differing_pixels(&mesh, &compute);
            eprintln!(
                "  mesh vs compute: {differing} differing pixels, FLIP mean {:.5}; mesh {:.2} ms, compute {:.2} ms (GPU)",
                stats.mean,
                mesh_t.passes[0].gpu_ms.unwrap_or(f64::NAN),
                compute_t.passes[0].gpu_ms.unwrap_or(f64::NAN)
            );
            Ok(())
        }),
        GpuTest::new("harness_fails_a_test_on_validation_errors", Requirements::NONE, |ctx| {
            let caught = run_checked(ctx, |ctx| {
                ctx.misuse_for_validation_selftest()?;
                Ok(())
            });
            let message = match caught {
                Ok(()) => anyhow::bail!("a deliberate misuse passed the harness"),
                Err(failed) => failed.message().unwrap_or_default().to_owned(),
            };
            ensure!(message.contains("validation error"), "unexpected failure text: {message}");
            ensure!(message.contains("VUID-VkSamplerCreateInfo-anisotropyEnable"), "{message}");
            // And the harness is clean again afterwards.
            run_checked(ctx, |_| Ok(())).map_err(|f| anyhow::anyhow!("{:?}", f.message()))?;
            Ok(())
        }),
        GpuTest::new("forcing_the_mesh_path_is_checked", Requirements::NONE, |ctx| {
            let caps = ctx.capabilities();
            let forced = gen_gpu::PathChoice::Mesh.resolve(caps);
            ensure!(forced.is_ok() == caps.mesh_shader.is_some(), "{forced:?}");
            ensure!(gen_gpu::PathChoice::Compute.resolve(caps)? == GenerationPath::Compute);
            if caps.is_cpu() {
                ensure!(
                    gen_gpu::PathChoice::Auto.resolve(caps)? == GenerationPath::Compute,
                    "CPU devices default to compute"
                );
            }
            ensure!("bogus".parse::<gen_gpu::PathChoice>().is_err());
            Ok(())
        }),
    ])
}
