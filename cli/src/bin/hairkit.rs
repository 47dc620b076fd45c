//! `hairkit`: device report and demo.
//!
//! ```text
//! hairkit info [--all] [--device SEL] [--path auto|mesh|compute]
//! hairkit demo [-o DIR] [--strands N] [--size WxH] [--device SEL] [--path auto|mesh|compute]
//! hairkit crowd [-o DIR] [--characters N] [--strands N] [--teapots N] [--teapot-strands N]
//!               [--size WxH] [--seed S]
//! ```

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result};
use clap::{Args, Parser, Subcommand};
use gen_gpu::{Context, ContextDesc, GenerationPath, PathChoice, Validation};
use hairmesh::output::Replace;

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
        /// The data set's folder (`heads/LeePerrySmith/…`, `heads/sintel/…`, `strands/…`).
        /// Default: where `HAIRKIT_DATA` points, else the folder beside the checkout, else the
        /// user cache (`cargo xtask data` fills it); without any, the demo renders the
        /// project's own head cap instead.
        #[arg(long)]
        data: Option<PathBuf>,
        /// Strands per generated hairstyle (1..=2000000).
        #[arg(long, default_value_t = 20_000, value_parser = clap::value_parser!(u64).range(1..=2_000_000))]
        strands: u64,
        /// People in the picture (they take the three looks in turn; 1..=400).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=400))]
        characters: u32,
        /// Image size, WIDTHxHEIGHT.
        #[arg(long, default_value = "960x400", value_parser = parse_size)]
        size: (u32, u32),
        /// Rasterizer of the people: auto (the compute rasterizer on CPU devices), triangles
        /// or compute.
        #[arg(long, default_value = "auto")]
        raster: render::scene::Raster,
        /// Write into the output folder even if it is not an earlier demo's (files of the same
        /// names in it are replaced; nothing else is touched).
        #[arg(long)]
        force: bool,
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
    /// Also write `heads_animated.json`: every head moving with its own phase, its hair
    /// simulated in its own wind (render it with `hair-render --frames`).
    #[arg(long)]
    animated: bool,
    /// Write into the output folder even if it is not an earlier crowd's (files of the same
    /// names in it are replaced; nothing else is touched).
    #[arg(long)]
    force: bool,
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
    hairmesh::terminal::exit_quietly_on_closed_pipe();
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
        animated: args.animated,
        replace: Replace::from_force(args.force),
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
    if let Some(animated) = &scenes.heads_animated {
        println!("{}", animated.display());
    }
    println!(
        "render one: hair-render {} -o {} --stats   (add --frames N to follow the camera path)",
        scenes.heads.display(),
        scenes.heads.with_extension("png").display()
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
        Command::Demo { out, data, strands, characters, size, raster, force, device } => {
            demo(&DemoOptions { out, data, strands, characters, size, raster, force }, &device)
        }
    }
}

struct DemoOptions {
    out: PathBuf,
    data: Option<PathBuf>,
    strands: u64,
    characters: u32,
    size: (u32, u32),
    raster: render::scene::Raster,
    force: bool,
}

/// The command named in a demo folder's marker.
const DEMO_COMMAND: &str = "hairkit demo";

fn timed<T>(what: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    let start = Instant::now();
    let value = f()?;
    println!("{what}: {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
    Ok(value)
}

use hairmesh::convert::sample_head::{SCALP as LEE_PERRY_SMITH_SCALP, SKULL_CENTRE as LEE_PERRY_SMITH_SKULL};

/// The heads the demo puts hair on.
struct DemoPeople {
    /// The head mesh (the scalp's file, drawn as each generated hairstyle's occluder).
    head: PathBuf,
    /// Its scalp, in the LeePerrySmith scan's frame and units.
    scalp: hairmesh::ScalpMesh,
    /// The artist's Sintel groom and its bust, when the data set has them.
    groom: Option<(PathBuf, PathBuf)>,
}

/// The real heads from the data set (`--data`, else the resolver); when the resolver finds
/// none, the project's own head cap, placed and scaled like the scan's head, written to `out`.
fn demo_people(data: Option<&Path>, out: &Path) -> Result<DemoPeople> {
    let set = match data {
        Some(dir) => data_set::DataSet::new(Some(dir.into()), None, None),
        None => data_set::DataSet::from_env(),
    };
    let found = set.locate(hairmesh::convert::sample_head::PATH).and_then(|head| {
        let bust = set.locate("heads/sintel/sintel_bust.obj")?;
        Ok((head, bust, set.locate("strands/tressfx/v4/sintel_hair_full_16points.tfx")?))
    });
    match found {
        Ok((head, bust, groom)) => {
            println!("== convert {} (scalp `{LEE_PERRY_SMITH_SCALP}`)", head.display());
            let scalp = timed("import and scalp selection", || {
                let selector = hairmesh::ScalpSelector::parse(LEE_PERRY_SMITH_SCALP)?;
                hairmesh::import::load_scalp(&head, &selector).with_context(|| format!("{}", head.display()))
            })?;
            Ok(DemoPeople { head, scalp, groom: Some((groom, bust)) })
        }
        // A folder the user named must hold the data: say what is missing there.
        Err(missing) if let Some(dir) = data => {
            Err(anyhow::Error::new(missing).context(format!("--data {}", dir.display())))
        }
        Err(missing) => {
            println!(
                "== {missing}\n== until then: hair on the project's own head cap (assets/head_cap.gltf)\n"
            );
            let mut scalp = hairmesh::procedural::head_cap(8, 32);
            // The cap (metres, centred at y = 1.6) scaled and moved onto the scan's skull, so
            // that the hairstyles, camera and spacing below fit it unchanged.
            let skull = glam::DVec3::from_array(LEE_PERRY_SMITH_SKULL);
            for p in &mut scalp.positions {
                *p = (*p - glam::DVec3::new(0.0, 1.6, 0.0)) * HEAD_CAP_SCALE + skull;
            }
            let head = out.join("head_cap.gltf");
            hairmesh::procedural::write_gltf(&head, &scalp, "head cap")
                .with_context(|| format!("writing {}", head.display()))?;
            Ok(DemoPeople { head, scalp, groom: None })
        }
    }
}

/// The LeePerrySmith scan's skull is about 21 times the head cap's (a 9.5 cm crown height).
const HEAD_CAP_SCALE: f64 = 21.0;

fn demo(o: &DemoOptions, device: &DeviceArgs) -> Result<()> {
    use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
    use hairmesh::hair_mesh::{DrapeParams, ExtrudeParams, HairMesh};
    use hairmesh::style::{Clump, Curl, Style, Wave};

    let own = ["assets", "people.json", "people-*", "head_cap.gltf"];
    hairmesh::output::check_command_folder(&o.out, DEMO_COMMAND, &own, Replace::from_force(o.force))?;
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

    std::fs::create_dir_all(&o.out).with_context(|| format!("creating {}", o.out.display()))?;
    hairmesh::output::mark_folder(&o.out, DEMO_COMMAND)
        .with_context(|| format!("writing into {}", o.out.display()))?;
    let people = demo_people(o.data.as_deref(), &o.out)?;
    let (head, scalp) = (people.head, people.scalp);
    // The long hair slides over the whole head mesh (ears, shoulders), not only around the skull.
    let head_surface = hairmesh::head::HeadSurface::from_mesh(
        &hairmesh::import::load_scalp(&head, &hairmesh::ScalpSelector::All)
            .with_context(|| format!("{}", head.display()))?,
    );
    let clearance = hairmesh::convert::clearance(&head_surface);
    let mut long = HairMesh::drape_over(
        &scalp,
        &DrapeParams {
            layers: 6,
            length: 4.5,
            centre: glam::DVec3::from_array(LEE_PERRY_SMITH_SKULL),
            lift: 0.04,
            gravity: glam::DVec3::NEG_Y,
            comb: glam::DVec3::new(0.0, 0.0, -2.5),
        },
        Some((&head_surface, clearance)),
    )?;
    let long_style = Style {
        width: 0.008,
        wave: Wave { amplitude: 0.06, frequency: 1.2, coherence: 0.0 },
        clump: Clump { strength: 0.45, exponent: 1.2 },
        length_variation: 0.2,
        seed: 7,
        ..Style::default()
    };
    // Far enough out that the waves stay out of the head.
    hairmesh::convert::keep_outside(&mut long, &head_surface, &long_style);
    let short = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 3, length: 0.45, droop: 0.5, ..ExtrudeParams::default() },
    )?;
    let looks = [
        ("long, combed back", long, long_style),
        (
            "short and curly",
            short,
            Style {
                width: 0.008,
                curl: Curl { radius: 0.05, frequency: 5.0, phase: 0.0 },
                clump: Clump { strength: 0.3, exponent: 1.5 },
                length_variation: 0.3,
                ..Style::default()
            },
        ),
    ];
    let assets = timed("hair meshes, textures and root sets (2 hairstyles)", || {
        looks
            .iter()
            .map(|(_, hm, style)| {
                Ok(HairAsset::build(
                    hm,
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
    for ((name, _, _), asset) in looks.iter().zip(&assets) {
        let h = gen_gpu::GpuHair::upload(&ctx, asset, gen_gpu::TexturePrecision::Auto)?;
        let stored = h.total_strands() * gen_gpu::MAX_VERTICES * gen_gpu::VERTEX_BYTES;
        println!(
            "  {name}: {} bundles, {} strands; GPU asset {} bytes ({:?}) vs {} bytes as stored vertices ({:.0}x)",
            h.bundle_count(),
            h.total_strands(),
            h.bytes.total(),
            h.precision,
            stored,
            stored as f64 / h.bytes.total() as f64
        );
    }
    let asset_dirs: Vec<PathBuf> =
        (0..assets.len()).map(|i| o.out.join(format!("assets/style{i}"))).collect();
    timed("write asset folders", || {
        for (asset, dir) in assets.iter().zip(&asset_dirs) {
            hairmesh::asset_io::write_asset(
                dir,
                asset,
                hairmesh::asset_io::Precision::F32,
                "file units",
                head.to_str(),
            )?;
        }
        Ok(())
    })?;
    // People in rows of up to five, taking the three looks in turn: the two generated styles on
    // the LeePerrySmith scan, and the artist's Sintel groom (TressFX, drawn as stored strands)
    // on the Sintel bust, scaled to the same head size. Each head is an occluder: it hides the
    // hair behind it and casts and receives the hair's shadows.
    let columns = o.characters.min(5);
    let rows = o.characters.div_ceil(columns);
    let absolute = |p: &Path| std::path::absolute(p).with_context(|| format!("{}", p.display()));
    let head = absolute(&head)?;
    let groom = people
        .groom
        .as_ref()
        .map(|(groom, bust)| Ok::<_, anyhow::Error>((absolute(groom)?, absolute(bust)?)));
    let groom = groom.transpose()?;
    let looks_count = if groom.is_some() { 3 } else { 2 };
    let characters: Vec<serde_json::Value> = (0..o.characters)
        .map(|i| {
            let (col, row) = (i % columns, i / columns);
            let x = (col as f32 - (columns - 1) as f32 / 2.0) * 6.5;
            let z = -(row as f32) * 7.0;
            match (i % looks_count, &groom) {
                (2, Some((groom, bust))) => serde_json::json!({
                    // The groom is in metres on a bust in centimetres 1.195 m below it (the
                    // artist's guide file); ×19 brings it to the scan's head size.
                    "hair": groom,
                    "strand_width": 0.0004,
                    "transform": { "translation": [x, -27.6, z], "scale": 19.0 },
                    "color": [0.171, 0.0397, 0.00719],
                    "occluder": { "mesh": bust, "transform": { "scale": 0.01, "translation": [0, 1.195, 0] }, "color": [0.62, 0.45, 0.36] },
                }),
                (look, _) => serde_json::json!({
                    // Relative to the scene file, which is written into the same output folder.
                    "hair": format!("assets/style{look}"),
                    "transform": { "translation": [x, 0.0, z], "rotation_y_degrees": if look == 0 { 12.0 } else { -12.0 } },
                    "color": if look == 0 { [0.11, 0.045, 0.014] } else { [0.012, 0.0065, 0.003] },
                    "occluder": { "mesh": head, "color": [0.62, 0.45, 0.36] },
                }),
            }
        })
        .collect();
    let (width, height) = o.size;
    // Far enough back that the front row (6.5 units a person, shoulders ±4.3) fills the width
    // or the height (heads 9 units from the shoulders' bottom to the hair's top), whichever
    // binds first; each further row adds its depth.
    let fov_y = 36f32.to_radians();
    let aspect = width as f32 / height.max(1) as f32;
    let fit_width = (columns as f32 * 6.5 / 2.0 + 0.5) / ((fov_y / 2.0).tan() * aspect);
    let fit_height = 5.5 / (fov_y / 2.0).tan();
    let distance = fit_width.max(fit_height) + 3.0 * (rows - 1) as f32;
    let scene_json = serde_json::json!({
        "output": { "width": width, "height": height },
        "camera": {
            "eye": [0.0, 2.6, distance],
            "target": [0.0, 0.9, -3.5 * (rows - 1) as f32],
            "fov_y_degrees": 36
        },
        "lights": [
            { "directional": { "direction": [0.35, 0.7, 0.6], "color": [1.0, 0.96, 0.9] } },
            { "directional": { "direction": [-0.6, 0.2, 0.5], "color": [0.25, 0.28, 0.35], "cast_shadows": false } },
            { "directional": { "direction": [0.0, 0.4, -1.0], "color": [0.35, 0.35, 0.4], "cast_shadows": false } }
        ],
        "characters": characters,
        "effects": {
            "transparency": "oit",
            "shadows": true,
            "ao": true,
            "raster": o.raster
        }
    });
    let scene_path = o.out.join("people.json");
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
        "\n== people: {} characters, {width}x{height}, heads as occluders, OIT + deep-opacity shadows + volume AO ({})",
        o.characters,
        scene_path.display()
    );
    let mut compute_raster_ms = None;
    // The same people through the triangle raster: the task + mesh path's picture when the
    // compute rasterizer (which generates its own strands) draws the scene, and the comparison.
    let mut triangles = scene.clone();
    triangles.scene.effects.raster = render::scene::Raster::Triangles;
    let effects = scene.scene.effects;
    let compute_raster = render::raster::resolve_raster(effects.raster, &effects, ctx.capabilities())?
        == render::raster::RasterPath::Compute;
    for path in paths {
        let path_scene = if compute_raster && path != GenerationPath::Compute { &triangles } else { &scene };
        let renderer = timed(&format!("{path} path: upload + pipelines"), || {
            Ok(render::frame::SceneRenderer::new(&ctx, path_scene, path)?)
        })?;
        if renderer.raster() == render::raster::RasterPath::Compute {
            println!(
                "hair in the view and the shadow maps drawn by the compute rasterizer (generation fused into its kernels)"
            );
        } else if compute_raster {
            println!(
                "{path} path: generating for the triangle raster (the compute rasterizer fuses its own)"
            );
        }
        if path == GenerationPath::Compute {
            println!("frame graph:\n{}", renderer.graph());
        }
        let first = renderer.render(&ctx)?;
        let frame = renderer.render(&ctx)?;
        let file = o.out.join(format!("people-{path}.png"));
        render::output::write_png(&file, &frame.image)?;
        println!("{path} path, {} raster -> {}", renderer.raster(), file.display());
        println!(
            "  first frame: {:.1} ms wall (shader compilation) + {:.1} ms GPU for the shadow maps, computed once",
            first.timings.cpu_wait_ms,
            first.shadow_ms.unwrap_or(0.0)
        );
        println!(
            "  strands {} ({} of {} bundles culled), vertices {}, OIT fragments beyond the node pool (blended order-independently) {}",
            frame.stats.strands,
            frame.stats.bundles_culled,
            frame.stats.bundles,
            frame.stats.vertices,
            frame.oit_overflow.unwrap_or(0)
        );
        println!("{}", frame.timings);
        if renderer.raster() == render::raster::RasterPath::Compute && path == GenerationPath::Compute {
            compute_raster_ms = frame.timings.pass_ms("scene frame");
        }
    }
    // What the compute rasterizer saves: the same picture through the triangle raster.
    if let Some(compute_ms) = compute_raster_ms {
        let renderer = render::frame::SceneRenderer::new(&ctx, &triangles, GenerationPath::Compute)?;
        renderer.render(&ctx)?;
        let frame = renderer.render(&ctx)?;
        let file = o.out.join("people-triangles.png");
        render::output::write_png(&file, &frame.image)?;
        let triangles_ms = frame.timings.pass_ms("scene frame").unwrap_or(f64::NAN);
        println!(
            "\ntriangle raster (compute path) -> {}: frame {triangles_ms:.1} ms against {compute_ms:.1} ms with the compute rasterizer ({:.1}×)",
            file.display(),
            triangles_ms / compute_ms
        );
    }
    println!("\ndemo finished in {:.2} s", start.elapsed().as_secs_f64());
    Ok(())
}
