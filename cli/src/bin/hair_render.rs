//! `hair-render SCENE -o frame.png`: renders a scene file (see `render::scene`).
//!
//! ```text
//! hair-render SCENE -o OUT.png|OUT.exr [--depth] [--coverage] [--frames N]
//!             [--path auto|mesh|compute] [--raster auto|triangles|compute]
//!             [--device SEL] [--print-graph]
//!             [--stats] [--stats-json FILE] [--validation]
//! ```
//!
//! `.png` output is 8-bit sRGB; `.exr` output is linear half-float RGB with an optional `A`
//! (coverage) and `Z` (view-space distance) channel.

use std::path::PathBuf;

use anyhow::{Context as _, Result};
use clap::Parser;
use gen_gpu::{Context, ContextDesc, PathChoice, Validation};
use render::frame::SceneRenderer;

#[derive(Parser, Debug)]
#[command(name = "hair-render", version, about = "Render a hairkit scene file")]
struct Cli {
    /// The scene (JSON).
    scene: PathBuf,
    /// Output image, written atomically: `.png` (8-bit sRGB) or `.exr` (linear half float).
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// EXR output: add a `Z` channel with the view-space distance (infinite on the background).
    #[arg(long)]
    depth: bool,
    /// EXR output: add an `A` channel with the coverage of hair and occluders.
    #[arg(long)]
    coverage: bool,
    /// Generation path: auto, mesh or compute.
    #[arg(long, default_value = "auto")]
    path: PathChoice,
    /// Rasterizer: auto, triangles or compute (overrides the scene's `effects.raster`; auto
    /// takes the compute rasterizer on CPU devices when it can draw the scene's effects).
    #[arg(long)]
    raster: Option<render::scene::Raster>,
    /// Device index or part of its name.
    #[arg(long)]
    device: Option<String>,
    /// Print the frame graph (the passes the scene's effects need) and exit unless -o is given.
    #[arg(long)]
    print_graph: bool,
    /// Print per-pass GPU times and counts.
    #[arg(long)]
    stats: bool,
    /// Write per-pass GPU times and counts as JSON.
    #[arg(long)]
    stats_json: Option<PathBuf>,
    /// Enable the Khronos validation layer (also HAIRKIT_VALIDATION=1).
    #[arg(long)]
    validation: bool,
    /// Render N frames along the scene's `camera_path`, or orbiting the camera once around its
    /// target when it has none; files are numbered (`out.png` → `out-0000.png`, …).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10000))]
    frames: u32,
}

/// `dir/name.png` → `dir/name-0007.png`.
fn numbered(path: &std::path::Path, index: u32) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    path.with_file_name(format!("{stem}-{index:04}{ext}"))
}

fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(&Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hair-render: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: &Cli) -> Result<()> {
    // Everything about the scene is checked before the GPU is touched.
    let mut scene = render::scene::load_scene(&cli.scene)?;
    if let Some(raster) = cli.raster {
        scene.scene.effects.raster = raster;
        scene.validate()?;
    }
    if cli.out.is_none() && !cli.print_graph {
        anyhow::bail!("nothing to do: give -o OUT.png and/or --print-graph");
    }
    let ctx = Context::new(&ContextDesc {
        validation: if cli.validation { Validation::On } else { Validation::FromEnv },
        device: cli.device.clone(),
    })?;
    let path = cli.path.resolve_with_env(ctx.capabilities())?;
    let renderer = SceneRenderer::new(&ctx, &scene, path)?;
    if cli.print_graph {
        print!("{}", renderer.graph());
    }
    let Some(out) = &cli.out else { return Ok(()) };
    let exr = match out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => false,
        Some("exr") => true,
        _ => anyhow::bail!("{}: the output must end in .png or .exr", out.display()),
    };
    if !exr && (cli.depth || cli.coverage) {
        anyhow::bail!("--depth and --coverage need an .exr output (PNG is 8-bit sRGB colour)");
    }
    let camera = scene.scene.camera;
    let (eye, target) = (glam::Vec3::from_array(camera.eye), glam::Vec3::from_array(camera.target));
    let mut last = None;
    for i in 0..cli.frames {
        let (frame_eye, frame_target) = if scene.scene.camera_path.is_empty() {
            let angle = std::f32::consts::TAU * i as f32 / cli.frames as f32;
            (target + glam::Quat::from_rotation_y(angle) * (eye - target), target)
        } else {
            scene.camera_at(i as f32 / (cli.frames - 1).max(1) as f32)
        };
        let frame = renderer.render_camera(&ctx, frame_eye, frame_target)?;
        let file = if cli.frames > 1 { numbered(out, i) } else { out.clone() };
        if exr {
            let channels = render::output::ExrChannels { coverage: cli.coverage, depth: cli.depth };
            let planes = (render::camera::NEAR, render::camera::FAR);
            render::output::write_exr(&file, &frame.linear, channels, planes)?;
        } else {
            render::output::write_png(&file, &frame.image)?;
        }
        let volumes = match frame.volume_characters {
            0 => String::new(),
            n => format!(", {n} character{} as volumes", if n == 1 { "" } else { "s" }),
        };
        println!(
            "{} ({}x{}, {} path, {} raster{volumes}, {:.0} ms)",
            file.display(),
            frame.image.width,
            frame.image.height,
            path,
            renderer.raster(),
            frame.timings.cpu_wait_ms
        );
        last = Some(frame);
    }
    let Some(frame) = last else { return Ok(()) };
    if cli.stats {
        println!("{}", frame.timings);
        println!(
            "strands {}, vertices {}, bundles culled {} of {}; {} characters as volumes, {} hairs voxelized",
            frame.stats.strands,
            frame.stats.vertices,
            frame.stats.bundles_culled,
            frame.stats.bundles,
            frame.volume_characters,
            frame.volumes_voxelized
        );
    }
    if let Some(json_path) = &cli.stats_json {
        let passes: Vec<serde_json::Value> = frame
            .timings
            .passes
            .iter()
            .map(|p| serde_json::json!({"name": p.name, "depth": p.depth, "gpu_ms": p.gpu_ms}))
            .collect();
        let json = serde_json::json!({
            "device": ctx.capabilities().device_name,
            "path": path.name(),
            "passes": passes,
            "wall_ms": frame.timings.cpu_wait_ms,
            "strands": frame.stats.strands,
            "vertices": frame.stats.vertices,
            "bundles": frame.stats.bundles,
            "bundles_culled": frame.stats.bundles_culled,
            "volume_characters": frame.volume_characters,
            "volumes_voxelized": frame.volumes_voxelized,
        });
        let text = serde_json::to_string_pretty(&json)?;
        hairmesh::atomic::write_file_atomic(json_path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", json_path.display()))?;
    }
    Ok(())
}
