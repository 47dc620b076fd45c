//! `hairkit`: device report and demo.
//!
//! ```text
//! hairkit info [--all] [--device SEL] [--path auto|mesh|compute]
//! hairkit demo [-o DIR] [--strands N] [--size WxH] [--device SEL] [--path auto|mesh|compute]
//! hairkit crowd [-o DIR] [--characters N] [--strands N] [--teapots N] [--teapot-strands N]
//!               [--size WxH] [--seed S]
//! ```

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand};
use gen_gpu::{Context, ContextDesc, GenerationPath, PathChoice, Validation};

#[derive(Parser, Debug)]
#[command(name = "hairkit", version, about = "hairkit: hair meshes rendered as strands generated on the GPU")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the Vulkan device's capability report and the generation path it will use.
    Info {
        /// List every Vulkan device on the machine first.
        #[arg(long)]
        all: bool,
        #[command(flatten)]
        device: DeviceArgs,
    },
    /// Run the demo: convert a scalp into hair assets, render a small crowd with hair generated
    /// on the GPU through each available path, write PNGs and print timings.
    Demo {
        /// Output folder.
        #[arg(short, long, default_value = "target/demo")]
        out: PathBuf,
        /// The scalp to convert (glTF or OBJ).
        #[arg(long, default_value = "assets/head_cap.gltf")]
        scalp: PathBuf,
        /// Strands per character.
        #[arg(long, default_value_t = 3000)]
        strands: u64,
        /// Characters in the crowd.
        #[arg(long, default_value_t = 6)]
        characters: u32,
        /// Image size, WIDTHxHEIGHT.
        #[arg(long, default_value = "640x360", value_parser = parse_size)]
        size: (u32, u32),
        #[command(flatten)]
        device: DeviceArgs,
    },
    /// Write crowd scenes: characters with unique hair meshes (variations of the head cap)
    /// and hairy Utah teapots, each with a camera path (`hair-render --frames N` follows it).
    Crowd(CrowdArgs),
}

/// `hairkit crowd`.
#[derive(Args, Debug)]
struct CrowdArgs {
    /// Output folder (asset folders, meshes, `heads.json`, `teapots.json`).
    #[arg(short, long, default_value = "target/crowd")]
    out: PathBuf,
    /// Characters with unique hair meshes.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=4096))]
    characters: u32,
    /// Strands per character.
    #[arg(long, default_value_t = 100_000, value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
    strands: u64,
    /// Hairy Utah teapots.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=4096))]
    teapots: u32,
    /// Strands per teapot.
    #[arg(long, default_value_t = 20_000, value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
    teapot_strands: u64,
    /// Image size of the scenes, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Seed of every random choice (same seed, same crowd).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Args, Debug)]
struct DeviceArgs {
    /// Device index (see `hairkit info --all`) or part of its name; default: HAIRKIT_DEVICE,
    /// else the best device (discrete > integrated > virtual > CPU).
    #[arg(long)]
    device: Option<String>,
    /// Generation path: `mesh` (task+mesh shaders), `compute` (fallback), or `auto`
    /// (HAIRKIT_PATH, else mesh on GPUs and compute on CPU devices).
    #[arg(long, default_value = "auto")]
    path: PathChoice,
    /// Enable the Khronos validation layer (also HAIRKIT_VALIDATION=1).
    #[arg(long)]
    validation: bool,
}

impl DeviceArgs {
    fn context(&self) -> Result<Context> {
        let desc = ContextDesc {
            validation: if self.validation { Validation::On } else { Validation::FromEnv },
            device: self.device.clone(),
        };
        Context::new(&desc).context("creating the Vulkan context")
    }

    /// The generation path on `ctx`: `--path`, else `HAIRKIT_PATH`, else the device default.
    fn path(&self, ctx: &Context) -> Result<GenerationPath> {
        Ok(self.path.resolve_with_env(ctx.capabilities())?)
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("`{v}` in `{s}`: {e}"));
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 || w > 8192 || h > 8192 {
        return Err(format!("{w}x{h}: width and height must be 1..=8192"));
    }
    Ok((w, h))
}

fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hairkit: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn crowd(args: &CrowdArgs) -> Result<()> {
    let options = hairkit_cli::crowd_scenes::CrowdOptions {
        out: args.out.clone(),
        characters: args.characters,
        strands: args.strands,
        teapots: args.teapots,
        teapot_strands: args.teapot_strands,
        size: args.size,
        seed: args.seed,
        ..hairkit_cli::crowd_scenes::CrowdOptions::default()
    };
    let start = Instant::now();
    let bar = indicatif::ProgressBar::new(0).with_style(
        indicatif::ProgressStyle::with_template("{msg:>20} [{bar:40}] {pos}/{len} ({eta} left)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let scenes = hairkit_cli::crowd_scenes::write_crowds(&options, |done, total, what| {
        bar.set_length(total);
        bar.set_position(done);
        bar.set_message(what.to_owned());
    })?;
    bar.finish_and_clear();
    println!(
        "{} characters × {} strands and {} teapots × {} strands in {:.1} s",
        args.characters,
        args.strands,
        args.teapots,
        args.teapot_strands,
        start.elapsed().as_secs_f64()
    );
    println!("{}\n{}", scenes.heads.display(), scenes.teapots.display());
    println!(
        "render one: hair-render {} -o crowd.png --stats   (add --frames N to follow the camera path)",
        scenes.heads.display()
    );
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Crowd(args) => crowd(&args),
        Command::Info { all, device } => {
            if all {
                println!("Vulkan devices:");
                for d in Context::list_devices()? {
                    println!("  {d}");
                }
                println!();
            }
            let ctx = device.context()?;
            println!("{}", ctx.capabilities());
            println!(
                "generation path:        {} (default for this device: {})",
                device.path(&ctx)?,
                GenerationPath::default_for(ctx.capabilities())
            );
            Ok(())
        }
        Command::Demo { out, scalp, strands, characters, size, device } => {
            demo(&DemoOptions { out, scalp, strands, characters, size }, &device)
        }
    }
}

struct DemoOptions {
    out: PathBuf,
    scalp: PathBuf,
    strands: u64,
    characters: u32,
    size: (u32, u32),
}

fn timed<T>(what: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    let start = Instant::now();
    let value = f()?;
    println!("{what}: {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
    Ok(value)
}

fn demo(o: &DemoOptions, device: &DeviceArgs) -> Result<()> {
    use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
    use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
    use hairmesh::style::{Clump, Curl, Style, Wave};

    if o.characters == 0 || o.characters > 400 {
        bail!("--characters {} (expected 1..=400)", o.characters);
    }
    let start = Instant::now();
    let ctx = device.context()?;
    let caps = ctx.capabilities();
    println!(
        "== device: {} ({}), VK_EXT_mesh_shader: {}, default path: {}
",
        caps.device_name,
        caps.driver_info,
        if caps.mesh_shader.is_some() { "yes" } else { "no" },
        device.path(&ctx)?
    );

    println!("== convert {}", o.scalp.display());
    let scalp = timed("import", || {
        hairmesh::import::load_scalp(&o.scalp, &hairmesh::ScalpSelector::All)
            .with_context(|| format!("{} (run from the repository root, or pass --scalp)", o.scalp.display()))
    })?;
    let variants = [
        (
            ExtrudeParams { layers: 4, length: 0.14, droop: 0.8, ..ExtrudeParams::default() },
            Style {
                width: 0.0015,
                curl: Curl { radius: 0.004, frequency: 30.0, phase: 0.0 },
                clump: Clump { strength: 0.3, exponent: 1.5 },
                length_variation: 0.25,
                ..Style::default()
            },
        ),
        (
            ExtrudeParams { layers: 6, length: 0.3, droop: 1.4, ..ExtrudeParams::default() },
            Style {
                width: 0.0015,
                wave: Wave { amplitude: 0.008, frequency: 8.0 },
                clump: Clump { strength: 0.5, exponent: 1.0 },
                length_variation: 0.15,
                seed: 7,
                ..Style::default()
            },
        ),
    ];
    let assets = timed("hair meshes, textures and root sets (2 styles)", || {
        variants
            .iter()
            .map(|(extrude, style)| {
                let hm = HairMesh::extrude(&scalp, extrude)?;
                Ok(HairAsset::build(
                    &hm,
                    &AssetParams {
                        strands: StrandCount::Total(o.strands),
                        sample_sets: 1,
                        seed: 1,
                        ..Default::default()
                    },
                    *style,
                )?)
            })
            .collect::<Result<Vec<_>>>()
    })?;
    let hairs = timed("upload", || {
        assets
            .iter()
            .map(|a| Ok(gen_gpu::GpuHair::upload(&ctx, a, gen_gpu::TexturePrecision::Auto)?))
            .collect::<Result<Vec<_>>>()
    })?;
    for (i, h) in hairs.iter().enumerate() {
        let stored = h.total_strands() * gen_gpu::MAX_VERTICES * gen_gpu::VERTEX_BYTES;
        println!(
            "  style {i}: {} bundles, {} strands; GPU asset {} bytes ({:?}) vs {} bytes as stored vertices ({:.0}x)",
            h.bundle_count(),
            h.total_strands(),
            h.bytes.total(),
            h.precision,
            stored,
            stored as f64 / h.bytes.total() as f64
        );
    }
    // The converted assets as asset folders, and a scene of a loose grid of characters facing
    // the camera, each turned a little, with OIT and self-shadowing.
    let asset_dirs: Vec<PathBuf> =
        (0..assets.len()).map(|i| o.out.join(format!("assets/style{i}"))).collect();
    timed("write asset folders", || {
        for (asset, dir) in assets.iter().zip(&asset_dirs) {
            hairmesh::asset_io::write_asset(
                dir,
                asset,
                hairmesh::asset_io::Precision::F32,
                "metres",
                o.scalp.to_str(),
            )?;
        }
        Ok(())
    })?;
    let columns = (f64::from(o.characters).sqrt().ceil() as u32).max(1);
    let rows = o.characters.div_ceil(columns);
    // Linear RGB.
    let colors = [
        [0.0073, 0.0039, 0.0018],
        [0.26, 0.089, 0.013],
        [0.32, 0.047, 0.0065],
        [0.45, 0.26, 0.073],
        [0.051, 0.016, 0.0048],
    ];
    let scalp_mesh = std::path::absolute(&o.scalp).with_context(|| format!("{}", o.scalp.display()))?;
    let characters: Vec<serde_json::Value> = (0..o.characters)
        .map(|i| {
            let (col, row) = (i % columns, i / columns);
            let x = (col as f32 - (columns - 1) as f32 / 2.0) * 0.45;
            let z = -(row as f32) * 0.5;
            let turn = (i as f32 * 2.4).sin() * 35.0;
            serde_json::json!({
                // Relative to the scene file, which is written into the same output folder.
                "hair": format!("assets/style{}", i as usize % asset_dirs.len()),
                "transform": { "translation": [x, 0.0, z], "rotation_y_degrees": turn },
                "color": colors[i as usize % colors.len()],
                // The scalp itself, drawn under the hair: it hides the hair behind the head and
                // casts and receives shadows.
                "occluder": { "mesh": scalp_mesh },
            })
        })
        .collect();
    let (width, height) = o.size;
    let scene_json = serde_json::json!({
        "output": { "width": width, "height": height },
        "camera": { "eye": [0.0, 2.3, 0.7 + 0.3 * columns as f32], "target": [0.0, 1.5, -0.25 * rows as f32], "fov_y_degrees": 50 },
        "lights": [
            { "directional": { "direction": [0.4, 0.8, 0.5], "color": [1.0, 0.97, 0.92] } },
            { "directional": { "direction": [-0.6, 0.3, -0.5], "color": [0.2, 0.25, 0.35], "cast_shadows": false } }
        ],
        "characters": characters,
        "effects": { "transparency": "oit", "shadows": true }
    });
    let scene_path = o.out.join("crowd.json");
    std::fs::create_dir_all(&o.out).with_context(|| format!("creating {}", o.out.display()))?;
    std::fs::write(&scene_path, serde_json::to_vec_pretty(&scene_json)?)
        .with_context(|| format!("writing {}", scene_path.display()))?;
    let scene = render::scene::load_scene(&scene_path)?;
    let mut paths = vec![GenerationPath::Compute];
    if caps.mesh_shader.is_some() {
        paths.push(GenerationPath::Mesh);
    }
    if device.path != PathChoice::Auto {
        let chosen = device.path(&ctx)?;
        paths.retain(|p| *p == chosen);
    }
    println!(
        "\n== crowd: {} characters, {width}x{height}, scalp occluders, OIT + deep-opacity shadows ({})",
        o.characters,
        scene_path.display()
    );
    for path in paths {
        let renderer = timed(&format!("{path} path: upload + pipelines"), || {
            Ok(render::frame::SceneRenderer::new(&ctx, &scene, path)?)
        })?;
        if path == GenerationPath::Compute {
            println!("frame graph:\n{}", renderer.graph());
        }
        let first = renderer.render(&ctx)?;
        let frame = renderer.render(&ctx)?;
        let file = o.out.join(format!("crowd-{path}.png"));
        render::output::write_png(&file, &frame.image)?;
        println!("{path} path -> {}", file.display());
        println!(
            "  first frame: {:.1} ms wall (shader compilation) + {:.1} ms GPU for the shadow maps, computed once",
            first.timings.cpu_wait_ms,
            first.shadow_ms.unwrap_or(0.0)
        );
        println!(
            "  strands {} ({} of {} bundles culled), vertices {}, OIT fragments dropped {}",
            frame.stats.strands,
            frame.stats.bundles_culled,
            frame.stats.bundles,
            frame.stats.vertices,
            frame.oit_overflow.unwrap_or(0)
        );
        println!("{}", frame.timings);
    }
    println!("\ndemo finished in {:.2} s", start.elapsed().as_secs_f64());
    Ok(())
}
