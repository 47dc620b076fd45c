//! `hair-render` as a user runs it: images, EXR channels, stats, and bad scene files refused
//! with clear errors before anything is written. GPU harness, validation layer on.

use std::path::Path;
use std::process::{Command, ExitCode};

use anyhow::{Context as _, ensure};
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};
use hairkit_tests::scenes::small_scene;

/// A change that breaks a scene.
type SceneEdit = Box<dyn Fn(&mut serde_json::Value)>;

fn hair_render(args: &[&str]) -> (bool, String) {
    let (ok, _, stderr) = hair_render_output(args);
    (ok, stderr)
}

/// Success, standard output and standard error.
fn hair_render_output(args: &[&str]) -> (bool, String, String) {
    match Command::new(env!("CARGO_BIN_EXE_hair-render")).args(args).output() {
        Ok(out) => (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        ),
        Err(e) => (false, String::new(), e.to_string()),
    }
}

fn main() -> ExitCode {
    run_gpu_tests(vec![
        GpuTest::new("bad_scene_files_are_refused_clearly_and_write_nothing", Requirements::NONE, |_| {
            let dir = tempfile::tempdir()?;
            let good = small_scene(dir.path(), "one_character", 64, 48)?;
            let base: serde_json::Value = serde_json::from_slice(&std::fs::read(&good)?)?;
            let out = dir.path().join("out.png");
            let cases: Vec<(&str, SceneEdit, &str)> = vec![
                ("unknown.json", Box::new(|v| v["colour"] = 1.into()), "unknown field `colour`"),
                (
                    "missing.json",
                    Box::new(|v| v["characters"][0]["hair"] = "no/such/asset".into()),
                    "characters[0].hair",
                ),
                (
                    "zero.json",
                    Box::new(|v| v["output"] = serde_json::json!({"width": 0, "height": 10})),
                    "output",
                ),
                (
                    "huge.json",
                    Box::new(|v| v["output"] = serde_json::json!({"width": 1000000, "height": 1000000})),
                    "output",
                ),
                (
                    "scale.json",
                    Box::new(|v| v["characters"][0]["transform"] = serde_json::json!({"scale": -1.0})),
                    "characters[0].transform.scale",
                ),
                ("k.json", Box::new(|v| v["effects"]["oit_k"] = 40.into()), "effects.oit_k"),
                ("msaa.json", Box::new(|v| v["effects"]["msaa"] = 3.into()), "effects.msaa"),
                (
                    "msaa_oit.json",
                    Box::new(|v| {
                        v["effects"]["msaa"] = 4.into();
                        v["effects"]["transparency"] = "oit".into();
                    }),
                    "effects.msaa",
                ),
                (
                    "occluder.json",
                    Box::new(|v| {
                        v["characters"][0]["occluder"] = serde_json::json!({ "mesh": "missing.obj" });
                    }),
                    "characters[0].occluder.mesh",
                ),
                // A folder where a mesh belongs (the long fuzz run found `"mesh": "."`): named once,
                // with the scene and the field.
                (
                    "occluder_folder.json",
                    Box::new(|v| {
                        v["characters"][0]["occluder"] = serde_json::json!({ "mesh": "." });
                    }),
                    "is a folder, not a mesh file",
                ),
                (
                    "point_shadow.json",
                    Box::new(|v| {
                        v["effects"]["shadows"] = true.into();
                        // Inside the hair's bounds: a cube map would be needed.
                        v["lights"] = serde_json::json!([{ "point": { "position": [0, 1.6, 0] } }]);
                    }),
                    "not supported yet",
                ),
                (
                    "layers.json",
                    Box::new(|v| {
                        v["effects"] =
                            serde_json::json!({ "shadows": true, "shadow_layers": [0.3, 0.2, 0.1] });
                    }),
                    "effects.shadow_layers",
                ),
                ("dynamics.json", Box::new(|v| v["effects"]["dynamics"] = true.into()), "no character has a"),
                (
                    "dynamics_off.json",
                    Box::new(|v| v["characters"][0]["dynamics"] = serde_json::json!({})),
                    "characters[0].dynamics: needs \"effects\": {\"dynamics\": true}",
                ),
                (
                    "no_animation.json",
                    Box::new(|v| {
                        v["characters"][0]["dynamics"] = serde_json::json!({});
                        v["effects"]["dynamics"] = true.into();
                    }),
                    "needs the scene's \"animation\"",
                ),
                (
                    "substeps.json",
                    Box::new(|v| {
                        v["animation"] = serde_json::json!({ "frames": 4 });
                        v["characters"][0]["dynamics"] = serde_json::json!({ "substeps": 0 });
                        v["effects"]["dynamics"] = true.into();
                    }),
                    "characters[0].dynamics: substeps: 0",
                ),
                (
                    "wind.json",
                    Box::new(|v| {
                        v["animation"] = serde_json::json!({ "frames": 4 });
                        v["characters"][0]["dynamics"] = serde_json::json!({ "wind": { "gust_period": -1 } });
                        v["effects"]["dynamics"] = true.into();
                    }),
                    "wind.gust_period",
                ),
                (
                    "motion.json",
                    Box::new(|v| {
                        v["animation"] = serde_json::json!({ "frames": 4 });
                        v["characters"][0]["motion"] =
                            serde_json::json!({ "pivot": [0, 1.4, 0], "keys": [{"time": 1}, {"time": 0.5}] });
                    }),
                    "characters[0].motion.keys[1].time",
                ),
                (
                    "fps.json",
                    Box::new(|v| v["animation"] = serde_json::json!({ "frames": 4, "fps": 0 })),
                    "animation.fps",
                ),
                (
                    "volume_triangles.json",
                    Box::new(|v| {
                        v["effects"]["volume_lod"] = true.into();
                        v["effects"]["raster"] = "triangles".into();
                    }),
                    "compute rasterizer",
                ),
                (
                    "style.json",
                    Box::new(|v| v["characters"][0]["style"] = serde_json::json!({"curly": 1})),
                    "characters[0].style",
                ),
                ("lod_word.json", Box::new(|v| v["lod"] = "fast".into()), "expected \"auto\" or an object"),
                (
                    "lod_field.json",
                    Box::new(|v| v["lod"] = serde_json::json!({ "strand_alfa": 2 })),
                    "unknown field `strand_alfa`",
                ),
                (
                    "lod_error.json",
                    Box::new(|v| v["lod"] = serde_json::json!({ "vertex_error_pixels": -1 })),
                    "lod.vertex_error_pixels",
                ),
            ];
            for (name, edit, expected) in cases {
                let mut v = base.clone();
                edit(&mut v);
                let path = dir.path().join(name);
                std::fs::write(&path, serde_json::to_vec_pretty(&v)?)?;
                let (ok, stderr) =
                    hair_render(&[path.to_str().context("utf-8")?, "-o", out.to_str().context("utf-8")?]);
                ensure!(!ok, "{name} should fail");
                ensure!(
                    stderr.contains(name) && stderr.contains(expected),
                    "{name}: `{stderr}` should name the file and mention `{expected}`"
                );
                ensure!(!out.exists(), "{name}: an image was written");
            }
            // NaN is not JSON: a syntax error with line and column.
            let nan = dir.path().join("nan.json");
            let text = std::fs::read_to_string(&good)?.replacen(
                "\"fov_y_degrees\": 45",
                "\"fov_y_degrees\": NaN",
                1,
            );
            std::fs::write(&nan, text)?;
            let (ok, stderr) =
                hair_render(&[nan.to_str().context("utf-8")?, "-o", out.to_str().context("utf-8")?]);
            ensure!(
                !ok && stderr.contains("nan.json") && stderr.contains("line ") && stderr.contains("column "),
                "{stderr}"
            );
            ensure!(!out.exists());
            Ok(())
        }),
        // Before the checks a `--stats-json` or `--sim-cache` could overwrite the scene, and a
        // scene naming a named pipe or a device hung or read without end.
        GpuTest::new(
            "outputs_never_replace_inputs_and_special_files_are_refused",
            Requirements::NONE,
            |_| {
                let dir = tempfile::tempdir()?;
                let scene = small_scene(dir.path(), "one_character", 32, 24)?;
                let scene_text = scene.to_str().context("utf-8")?;
                let before = std::fs::read(&scene)?;
                let out = dir.path().join("out.png");
                let out_text = out.to_str().context("utf-8")?;
                let (ok, stderr) =
                    hair_render(&[scene_text, "-o", out_text, "--stats-json", scene_text, "--force"]);
                ensure!(!ok && stderr.contains("is an input of this command"), "{stderr}");
                let (ok, stderr) =
                    hair_render(&[scene_text, "--simulate", "--sim-cache", scene_text, "--force"]);
                ensure!(!ok && stderr.contains("is an input of this command"), "{stderr}");
                ensure!(std::fs::read(&scene)? == before, "the scene changed");
                // An image path holding something else needs --force.
                std::fs::write(&out, "not an image")?;
                let (ok, stderr) = hair_render(&[scene_text, "-o", out_text]);
                ensure!(
                    !ok && stderr.contains("not a PNG image written by hairkit")
                        && stderr.contains("--force"),
                    "{stderr}"
                );
                ensure!(std::fs::read(&out)? == b"not an image", "overwritten");
                // A scene whose hair is a named pipe, whose occluder is a device.
                let fifo = dir.path().join("pipe");
                ensure!(Command::new("mkfifo").arg(&fifo).status()?.success(), "mkfifo");
                std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.glb"))?;
                let json: serde_json::Value = serde_json::from_slice(&before)?;
                for (field, value, expected) in
                    [("hair", "pipe", "named pipe"), ("occluder", "zero.glb", "a device")]
                {
                    let mut edited = json.clone();
                    if field == "hair" {
                        edited["characters"][0]["hair"] = value.into();
                    } else {
                        edited["characters"][0]["occluder"]["mesh"] = value.into();
                    }
                    let path = dir.path().join(format!("{field}.json"));
                    std::fs::write(&path, serde_json::to_vec(&edited)?)?;
                    let (ok, stderr) =
                        hair_render(&[path.to_str().context("utf-8")?, "-o", out_text, "--force"]);
                    ensure!(!ok && stderr.contains(expected) && stderr.contains(value), "{field}: {stderr}");
                }
                Ok(())
            },
        ),
        GpuTest::new("frame_ranges_in_separate_processes_equal_one_run", Requirements::NONE, |_| {
            // `--frames 0..10` in one process equals `0..5` and `5..10` in two, byte for byte:
            // with dynamics (one half reading the simulation cache, the other simulating in
            // memory) and without (the head moves rigidly).
            let dir = tempfile::tempdir()?;
            for dynamics in [true, false] {
                let effects = serde_json::json!({ "transparency": "opaque", "dynamics": dynamics });
                let path = hairkit_tests::scenes::scene_with(dir.path(), "dynamics", 96, 72, effects)?;
                if !dynamics {
                    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&path)?)?;
                    v["characters"][0].as_object_mut().map(|c| c.remove("dynamics"));
                    std::fs::write(&path, serde_json::to_vec_pretty(&v)?)?;
                }
                let scene = path.to_str().context("utf-8")?;
                let run = |frames: &str, out: &Path, cache: &Path| {
                    let out = out.join("f.png");
                    let (ok, stdout, stderr) = hair_render_output(&[
                        scene,
                        "--frames",
                        frames,
                        "--sim-cache",
                        cache.to_str().unwrap_or_default(),
                        "-o",
                        out.to_str().unwrap_or_default(),
                    ]);
                    ensure!(ok, "--frames {frames}: {stderr}");
                    Ok::<_, anyhow::Error>((stdout, stderr))
                };
                let (full, split) = (dir.path().join("full"), dir.path().join("split"));
                std::fs::create_dir_all(&full)?;
                std::fs::create_dir_all(&split)?;
                let cache = dir.path().join("scene.sim");
                let none = dir.path().join("none.sim");
                let (stdout, _) = run("0..10", &full, &none)?;
                ensure!(stdout.contains("re-baked") == dynamics, "{stdout}");
                if dynamics {
                    let (ok, stdout, stderr) = hair_render_output(&[
                        scene,
                        "--simulate",
                        "--sim-cache",
                        cache.to_str().context("utf-8")?,
                    ]);
                    ensure!(ok && stdout.contains("48 frames"), "--simulate: {stdout} {stderr}");
                    let (_, stderr) = run("0..5", &split, &cache)?;
                    ensure!(!stderr.contains("simulating"), "the first half reads the cache: {stderr}");
                    // Without --sim-cache the cache goes beside the output, never beside the
                    // scene; with neither, --simulate asks where.
                    let beside = dir.path().join("beside");
                    let out = beside.join("frame.png");
                    let (ok, stdout, stderr) =
                        hair_render_output(&[scene, "--simulate", "-o", out.to_str().context("utf-8")?]);
                    ensure!(ok && beside.join("frame.sim").is_file(), "--simulate -o: {stdout} {stderr}");
                    ensure!(!path.with_extension("sim").exists(), "a cache was written beside the scene");
                    let (ok, _, stderr) = hair_render_output(&[scene, "--simulate"]);
                    ensure!(!ok && stderr.contains("--sim-cache FILE"), "{stderr}");
                } else {
                    run("0..5", &split, &none)?;
                }
                let (_, stderr) = run("5..10", &split, &none)?;
                ensure!(stderr.contains("simulating") == dynamics, "{stderr}");
                for f in 0..10 {
                    let name = format!("f-{f:04}.png");
                    let (a, b) = (std::fs::read(full.join(&name))?, std::fs::read(split.join(&name))?);
                    ensure!(a == b, "dynamics {dynamics}: {name} differs between one run and two");
                }
                ensure!(
                    std::fs::read(full.join("f-0000.png"))? != std::fs::read(full.join("f-0009.png"))?,
                    "the frames differ (the test would pass on a still scene)"
                );
                std::fs::remove_dir_all(&full)?;
                std::fs::remove_dir_all(&split)?;
            }
            let (ok, stderr) = hair_render(&["x.json", "--frames", "5..3", "-o", "x.png"]);
            ensure!(!ok && stderr.contains("holds no frame"), "{stderr}");
            let path = hairkit_tests::scenes::scene_with(
                dir.path(),
                "dynamics",
                96,
                72,
                serde_json::json!({"dynamics": true}),
            )?;
            let (ok, stderr) =
                hair_render(&[path.to_str().context("utf-8")?, "--frames", "40..60", "-o", "x.png"]);
            ensure!(!ok && stderr.contains("48 frames"), "{stderr}");
            Ok(())
        }),
        GpuTest::new("hair_render_writes_linear_exr_with_depth_and_coverage", Requirements::NONE, |_| {
            use exr::prelude::*;
            let dir = tempfile::tempdir()?;
            let scene = small_scene(dir.path(), "one_character", 96, 64)?;
            let (exr_path, png_path) = (dir.path().join("frame.exr"), dir.path().join("frame.png"));
            let arg = |p: &Path| p.to_str().map(str::to_owned).context("utf-8");
            let (ok, stderr) = hair_render(&[&arg(&scene)?, "-o", &arg(&exr_path)?, "--depth", "--coverage"]);
            ensure!(ok, "{stderr}");
            let (ok, stderr) = hair_render(&[&arg(&scene)?, "-o", &arg(&png_path)?]);
            ensure!(ok, "{stderr}");
            let (ok, stderr) =
                hair_render(&[&arg(&scene)?, "-o", &arg(&dir.path().join("x.png"))?, "--depth"]);
            ensure!(!ok && stderr.contains(".exr"), "--depth needs EXR: {stderr}");
            let image = read_all_flat_layers_from_file(&exr_path)?;
            let layer = &image.layer_data[0];
            let channel = |name: &str| -> anyhow::Result<Vec<f32>> {
                let c =
                    layer.channel_data.list.iter().find(|c| c.name.to_string() == name).context("channel")?;
                Ok(c.sample_data.values_as_f32().collect())
            };
            let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
            ensure!(names == ["A", "B", "G", "R", "Z"], "{names:?}");
            let (a, z, r) = (channel("A")?, channel("Z")?, channel("R")?);
            ensure!(a.iter().zip(&z).all(|(a, z)| (*a > 0.0) == z.is_finite()), "depth where covered");
            ensure!(a.iter().any(|&a| a > 0.0 && a < 1.0), "partial coverage (coverage AA)");
            ensure!(
                z.iter().filter(|z| z.is_finite()).all(|&z| z > 0.1 && z < 2.0),
                "view distances in metres"
            );
            // The PNG is the same frame encoded to sRGB.
            let png = render::output::read_png(&png_path)?;
            let worst = r
                .iter()
                .zip(png.pixels.chunks_exact(4))
                .map(|(&r, p)| (render::target::linear_to_srgb(r) * 255.0 - f32::from(p[0])).abs())
                .fold(0.0f32, f32::max);
            ensure!(worst <= 1.0, "PNG = sRGB(EXR) within one step (worst {worst})");
            Ok(())
        }),
        GpuTest::new("hair_render_writes_the_image_and_stats", Requirements::NONE, |_| {
            let dir = tempfile::tempdir()?;
            let scene = small_scene(dir.path(), "one_character", 96, 64)?;
            let out = dir.path().join("frame.png");
            let stats = dir.path().join("stats.json");
            let (ok, stderr) = hair_render(&[
                scene.to_str().context("utf-8")?,
                "-o",
                out.to_str().context("utf-8")?,
                "--stats",
                "--stats-json",
                stats.to_str().context("utf-8")?,
                "--print-graph",
            ]);
            ensure!(ok, "{stderr}");
            ensure!(!stderr.contains("vulkan validation"), "{stderr}");
            let image = render::output::read_png(&out)?;
            ensure!((image.width, image.height) == (96, 64));
            // An orbit writes numbered frames.
            let orbit = dir.path().join("orbit.png");
            let (ok, stderr) = hair_render(&[
                scene.to_str().context("utf-8")?,
                "-o",
                orbit.to_str().context("utf-8")?,
                "--frames",
                "3",
            ]);
            ensure!(ok, "{stderr}");
            let frames: Vec<_> = (0..3).map(|i| dir.path().join(format!("orbit-{i:04}.png"))).collect();
            ensure!(frames.iter().all(|f| f.is_file()) && !orbit.exists(), "{frames:?}");
            ensure!(std::fs::read(&frames[0])? != std::fs::read(&frames[1])?, "the camera moves");
            let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats)?)?;
            ensure!(json["passes"].as_array().is_some_and(|p| p.len() >= 4), "{json}");
            ensure!(json["strands"].as_u64().is_some_and(|s| s > 0), "{json}");
            ensure!(json["repeated"].is_null(), "no --repeat, no summary: {json}");
            // --repeat: the frame again, each pass's median and quartiles over the repeats.
            let repeat_stats = dir.path().join("repeat.json");
            let (ok, stdout, stderr) = hair_render_output(&[
                scene.to_str().context("utf-8")?,
                "-o",
                out.to_str().context("utf-8")?,
                "--stats",
                "--stats-json",
                repeat_stats.to_str().context("utf-8")?,
                "--repeat",
                "3",
            ]);
            ensure!(ok, "{stderr}");
            ensure!(stdout.contains("over 3 frames: median"), "{stdout}");
            let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&repeat_stats)?)?;
            let repeated = &json["repeated"];
            ensure!(repeated["frames"].as_u64() == Some(3), "{json}");
            let passes = repeated["passes"].as_array().context("repeated.passes")?;
            let timed = json["passes"].as_array().is_some_and(|p| p.iter().any(|p| p["gpu_ms"].is_number()));
            ensure!(!timed || passes.len() >= 4, "{json}");
            for pass in passes {
                let ms = |key: &str| pass[key].as_f64().with_context(|| format!("{key}: {pass}"));
                ensure!(
                    ms("gpu_ms_q1")? <= ms("gpu_ms_median")? && ms("gpu_ms_median")? <= ms("gpu_ms_q3")?,
                    "{pass}"
                );
                ensure!(pass["frames"].as_u64().is_some_and(|n| (1..=3).contains(&n)), "{pass}");
            }
            // Refused before anything renders: repeats nothing reports, and no repeats.
            for (args, expected) in [
                (vec!["--repeat", "2"], "add --stats"),
                (vec!["--repeat", "0", "--stats"], "0 is not in 1..=1000"),
            ] {
                let mut all = vec![scene.to_str().context("utf-8")?, "-o", out.to_str().context("utf-8")?];
                all.extend(args);
                let (ok, stderr) = hair_render(&all);
                ensure!(!ok && stderr.contains(expected), "{all:?}: {stderr}");
            }
            Ok(())
        }),
        GpuTest::new("hair_render_warns_when_the_oit_pool_overflows", Requirements::NONE, |_| {
            // A pool far too small: the image keeps its hair (the overflow is blended), and the
            // user is told what happened and which setting to raise; the stats count it.
            let dir = tempfile::tempdir()?;
            let effects = serde_json::json!({ "transparency": "oit", "oit_nodes_per_pixel": 0.05 });
            let scene = hairkit_tests::scenes::scene_with(dir.path(), "one_character", 64, 48, effects)?;
            let (out, stats) = (dir.path().join("oit.png"), dir.path().join("stats.json"));
            let arg = |p: &Path| p.to_str().map(str::to_owned).context("utf-8");
            let (ok, stdout, stderr) = hair_render_output(&[
                &arg(&scene)?,
                "-o",
                &arg(&out)?,
                "--stats",
                "--stats-json",
                &arg(&stats)?,
            ]);
            ensure!(ok, "{stderr}");
            ensure!(
                stderr.contains("warning")
                    && stderr.contains("oit.png")
                    && stderr.contains("oit_nodes_per_pixel"),
                "{stderr}"
            );
            ensure!(stdout.contains("OIT:"), "{stdout}");
            let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats)?)?;
            ensure!(json["oit_overflow"].as_u64().is_some_and(|n| n > 0), "{json}");
            ensure!(json["oit_pool"].as_u64().is_some_and(|n| n > 0), "{json}");
            // With a pool that holds the frame, no warning.
            let scene = hairkit_tests::scenes::scene_with(
                dir.path(),
                "one_character",
                64,
                48,
                serde_json::json!({ "transparency": "oit", "oit_nodes_per_pixel": 256 }),
            )?;
            let (ok, stderr) = hair_render(&[&arg(&scene)?, "-o", &arg(&out)?]);
            ensure!(ok && !stderr.contains("warning"), "{stderr}");
            Ok(())
        }),
        GpuTest::new("hair_render_raster_option_picks_the_rasterizer", Requirements::INT64_ATOMICS, |_| {
            let dir = tempfile::tempdir()?;
            let scene = small_scene(dir.path(), "one_character", 64, 48)?;
            let scene = scene.to_str().context("utf-8")?;
            for raster in ["triangles", "compute"] {
                let out = dir.path().join(format!("{raster}.png"));
                let (ok, stdout, stderr) =
                    hair_render_output(&[scene, "-o", out.to_str().context("utf-8")?, "--raster", raster]);
                ensure!(ok, "{stderr}");
                ensure!(stdout.contains(&format!("{raster} raster")), "{raster}: {stdout}");
                ensure!(out.is_file(), "{raster}: no image");
            }
            let (ok, stdout, _) = hair_render_output(&[scene, "--print-graph", "--raster", "compute"]);
            ensure!(ok && stdout.contains("compute raster"), "{stdout}");
            // MSAA is the triangle raster's: refused with the compute rasterizer, naming the file
            // and the field.
            let msaa = dir.path().join("msaa.json");
            let mut json: serde_json::Value = serde_json::from_slice(&std::fs::read(scene)?)?;
            json["effects"]["msaa"] = 4.into();
            std::fs::write(&msaa, serde_json::to_vec_pretty(&json)?)?;
            let out = dir.path().join("msaa.png");
            let (ok, stderr) = hair_render(&[
                msaa.to_str().context("utf-8")?,
                "-o",
                out.to_str().context("utf-8")?,
                "--raster",
                "compute",
            ]);
            ensure!(!ok && stderr.contains("msaa.json") && stderr.contains("effects.msaa"), "{stderr}");
            ensure!(!out.exists(), "an image was written");
            let (ok, stderr) = hair_render(&[scene, "--print-graph", "--raster", "quads"]);
            ensure!(!ok && stderr.contains("quads"), "{stderr}");
            Ok(())
        }),
        GpuTest::new("hair_render_draws_volumes_and_ao", Requirements::INT64_ATOMICS, |_| {
            // The example scene far away with the volume effects: the graph names the
            // voxelization, the AO and the raymarch, and the frame renders.
            let dir = tempfile::tempdir()?;
            let path = hairkit_tests::scenes::scene_with(
                dir.path(),
                "one_character",
                96,
                64,
                serde_json::json!({ "raster": "auto", "ao": true, "volume_lod": true, "volume_shadows": true }),
            )?;
            let mut json: serde_json::Value = serde_json::from_slice(&std::fs::read(&path)?)?;
            json["camera"]["eye"] = serde_json::json!([0.0, 3.8, 5.2]);
            std::fs::write(&path, serde_json::to_vec_pretty(&json)?)?;
            let scene = path.to_str().context("utf-8")?;
            let (ok, stdout, stderr) = hair_render_output(&[scene, "--print-graph"]);
            ensure!(ok, "{stderr}");
            for pass in
                ["voxelize hair 0", "volume AO hair 0", "volume bricks hair 0", "raymarch character 0"]
            {
                ensure!(stdout.contains(pass), "no {pass:?} in the graph:\n{stdout}");
            }
            let out = dir.path().join("far.png");
            let (ok, stderr) = hair_render(&[scene, "-o", out.to_str().context("utf-8")?, "--validation"]);
            ensure!(ok && out.is_file(), "{stderr}");
            ensure!(!stderr.contains("vulkan validation"), "{stderr}");
            Ok(())
        }),
    ])
}
