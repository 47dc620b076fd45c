//! The `hairkit` binary as a user runs it (README commands), on the GPU harness.

use std::process::{Command, ExitCode};

use anyhow::{Context as _, ensure};
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};

fn hairkit(args: &[&str]) -> anyhow::Result<(bool, String, String)> {
    hairkit_with(args, &[])
}

fn hairkit_with(args: &[&str], env: &[(&str, &std::path::Path)]) -> anyhow::Result<(bool, String, String)> {
    let out = Command::new(env!("CARGO_BIN_EXE_hairkit")).args(args).envs(env.iter().copied()).output()?;
    Ok((
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    ))
}

/// `hair-bench --quick --only SECTIONS --out DIR` into a new folder: the folder and its report,
/// which names the device.
fn quick_bench(ctx: &gen_gpu::Context, sections: &str) -> anyhow::Result<(tempfile::TempDir, String)> {
    let dir = tempfile::tempdir()?;
    let out = Command::new(env!("CARGO_BIN_EXE_hair-bench"))
        .args(["--quick", "--only", sections, "--out"])
        .arg(dir.path())
        .output()?;
    ensure!(
        out.status.success(),
        "hair-bench --only {sections} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = std::fs::read_to_string(dir.path().join("benchmarks.md"))?;
    ensure!(report.contains(&ctx.capabilities().device_name), "the report names the device");
    Ok((dir, report))
}

/// At least `min_rows` rows in `file`, every value after the first `skip` finite and ≥ 0.
fn finite_rows(dir: &std::path::Path, file: &str, skip: usize, min_rows: usize) -> anyhow::Result<()> {
    let csv = std::fs::read_to_string(dir.join(file))?;
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    ensure!(rows.len() >= min_rows, "{file}: {csv}");
    for row in rows {
        for value in row.split(',').skip(skip) {
            let v: f64 = value.parse()?;
            ensure!(v.is_finite() && v >= 0.0, "{file}: {row}");
        }
    }
    Ok(())
}

/// The plots are written at the plots' size and shown in the report.
fn check_plots(dir: &std::path::Path, report: &str, plots: &[&str]) -> anyhow::Result<()> {
    for plot in plots {
        let image = render::output::read_png(&dir.join(plot))?;
        ensure!((image.width, image.height) == hairkit_cli::plots::IMAGE_SIZE, "{plot}");
        ensure!(report.contains(&format!("]({plot})")), "the report shows {plot}");
    }
    Ok(())
}

/// The text of a report's section `name`, between its markers.
fn section(text: &str, name: &str) -> Option<String> {
    let (b, e) = (format!("<!-- hair-bench:{name}:begin -->"), format!("<!-- hair-bench:{name}:end -->"));
    let (i, j) = (text.find(&b)?, text.find(&e)?);
    Some(text[i..j].to_owned())
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
            let workers = format!("dispatch workers:       {}", ctx.capabilities().dispatch_workers);
            ensure!(stdout.contains(&workers), "`{workers}` missing from:\n{stdout}");
            Ok(())
        }),
        GpuTest::new("crowd_scenes_are_written_reproducibly_and_render", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let write = |out: &std::path::Path| -> anyhow::Result<()> {
                let out = out.to_str().ok_or_else(|| anyhow::anyhow!("non-UTF-8 temp dir"))?;
                let args = ["crowd", "-o", out, "--characters", "4", "--strands", "400", "--teapots", "3"];
                let (ok, _, stderr) =
                    hairkit(&[&args[..], &["--teapot-strands", "300", "--size", "96x64"]].concat())?;
                ensure!(ok, "hairkit crowd failed: {stderr}");
                Ok(())
            };
            let (a, b) = (dir.path().join("a"), dir.path().join("b"));
            write(&a)?;
            write(&b)?;
            // An earlier crowd is written over; a folder of other files only with --force, which
            // leaves those files alone.
            write(&b)?;
            let foreign = dir.path().join("c");
            std::fs::create_dir(&foreign)?;
            std::fs::write(foreign.join("notes.txt"), "mine")?;
            let foreign_text = foreign.to_str().ok_or_else(|| anyhow::anyhow!("non-UTF-8 temp dir"))?;
            let small =
                ["crowd", "-o", foreign_text, "--characters", "1", "--strands", "50", "--teapots", "1"];
            let (ok, _, stderr) = hairkit(&small)?;
            ensure!(!ok && stderr.contains("notes.txt") && stderr.contains("--force"), "{stderr}");
            let (ok, _, stderr) = hairkit(&[&small[..], &["--teapot-strands", "50", "--force"]].concat())?;
            ensure!(
                ok && foreign.join("notes.txt").exists() && foreign.join("heads.json").exists(),
                "{stderr}"
            );
            for name in ["heads.json", "teapots.json"] {
                let text = std::fs::read_to_string(a.join(name))?;
                ensure!(text == std::fs::read_to_string(b.join(name))?, "{name}: same seed, same scene");
                let scene = render::scene::load_scene(&a.join(name))?;
                ensure!(scene.scene.camera_path.len() >= 2, "{name} has a camera path");
                let expected = if name == "heads.json" { 4 } else { 3 };
                ensure!(scene.scene.characters.len() == expected, "{name}");
                ensure!(scene.scene.characters.iter().all(|c| c.occluder.is_some()), "{name}: occluders");
                // Halfway along the camera path.
                let (eye, target) = scene.camera_at(0.5);
                let renderer =
                    render::frame::SceneRenderer::new(ctx, &scene, gen_gpu::GenerationPath::Compute)?;
                let frame = renderer.render_camera(ctx, eye, target)?;
                let drawn = frame.linear.rgba.chunks_exact(4).filter(|p| p[3] > 0.0).count();
                ensure!(drawn > 200 && frame.stats.strands > 0, "{name}: {drawn} pixels drawn");
            }
            // Unique hair per character: the asset folders differ.
            let hair = |i: u32| std::fs::read(a.join(format!("heads/hair_{i:03}/hair.json")));
            ensure!(hair(0)? != hair(1)?, "characters have their own hair meshes");
            Ok(())
        }),
        GpuTest::new("demo_writes_images_and_timings", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let out = dir.path().to_str().ok_or_else(|| anyhow::anyhow!("non-UTF-8 temp dir"))?;
            let (ok, stdout, stderr) =
                hairkit(&["demo", "-o", out, "--strands", "300", "--characters", "3", "--size", "128x96"])?;
            ensure!(ok, "hairkit demo failed: {stderr}");
            // The child process runs with HAIRKIT_VALIDATION=1 too; its layer messages go to stderr.
            ensure!(!stderr.contains("vulkan validation"), "validation messages from the demo:\n{stderr}");
            let image = render::output::read_png(&dir.path().join("people-compute.png"))?;
            ensure!((image.width, image.height) == (128, 96));
            let hair_pixels = image.pixels.chunks_exact(4).filter(|p| p[0] > 20).count();
            ensure!(hair_pixels > 100, "only {hair_pixels} hair pixels");
            let caps = ctx.capabilities();
            // On a CPU device with 64-bit atomics the compute rasterizer draws the view (and the
            // demo compares it with the triangle raster); elsewhere the triangle raster with OIT.
            let compute = caps.is_cpu() && caps.buffer_int64_atomics;
            let mut expected = vec![
                "== convert",
                "import and scalp selection:",
                "raster hair",
                "shadow maps",
                "strands",
                "ms",
            ];
            if compute {
                expected.extend([
                    "raster hair (compute raster",
                    "resolve hair",
                    "triangle raster (compute path)",
                ]);
                ensure!(dir.path().join("people-triangles.png").is_file(), "{stdout}");
            } else {
                expected.extend(["generate character", "OIT resolve"]);
            }
            for expected in expected {
                ensure!(stdout.contains(expected), "`{expected}` missing from:\n{stdout}");
            }
            if ctx.capabilities().mesh_shader.is_some() {
                ensure!(dir.path().join("people-mesh.png").is_file(), "{stdout}");
            }
            Ok(())
        }),
        GpuTest::new("demo_without_the_data_set_renders_the_head_cap", Requirements::NONE, |_| {
            // HAIRKIT_DATA names an empty folder: the real heads are nowhere, so the demo says how
            // to get them and puts both generated hairstyles on the project's own head cap.
            let (dir, empty) = (tempfile::tempdir()?, tempfile::tempdir()?);
            let out = dir.path().to_str().ok_or_else(|| anyhow::anyhow!("non-UTF-8 temp dir"))?;
            let args = ["demo", "-o", out, "--strands", "300", "--characters", "2", "--size", "96x64"];
            let (ok, stdout, stderr) = hairkit_with(&args, &[(data_set::ENV_VAR, empty.path())])?;
            ensure!(ok, "hairkit demo failed: {stderr}");
            for expected in [data_set::SAMPLE_HEAD, data_set::ENV_VAR, data_set::FETCH_COMMAND, "head cap"] {
                ensure!(stdout.contains(expected), "`{expected}` missing from:\n{stdout}");
            }
            ensure!(
                dir.path().join("head_cap.gltf").is_file(),
                "the cap occluder is written beside the scene"
            );
            let image = render::output::read_png(&dir.path().join("people-compute.png"))?;
            let hair_pixels = image.pixels.chunks_exact(4).filter(|p| p[0] > 20).count();
            ensure!(hair_pixels > 100, "only {hair_pixels} hair pixels");
            Ok(())
        }),
        // `hair-bench --quick` by section groups, each in its own folder, so that the groups run
        // side by side (they are independent runs of the same binary).
        GpuTest::new("hair_bench_quick_generation_memory_stored_accuracy", Requirements::NONE, |ctx| {
            let (dir, report) = quick_bench(ctx, "generation,memory,stored,accuracy")?;
            for (file, skip, min_rows) in [
                // (strands, path, evaluation, then the generate pass alone: compute path only)
                ("bench-generation.csv", 4, 4),
                ("bench-stored.csv", 0, 2),
                ("bench-accuracy.csv", 1, 9),
                ("bench-memory.csv", 1, 5),
            ] {
                finite_rows(dir.path(), file, skip, min_rows)?;
            }
            // The compute path's rows time generation alone too.
            for row in std::fs::read_to_string(dir.path().join("bench-generation.csv"))?.lines().skip(1) {
                if row.split(',').nth(1) == Some("compute") {
                    let alone: f64 = row.split(',').nth(3).unwrap_or_default().parse()?;
                    ensure!(alone.is_finite() && alone > 0.0, "bench-generation.csv: {row}");
                }
            }
            // The lattice layout needs fewer texels and bytes than 2×2 blocks on every head cap.
            for row in std::fs::read_to_string(dir.path().join("bench-memory.csv"))?.lines().skip(1) {
                let v: Vec<f64> = row.split(',').skip(1).map(str::parse).collect::<Result<_, _>>()?;
                ensure!(v[4] < v[3] && v[6] < v[5], "bench-memory.csv: {row}");
            }
            for section in ["On-the-fly vs stored", "Accuracy vs time", "GPU memory"] {
                ensure!(report.contains(section), "`{section}` missing");
            }
            // Bytes do not depend on the machine: the project's report (docs/benchmarks.md) shows
            // the rows this run shares with a full one (10k strands; the head caps at 100k) as
            // they are.
            let docs =
                std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/benchmarks.md"))?;
            let (ours, theirs) = (section(&report, "memory"), section(&docs, "memory"));
            let (ours, theirs) = (ours.context("memory section")?, theirs.context("docs: memory section")?);
            let shared: Vec<&str> =
                ours.lines().filter(|l| l.starts_with("| head cap") || l.starts_with("| 9992 |")).collect();
            ensure!(shared.len() >= 7, "the memory section's machine-independent rows: {ours}");
            for row in shared {
                ensure!(
                    theirs.contains(row),
                    "docs/benchmarks.md's memory section lacks `{row}`: run `hair-bench --only memory --out docs`"
                );
            }
            check_plots(dir.path(), &report, &["plot-generation.png", "plot-accuracy.png"])?;
            // A second run replaces its own section and keeps the rest of the file, and `--only`
            // replaces only the sections it names.
            std::fs::write(dir.path().join("benchmarks.md"), format!("# Benchmarks\n\nkeep me\n\n{report}"))?;
            let out = Command::new(env!("CARGO_BIN_EXE_hair-bench"))
                .args(["--quick", "--only", "memory", "--out"])
                .arg(dir.path())
                .output()?;
            ensure!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            let again = std::fs::read_to_string(dir.path().join("benchmarks.md"))?;
            ensure!(
                again.contains("keep me")
                    && again.matches("hair-bench:memory:begin").count() == 1
                    && again.matches("hair-bench:generation:begin").count() == 1,
                "{again}"
            );
            for name in ["generation", "stored", "accuracy"] {
                ensure!(
                    section(&again, name).is_some() && section(&again, name) == section(&report, name),
                    "{name} kept"
                );
            }
            ensure!(section(&again, "memory").is_some_and(|m| m.contains("--only memory")), "{again}");
            let out = Command::new(env!("CARGO_BIN_EXE_hair-bench"))
                .args(["--quick", "--only", "generation,colour", "--out"])
                .arg(dir.path())
                .output()?;
            let stderr = String::from_utf8_lossy(&out.stderr);
            ensure!(!out.status.success() && stderr.contains("unknown section `colour`"), "{stderr}");
            ensure!(
                std::fs::read_to_string(dir.path().join("benchmarks.md"))? == again,
                "a refused run writes nothing"
            );
            Ok(())
        }),
        GpuTest::new("hair_bench_quick_crowd_passes_dynamics", Requirements::NONE, |ctx| {
            let (dir, report) = quick_bench(ctx, "crowd,passes,dynamics")?;
            finite_rows(dir.path(), "bench-effects.csv", 1, 3)?;
            finite_rows(dir.path(), "bench-crowd.csv", 2, 6)?;
            // Dynamics: per character every cost measured; in the crowd only the dynamic variant
            // simulates, re-bakes and uploads.
            let dynamics = std::fs::read_to_string(dir.path().join("bench-dynamics.csv"))?;
            let field = |row: &str, i: usize| -> anyhow::Result<f64> {
                Ok(row.split(',').nth(i).ok_or_else(|| anyhow::anyhow!("{row}: no field {i}"))?.parse()?)
            };
            let mut crowd_rows = 0;
            for row in dynamics.lines().skip(1) {
                if row.starts_with("character,") {
                    for i in [2, 4, 5, 6, 7, 8] {
                        let v = field(row, i)?;
                        ensure!(v.is_finite() && v > 0.0, "bench-dynamics.csv: {row}");
                    }
                } else {
                    crowd_rows += 1;
                    let moving = row.starts_with("crowd,motion + dynamics,");
                    for i in [4, 5, 9] {
                        ensure!((field(row, i)? > 0.0) == moving, "bench-dynamics.csv: {row}");
                    }
                    ensure!(field(row, 10)? > 0.0 && field(row, 11)? > 0.0, "bench-dynamics.csv: {row}");
                }
            }
            ensure!(crowd_rows == 3 && dynamics.lines().count() >= 6, "{dynamics}");
            for section in ["Render passes", "Crowds", "## Dynamics"] {
                ensure!(report.contains(section), "`{section}` missing");
            }
            check_plots(dir.path(), &report, &["plot-crowd.png"])
        }),
        GpuTest::new("hair_bench_quick_raster", Requirements::INT64_ATOMICS, |ctx| {
            let (dir, report) = quick_bench(ctx, "raster")?;
            // The raster table: both rasterizers' times and the compute rasterizer's parts.
            let csv = std::fs::read_to_string(dir.path().join("bench-raster.csv"))?;
            let rows: Vec<&str> = csv.lines().skip(1).collect();
            ensure!(rows.len() >= 4, "bench-raster.csv: {csv}");
            for row in rows {
                let values: Vec<f64> = row.split(',').skip(1).map(str::parse).collect::<Result<_, _>>()?;
                ensure!(values.len() == 11, "bench-raster.csv: {row}");
                ensure!(values.iter().all(|v| v.is_finite() && *v >= 0.0), "bench-raster.csv: {row}");
                // The rest phase draws every strand the front phase leaves: never nothing.
                ensure!(values[8] > 0.0, "bench-raster.csv: {row}");
            }
            // The far character timed again with straight strands: a positive time per far row.
            let straight = report
                .lines()
                .find(|l| l.starts_with("What generation costs inside the fused kernel"))
                .context("the raster section has no straight-strand timing")?;
            let times: Vec<f64> = straight
                .split(" ms with straight strands")
                .filter_map(|part| part.rsplit(' ').next()?.parse().ok())
                .collect();
            ensure!(!times.is_empty() && times.iter().all(|t| t.is_finite() && *t > 0.0), "{straight}");
            Ok(())
        }),
        GpuTest::new("hair_bench_quick_shadows_and_volume", Requirements::NONE, |ctx| {
            let (dir, _) = quick_bench(ctx, "shadows,volume")?;
            finite_rows(dir.path(), "bench-shadows.csv", 1, 6)?;
            // The compute rasterizer's maps look like the triangle pipeline's.
            for row in std::fs::read_to_string(dir.path().join("bench-shadows.csv"))?.lines().skip(1) {
                let flip: f64 = row.rsplit(',').next().unwrap_or_default().parse()?;
                ensure!(flip < 0.05, "bench-shadows.csv: {row}");
            }
            Ok(())
        }),
        GpuTest::new("bad_arguments_are_refused_clearly", Requirements::NONE, |_| {
            let (ok, _, stderr) = hairkit(&["demo", "--size", "0x10"])?;
            ensure!(!ok && stderr.contains("width and height must be"), "{stderr}");
            let (ok, _, stderr) = hairkit(&["demo", "--data", "no/such/folder"])?;
            ensure!(!ok && stderr.contains("no/such/folder") && stderr.contains("--data"), "{stderr}");
            let (ok, _, stderr) = hairkit(&["info", "--path", "sideways"])?;
            ensure!(!ok && stderr.contains("unknown generation path"), "{stderr}");
            let (ok, _, stderr) = hairkit(&["info", "--device", "no-such-gpu"])?;
            ensure!(!ok && stderr.contains("no Vulkan device matches `no-such-gpu`"), "{stderr}");
            Ok(())
        }),
    ])
}
