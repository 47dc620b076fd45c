//! `hair-render SCENE -o frame.png`: renders a scene file (see `render::scene`).
//!
//! ```text
//! hair-render SCENE -o OUT.png|OUT.exr [--depth] [--coverage] [--frames N|START..END]
//!             [--simulate] [--sim-cache FILE]
//!             [--path auto|mesh|compute] [--raster auto|triangles|compute]
//!             [--device SEL] [--print-graph]
//!             [--stats] [--stats-json FILE] [--repeat N] [--validation]
//! ```
//!
//! `.png` output is 8-bit sRGB; `.exr` output is linear half-float RGB with an optional `A`
//! (coverage) and `Z` (view-space distance) channel.
//!
//! Animations (`render::animation`): `--frames START..END` renders frames START to END − 1 of
//! the scene's animation, numbered by their absolute index, exactly as one full run would; with
//! dynamics, `--simulate` writes the simulation cache (`--sim-cache FILE`, else beside the
//! output: `-o out/frame.png` → `out/frame.sim`) that every process rendering a range then reads
//! (without it, a process simulates from frame 0 in memory, with the same result). The default
//! keeps the cache with the frames, never beside the scene, which may sit in a checkout.
//!
//! Timing: `--stats` prints the last frame's per-pass GPU times; `--repeat N` renders that frame
//! N more times (the first frame pays shader compilation and cache fills; on a CPU device frames
//! vary by 5–10 %) and reports each pass's median and quartiles over those N instead.

use std::path::PathBuf;

use anyhow::{Context as _, Result};
use clap::Parser;
use gen_gpu::{Context, ContextDesc, PathChoice, Validation};
use hairmesh::output::{FileKind, Replace};
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
    /// Render the last frame N more times and report each pass's median GPU time and quartiles
    /// over those frames (with --stats and/or --stats-json): the first frame pays shader
    /// compilation and cache fills, and frames vary from one to the next.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_REPEAT as i64))]
    repeat: Option<u32>,
    /// Enable the Khronos validation layer (also HAIRKIT_VALIDATION=1).
    #[arg(long)]
    validation: bool,
    /// Frames to render: `N` (frames 0..N) or a half-open range `START..END` of the scene's
    /// animation. Without an `animation` block, N frames orbit the camera once around its
    /// target (or follow its `camera_path`). Files are numbered by absolute frame
    /// (`out.png` → `out-0007.png`) whenever the animation has more than one frame.
    #[arg(long, default_value = "1")]
    frames: FrameRange,
    /// Simulate the scene's dynamics for its whole animation into the simulation cache, then
    /// render what -o asks for (nothing without -o).
    #[arg(long)]
    simulate: bool,
    /// The simulation cache [default: beside the output, OUT with the extension `.sim`].
    #[arg(long)]
    sim_cache: Option<PathBuf>,
    /// Replace output files even when they are not images / statistics / caches written by
    /// hairkit (never the scene or a file it refers to).
    #[arg(long)]
    force: bool,
}

/// What the statistics JSON holds at its top level (how an earlier one is recognized).
const STATS_JSON: FileKind =
    FileKind::Json { what: "hair-render statistics file", keys: &["device", "passes"] };

/// Most frames `--repeat` renders (a bound on a typo's cost, not on what is useful).
const MAX_REPEAT: u32 = 1000;

/// `N` or `START..END` (half-open).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct FrameRange {
    start: u32,
    end: u32,
    /// Written as a range (`START..END`) rather than a count.
    range: bool,
}

impl std::str::FromStr for FrameRange {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let number =
            |x: &str| x.trim().parse::<u32>().map_err(|e| format!("{x:?} is not a frame number ({e})"));
        let (start, end, range) = match s.split_once("..") {
            Some((a, b)) => (number(a)?, number(b)?, true),
            None => (0, number(s)?, false),
        };
        if start >= end {
            return Err(format!("{s:?} holds no frame (expected N ≥ 1 or START..END with START < END)"));
        }
        if end > render::scene::MAX_FRAMES {
            return Err(format!("{s:?} ends past frame {}", render::scene::MAX_FRAMES));
        }
        Ok(Self { start, end, range })
    }
}

/// `dir/name.png` → `dir/name-0007.png`.
fn numbered(path: &std::path::Path, index: u32) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    path.with_file_name(format!("{stem}-{index:04}{ext}"))
}

fn main() -> std::process::ExitCode {
    hairmesh::terminal::exit_quietly_on_closed_pipe();
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
    // The animation's length decides the camera of every frame, so a range renders the frames
    // a full run would.
    let length = match scene.scene.animation {
        Some(a) => {
            if cli.frames.end > a.frames {
                anyhow::bail!(
                    "--frames {}..{}: the scene's animation has {} frames (0..{})",
                    cli.frames.start,
                    cli.frames.end,
                    a.frames,
                    a.frames
                );
            }
            a.frames
        }
        None if cli.frames.start > 0 || cli.frames.range && cli.frames.end > 1 => anyhow::bail!(
            "--frames {}..{}: a frame range needs the scene's animation length; add \"animation\": {{\"frames\": N}} to {}",
            cli.frames.start,
            cli.frames.end,
            cli.scene.display()
        ),
        None => cli.frames.end,
    };
    let cache_path = cli.sim_cache.clone().or_else(|| cli.out.as_ref().map(|out| out.with_extension("sim")));
    if cli.simulate && cache_path.is_none() {
        anyhow::bail!(
            "--simulate: where should the simulation cache go? Give --sim-cache FILE, or -o OUT (the cache then goes beside it, as OUT.sim)"
        );
    }
    let image_kind = check_outputs(cli, &scene, length, cache_path.as_deref())?;
    let mut instance = render::instance::SceneInstance::load(&scene)?;
    let animation = render::animation::Animation::new(&mut instance)?;
    if let (true, Some(cache_path)) = (cli.simulate, &cache_path) {
        if animation.dynamic_characters() == 0 {
            anyhow::bail!("--simulate: {} has no character with dynamics", cli.scene.display());
        }
        let started = std::time::Instant::now();
        let frames = animation.frames();
        let bytes = render::sim_cache::cache_bytes(&animation, frames);
        hairmesh::output::check_space(cache_path, bytes)?;
        eprintln!(
            "simulating {frames} frames into {} ({})",
            cache_path.display(),
            hairmesh::terminal::bytes(bytes)
        );
        let bar = indicatif::ProgressBar::new(u64::from(frames)).with_style(
            indicatif::ProgressStyle::with_template(
                "simulating [{bar:30}] {pos}/{len} frames {elapsed} ({eta} left)",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        render::sim_cache::write_sim_cache(&animation, frames, cache_path, &|f| {
            bar.set_position(u64::from(f));
        })?;
        bar.finish_and_clear();
        println!(
            "{} ({} frames of {} character{}, {:.0} ms)",
            cache_path.display(),
            frames,
            animation.dynamic_characters(),
            if animation.dynamic_characters() == 1 { "" } else { "s" },
            started.elapsed().as_secs_f64() * 1e3
        );
    }
    if cli.repeat.is_some() && !cli.stats && cli.stats_json.is_none() {
        anyhow::bail!("--repeat times frames that nothing would report: add --stats and/or --stats-json");
    }
    if cli.out.is_none() && !cli.print_graph {
        if cli.simulate {
            return Ok(());
        }
        anyhow::bail!("nothing to do: give -o OUT.png and/or --print-graph");
    }
    let ctx = Context::new(&ContextDesc {
        validation: if cli.validation { Validation::On } else { Validation::FromEnv },
        device: cli.device.clone(),
    })?;
    let path = cli.path.resolve_with_env(ctx.capabilities())?;
    let mut renderer = SceneRenderer::from_instance(&ctx, &instance, path)?;
    if cli.print_graph {
        print!("{}", renderer.graph());
    }
    let Some(out) = &cli.out else { return Ok(()) };
    let exr = image_kind == Some(FileKind::Exr);
    // Hair-mesh positions per frame: from the cache when it holds the range, else simulated here.
    let cache = match &cache_path {
        Some(cache_path) if animation.dynamic_characters() > 0 => {
            match render::sim_cache::SimCache::open(cache_path, &animation) {
                Ok(c) if c.frames() >= cli.frames.end => Some((c, cache_path)),
                Ok(c) => {
                    eprintln!(
                        "hair-render: {} holds frames 0..{}, not ..{}: simulating in memory",
                        cache_path.display(),
                        c.frames(),
                        cli.frames.end
                    );
                    None
                }
                Err(e) => {
                    eprintln!(
                        "hair-render: no usable simulation cache ({e}): simulating frames 0..{} in memory (hair-render {} --simulate --sim-cache {} writes one for every process to share)",
                        cli.frames.end,
                        cli.scene.display(),
                        cache_path.display()
                    );
                    None
                }
            }
        }
        _ => None,
    };
    let mut live = animation.start();
    let mut player = render::animation::Player::new(&animation);
    let mut last = None;
    let loop_start = std::time::Instant::now();
    for i in cli.frames.start..cli.frames.end {
        let (frame_eye, frame_target) = scene.frame_camera(i, length);
        let update = if animation.moves() {
            let simulated;
            let cached;
            let positions = match &cache {
                // The cache was checked to hold every frame of the range.
                Some((c, file)) => {
                    cached = c.positions(i)?.with_context(|| format!("{}: frame {i}", file.display()))?;
                    &cached
                }
                None => {
                    while live.frame() < i {
                        live.advance();
                    }
                    simulated = live.positions();
                    &simulated
                }
            };
            Some(player.show(&animation, &mut renderer, &ctx, i, positions)?)
        } else {
            None
        };
        let frame = renderer.render_camera(&ctx, frame_eye, frame_target)?;
        let file = if length > 1 { numbered(out, i) } else { out.clone() };
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
        let dynamics = match update {
            Some(u) if u.rebaked > 0 => format!(", {} re-baked in {:.1} ms", u.rebaked, u.rebake_ms),
            _ => String::new(),
        };
        // Long sequences say how long the rest will take (from the frames so far).
        let done = i + 1 - cli.frames.start;
        let left = cli.frames.end - 1 - i;
        let eta = if left > 0 && done > 0 {
            let seconds = loop_start.elapsed().as_secs_f64() / f64::from(done) * f64::from(left);
            format!(", {left} frames ≈ {seconds:.0} s left")
        } else {
            String::new()
        };
        println!(
            "{} ({}x{}, {} path, {} raster{volumes}{dynamics}, {:.0} ms{eta})",
            file.display(),
            frame.image.width,
            frame.image.height,
            path,
            renderer.raster(),
            frame.timings.cpu_wait_ms
        );
        if let Some(warning) = budget_warning(&frame) {
            eprintln!("warning: {}: {warning}", file.display());
        }
        last = Some(frame);
    }
    let Some(frame) = last else { return Ok(()) };
    // The last frame again, as it was (its camera, its animation state), timed only.
    let repeated = match cli.repeat {
        Some(n) => {
            let i = cli.frames.end - 1;
            let (eye, target) = scene.frame_camera(i, length);
            let bar = indicatif::ProgressBar::new(u64::from(n)).with_style(
                indicatif::ProgressStyle::with_template(&format!(
                    "timing frame {i} [{{bar:30}}] {{pos}}/{{len}} {{elapsed}}"
                ))
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            let mut timings = Vec::with_capacity(n as usize);
            for _ in 0..n {
                timings.push(renderer.render_camera(&ctx, eye, target)?.timings);
                bar.inc(1);
            }
            bar.finish_and_clear();
            Some(gen_gpu::TimingSummary::of(&timings))
        }
        _ => None,
    };
    if cli.stats {
        match &repeated {
            Some(summary) => println!("{summary}"),
            None => println!("{}", frame.timings),
        }
        println!(
            "strands {}, vertices {}, bundles culled {} of {}; {} characters as volumes, {} hairs voxelized",
            frame.stats.strands,
            frame.stats.vertices,
            frame.stats.bundles_culled,
            frame.stats.bundles,
            frame.volume_characters,
            frame.volumes_voxelized
        );
        if let (Some(overflow), Some(pool)) = (frame.oit_overflow, frame.oit_pool) {
            println!(
                "OIT: {pool} nodes, {overflow} fragments beyond them (blended into their pixels' overflow tails)"
            );
        }
        if let (Some(overflow), Some(slots)) = (frame.raster_overflow, frame.raster_slots) {
            println!(
                "compute raster: {slots} visibility slots per pixel, {overflow} pixels with more fragments"
            );
        }
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
            "oit_overflow": frame.oit_overflow,
            "oit_pool": frame.oit_pool,
            "raster_overflow": frame.raster_overflow,
            "raster_slots": frame.raster_slots,
            "repeated": repeated.as_ref().map(|r| serde_json::json!({
                "frames": r.frames,
                "wall_ms_median": r.wall_median_ms,
                "passes": r.passes.iter().map(|p| serde_json::json!({
                    "name": p.name,
                    "depth": p.depth,
                    "frames": p.frames,
                    "gpu_ms_median": p.median_ms,
                    "gpu_ms_q1": p.q1_ms,
                    "gpu_ms_q3": p.q3_ms,
                })).collect::<Vec<_>>(),
            })),
        });
        let text = serde_json::to_string_pretty(&json)?;
        hairmesh::atomic::write_file_atomic(json_path, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", json_path.display()))?;
    }
    Ok(())
}

/// Every file this run would write may be written (before anything is loaded or simulated):
/// none is an input, and each is new or an earlier output of its kind unless `--force`.
/// Returns the kind of image `-o` asks for.
fn check_outputs(
    cli: &Cli,
    scene: &render::scene::LoadedScene,
    length: u32,
    cache: Option<&std::path::Path>,
) -> Result<Option<FileKind>> {
    let inputs = scene.input_files();
    let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
    let replace = Replace::from_force(cli.force);
    if let (true, Some(cache)) = (cli.simulate, cache) {
        hairmesh::output::check_file(cache, FileKind::SimCache, &inputs, replace)?;
    }
    if let Some(path) = &cli.stats_json {
        hairmesh::output::check_file(path, STATS_JSON, &inputs, replace)?;
    }
    if let Some(out) = &cli.out {
        let kind = FileKind::from_extension(out)
            .filter(|k| matches!(k, FileKind::Png | FileKind::Exr))
            .with_context(|| format!("{}: the output must end in .png or .exr", out.display()))?;
        if kind != FileKind::Exr && (cli.depth || cli.coverage) {
            anyhow::bail!("--depth and --coverage need an .exr output (PNG is 8-bit sRGB colour)");
        }
        for i in cli.frames.start..cli.frames.end {
            let file = if length > 1 { numbered(out, i) } else { out.clone() };
            hairmesh::output::check_file(&file, kind, &inputs, replace)?;
        }
        // What the images may take: PNG at most its raw RGBA bytes, EXR half floats.
        let frames = u64::from(cli.frames.end - cli.frames.start);
        let pixels = u64::from(scene.scene.output.width) * u64::from(scene.scene.output.height);
        let per_image = match kind {
            FileKind::Exr => pixels * 2 * (3 + u64::from(cli.coverage) + u64::from(cli.depth)),
            _ => pixels * 4,
        } + 4096;
        hairmesh::output::check_space(out, frames * per_image)?;
        if frames > 1 {
            eprintln!(
                "rendering {frames} frames of {}×{} (at most {} of images)",
                scene.scene.output.width,
                scene.scene.output.height,
                hairmesh::terminal::bytes(frames * per_image)
            );
        }
        return Ok(Some(kind));
    }
    Ok(None)
}

/// What a user should know when a frame outgrew a budget: the OIT node pool (its overflow is
/// blended order-independently, so the hair's layering is approximate where it happened).
fn budget_warning(frame: &render::frame::RenderedFrame) -> Option<String> {
    let (overflow, pool) = (frame.oit_overflow?, frame.oit_pool?);
    (overflow > 0).then(|| {
        format!(
            "{overflow} hair fragments found the OIT node pool ({pool} nodes) full and were blended \
             order-independently; raise effects.oit_nodes_per_pixel (the pool is also capped at \
             {} MiB, or by the device's storage-buffer range where it has no buffer device \
             addresses) or use \"raster\": \"compute\"",
            render::frame::OIT_POOL_BYTES >> 20
        )
    })
}
