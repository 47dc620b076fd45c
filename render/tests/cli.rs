//! The `hairkit` binary as a user runs it (README commands), on the GPU harness.

use std::process::{Command, ExitCode};

use anyhow::ensure;
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};

fn hairkit(args: &[&str]) -> anyhow::Result<(bool, String, String)> {
    let out = Command::new(env!("CARGO_BIN_EXE_hairkit")).args(args).output()?;
    Ok((
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    ))
}

fn main() -> ExitCode {
    run_gpu_tests(vec![
        GpuTest::new("info_reports_the_device", Requirements::NONE, |ctx| {
            let (ok, stdout, stderr) = hairkit(&["info", "--all"])?;
            ensure!(ok, "hairkit info failed: {stderr}");
            ensure!(stdout.contains(&ctx.capabilities().device_name), "{stdout}");
            for field in ["VK_EXT_mesh_shader:", "subgroup size:", "max storage buffer:", "generation path:"]
            {
                ensure!(stdout.contains(field), "`{field}` missing from:\n{stdout}");
            }
            Ok(())
        }),
        GpuTest::new("demo_writes_images_and_timings", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let out = dir.path().to_str().ok_or_else(|| anyhow::anyhow!("non-UTF-8 temp dir"))?;
            let (ok, stdout, stderr) = hairkit(&["demo", "-o", out, "--strands", "40", "--size", "96x64"])?;
            ensure!(ok, "hairkit demo failed: {stderr}");
            let image = render::output::read_png(&dir.path().join("strips-compute.png"))?;
            ensure!((image.width, image.height) == (96, 64));
            ensure!(stdout.contains("generate (compute)") && stdout.contains("ms"), "{stdout}");
            if ctx.capabilities().mesh_shader.is_some() {
                ensure!(dir.path().join("strips-mesh.png").is_file(), "{stdout}");
            }
            Ok(())
        }),
        GpuTest::new("bad_arguments_are_refused_clearly", Requirements::NONE, |_| {
            let (ok, _, stderr) = hairkit(&["demo", "--size", "0x10"])?;
            ensure!(!ok && stderr.contains("width and height must be"), "{stderr}");
            let (ok, _, stderr) = hairkit(&["info", "--path", "sideways"])?;
            ensure!(!ok && stderr.contains("unknown generation path"), "{stderr}");
            let (ok, _, stderr) = hairkit(&["info", "--device", "no-such-gpu"])?;
            ensure!(!ok && stderr.contains("no Vulkan device matches `no-such-gpu`"), "{stderr}");
            Ok(())
        }),
    ])
}
