//! Scene rendering: golden images, the frame graph, and bad scene files. GPU harness,
//! validation layer on.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{Context as _, ensure};
use gen_gpu::GenerationPath;
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};
use hairkit_tests::image_compare::{Tolerance, compare};
use render::frame::SceneRenderer;
use render::scene::load_scene;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

/// The example scene at a test size, written beside the assets so its relative paths resolve.
fn small_scene(dir: &Path, name: &str, width: u32, height: u32) -> anyhow::Result<PathBuf> {
    scene_with(dir, name, width, height, serde_json::json!({ "transparency": "opaque" }))
}

/// The example scene at a test size with other effects.
fn scene_with(
    dir: &Path,
    name: &str,
    width: u32,
    height: u32,
    effects: serde_json::Value,
) -> anyhow::Result<PathBuf> {
    let text = std::fs::read_to_string(repo(&format!("assets/scenes/{name}.json")))?;
    let mut json: serde_json::Value = serde_json::from_str(&text)?;
    json["output"] = serde_json::json!({ "width": width, "height": height });
    json["effects"] = effects;
    for c in json["characters"].as_array_mut().context("characters")? {
        let hair = c["hair"].as_str().context("hair")?.to_owned();
        c["hair"] = serde_json::json!(repo("assets/scenes").join(hair));
    }
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, serde_json::to_vec_pretty(&json)?)?;
    Ok(path)
}

/// Compares with `tests/golden/NAME.png`; `HAIRKIT_UPDATE_GOLDEN=1` rewrites the golden.
fn check_golden(name: &str, image: &render::RgbaImage) -> anyhow::Result<()> {
    let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden").join(format!("{name}.png"));
    if std::env::var("HAIRKIT_UPDATE_GOLDEN").is_ok_and(|v| v == "1") {
        render::output::write_png(&golden, image)?;
    }
    let expected = render::output::read_png(&golden)
        .with_context(|| format!("golden image {} (HAIRKIT_UPDATE_GOLDEN=1 writes it)", golden.display()))?;
    // lavapipe is deterministic run to run; the tolerance leaves room for other drivers'
    // rasterization rules and transcendental functions: mean FLIP ≤ 0.02, 99th percentile ≤ 0.3.
    compare(name, image, &expected, Tolerance { mean: 0.02, percentile: (0.99, 0.3) })
        .map_err(anyhow::Error::msg)?;
    Ok(())
}

/// A change that breaks a scene.
type SceneEdit = Box<dyn Fn(&mut serde_json::Value)>;

fn hair_render(args: &[&str]) -> (bool, String) {
    match Command::new(env!("CARGO_BIN_EXE_hair-render")).args(args).output() {
        Ok(out) => (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned()),
        Err(e) => (false, e.to_string()),
    }
}

fn main() -> ExitCode {
    run_gpu_tests(vec![
        GpuTest::new("one_character_matches_its_golden_image", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let scene = load_scene(&small_scene(dir.path(), "one_character", 256, 192)?)?;
            let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
            let frame = renderer.render(ctx)?;
            let lit = frame.image.pixels.chunks_exact(4).filter(|p| p[0] > 30).count();
            ensure!(lit > 5000, "only {lit} lit pixels");
            check_golden("one_character", &frame.image)
        }),
        GpuTest::new("small_crowd_matches_its_golden_image_on_both_paths", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let scene = load_scene(&small_scene(dir.path(), "small_crowd", 256, 160)?)?;
            let compute = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.render(ctx)?;
            check_golden("small_crowd", &compute.image)?;
            if ctx.capabilities().mesh_shader.is_some() {
                let mesh = SceneRenderer::new(ctx, &scene, GenerationPath::Mesh)?.render(ctx)?;
                compare(
                    "small_crowd_mesh_vs_compute",
                    &mesh.image,
                    &compute.image,
                    Tolerance { mean: 0.01, percentile: (0.99, 0.1) },
                )
                .map_err(anyhow::Error::msg)?;
            }
            Ok(())
        }),
        GpuTest::new("oit_matches_its_golden_image_and_differs_from_opaque", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let scene = load_scene(&scene_with(
                dir.path(),
                "one_character",
                256,
                192,
                serde_json::json!({ "transparency": "oit", "oit_k": 8 }),
            )?)?;
            let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
            let names: Vec<String> = renderer.graph().passes.iter().map(|p| p.name.clone()).collect();
            ensure!(
                names.iter().any(|n| n == "OIT resolve") && !names.iter().any(|n| n.contains("opaque")),
                "{names:?}"
            );
            let frame = renderer.render(ctx)?;
            ensure!(frame.passes == names, "{:?} vs {names:?}", frame.passes);
            ensure!(
                frame.oit_overflow == Some(0),
                "the default pool holds this frame: {:?} of {:?}",
                frame.oit_overflow,
                frame.oit_pool
            );
            check_golden("one_character_oit", &frame.image)?;
            let opaque = SceneRenderer::new(
                ctx,
                &load_scene(&small_scene(dir.path(), "one_character", 256, 192)?)?,
                GenerationPath::Compute,
            )?
            .render(ctx)?;
            let differing = frame
                .image
                .pixels
                .chunks_exact(4)
                .zip(opaque.image.pixels.chunks_exact(4))
                .filter(|(a, b)| a != b)
                .count();
            ensure!(differing > 1000, "OIT should change the image ({differing} pixels differ)");
            Ok(())
        }),
        GpuTest::new("a_tiny_oit_pool_overflows_gracefully", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let effects =
                serde_json::json!({ "transparency": "oit", "oit_k": 4, "oit_nodes_per_pixel": 0.05 });
            let scene = load_scene(&scene_with(dir.path(), "one_character", 128, 96, effects)?)?;
            let frame = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?.render(ctx)?;
            let overflow = frame.oit_overflow.unwrap_or(0);
            eprintln!("  pool {:?} nodes, {overflow} fragments dropped", frame.oit_pool);
            ensure!(overflow > 0, "the pool should overflow");
            let background = [5u8, 5, 8, 255];
            let drawn = frame.image.pixels.chunks_exact(4).filter(|p| *p != background).count();
            ensure!(drawn > 0, "what fits is still drawn");
            Ok(())
        }),
        GpuTest::new("sintel_groom_from_tressfx_matches_its_golden_images", Requirements::NONE, |ctx| {
            // The artist's full Sintel groom (11,400 strands × 16 points), read from
            // ../shared/testdata at run time, drawn as explicit strands.
            let dir = tempfile::tempdir()?;
            let groom = repo("../shared/testdata/strands/tressfx/v4/sintel_hair_full_16points.tfx");
            ensure!(groom.is_file(), "{} is missing (clone the project beside shared/)", groom.display());
            for (name, effects) in [
                ("sintel_opaque", serde_json::json!({ "transparency": "opaque" })),
                ("sintel_oit", serde_json::json!({ "transparency": "oit" })),
                (
                    "sintel_oit_shadows",
                    serde_json::json!({ "transparency": "oit", "shadows": true, "shadow_map_size": 256 }),
                ),
            ] {
                let scene = serde_json::json!({
                    "output": { "width": 256, "height": 256 },
                    "camera": { "eye": [0.15, 1.62, 0.5], "target": [0.0, 1.52, 0.0], "fov_y_degrees": 40 },
                    "lights": [ { "directional": { "direction": [0.3, 0.9, 0.6] } } ],
                    "characters": [ { "hair": groom, "color": [0.45, 0.22, 0.08], "strand_width": 0.0004 } ],
                    "effects": effects
                });
                let path = dir.path().join(format!("{name}.json"));
                std::fs::write(&path, serde_json::to_vec_pretty(&scene)?)?;
                let renderer = SceneRenderer::new(ctx, &load_scene(&path)?, GenerationPath::Compute)?;
                let frame = renderer.render(ctx)?;
                ensure!(frame.stats.strands == 11_400, "{:?}", frame.stats);
                ensure!(
                    !frame.passes.iter().any(|p| p.starts_with("generate")),
                    "explicit strands are not generated: {:?}",
                    frame.passes
                );
                let lit = frame.image.pixels.chunks_exact(4).filter(|p| p[0] > 30).count();
                ensure!(lit > 3000, "{name}: only {lit} lit pixels");
                check_golden(name, &frame.image)?;
            }
            Ok(())
        }),
        GpuTest::new(
            "deep_opacity_shadows_are_computed_once_and_darken_the_hair",
            Requirements::NONE,
            |ctx| {
                let dir = tempfile::tempdir()?;
                let effects =
                    serde_json::json!({ "transparency": "oit", "shadows": true, "shadow_map_size": 256 });
                let scene = load_scene(&scene_with(dir.path(), "one_character", 256, 192, effects)?)?;
                let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
                let graph: Vec<String> = renderer.graph().passes.iter().map(|p| p.name.clone()).collect();
                ensure!(
                    graph.iter().filter(|n| n.starts_with("shadow")).count() == 3,
                    "one light casts: {graph:?}"
                );
                let first = renderer.render(ctx)?;
                ensure!(!first.shadow_cached && first.passes == graph, "{:?}", first.passes);
                let second = renderer.render(ctx)?;
                ensure!(second.shadow_cached, "a static scene reuses its shadow maps");
                ensure!(!second.passes.iter().any(|p| p.starts_with("shadow")), "{:?}", second.passes);
                ensure!(first.image == second.image, "cached maps give the same frame");
                let unshadowed = SceneRenderer::new(
                    ctx,
                    &load_scene(&scene_with(
                        dir.path(),
                        "one_character",
                        256,
                        192,
                        serde_json::json!({ "transparency": "oit" }),
                    )?)?,
                    GenerationPath::Compute,
                )?
                .render(ctx)?;
                let brightness = |i: &render::RgbaImage| {
                    i.pixels
                        .chunks_exact(4)
                        .map(|p| u64::from(p[0]) + u64::from(p[1]) + u64::from(p[2]))
                        .sum::<u64>()
                };
                let (lit, shadowed) = (brightness(&unshadowed.image), brightness(&first.image));
                eprintln!(
                    "  brightness without shadows {lit}, with {shadowed} ({:.1}%)",
                    100.0 * shadowed as f64 / lit as f64
                );
                ensure!(
                    shadowed < lit * 95 / 100 && shadowed > lit / 4,
                    "self-shadowing darkens, but not to black"
                );
                check_golden("one_character_oit_shadows", &first.image)
            },
        ),
        GpuTest::new("the_frame_runs_exactly_the_passes_of_its_graph", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let scene = load_scene(&small_scene(dir.path(), "small_crowd", 64, 48)?)?;
            let renderer = SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
            let graph = renderer.graph();
            let names: Vec<String> = graph.passes.iter().map(|p| p.name.clone()).collect();
            let frame = renderer.render(ctx)?;
            ensure!(frame.passes == names, "recorded {:?}\ngraph {:?}", frame.passes, names);
            // No effect asks for shadows: no shadow pass exists or runs.
            ensure!(!names.iter().any(|n| n.contains("shadow")), "{names:?}");
            ensure!(names.iter().filter(|n| n.starts_with("generate character")).count() == 5);
            // Characters sharing an asset and style share one upload (3 distinct here).
            ensure!(format!("{renderer:?}").contains("hairs: 3"), "{renderer:?}");
            Ok(())
        }),
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
                (
                    "point_shadow.json",
                    Box::new(|v| {
                        v["effects"]["shadows"] = true.into();
                        v["lights"] = serde_json::json!([{ "point": { "position": [0, 3, 0] } }]);
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
                ("volume.json", Box::new(|v| v["effects"]["volume_lod"] = true.into()), "not supported yet"),
                (
                    "style.json",
                    Box::new(|v| v["characters"][0]["style"] = serde_json::json!({"curly": 1})),
                    "characters[0].style",
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
            Ok(())
        }),
    ])
}
