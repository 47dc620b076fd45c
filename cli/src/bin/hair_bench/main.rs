//! `hair-bench`: GPU benchmarks of on-the-fly strand generation, written into
//! `target/bench/benchmarks.md` (between markers, so other sections stay) and CSV files;
//! `--out docs` updates the project's report, which is the only way it is rewritten.
//!
//! ```text
//! hair-bench [--quick] [--only SECTION[,SECTION]] [--out DIR] [--device SEL]
//! ```
//! Sections: `generation`, `memory`, `stored`, `accuracy`, `crowd`, `passes`, `raster`, `shadows`,
//! `volume`, `dynamics`; each sits between its own markers in the report, so `--only` replaces just those.
//! Tables: generation + raster per path, GPU memory of an asset vs the same strands stored,
//! on-the-fly vs stored strands, accuracy vs time, crowds with LOD off and on (the scenes of
//! `hairkit crowd`), render passes, both rasterizers, deep opacity maps both ways, the volume LOD
//! path, dynamics (simulation,
//! re-bake and upload per character; an animated crowd); CSV files beside the report and PNG plots
//! (`plot-*.png`). A progress bar shows the stage on a terminal.

mod accuracy;
mod collision;
mod crowd;
mod dynamics;
mod generation;
mod memory;
mod passes;
mod raster;
mod shadows;
mod stored;
mod volume;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use clap::Parser;
use gen_gpu::{
    Context, ContextDesc, Filtering, GenerationPath, Generator, GeneratorOptions, GpuHair, TexturePrecision,
    Validation,
};
use glam::{Mat4, Vec3};
use hairkit_cli::bench_crowd::{
    Camera, Character, FrameView, generate_alone, prepare_crowd, render_crowd, render_prepared,
};
use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::reference::LodParams;
use hairmesh::style::{Clump, Style, Wave};
use hairmesh::texture::SliceLayout;
use render::RgbaImage;
use render::scene::LodDesc;

use accuracy::accuracy_section;
use crowd::crowd_section;
use generation::generation_section;
use memory::memory_section;
use passes::passes_section;
use raster::raster_section;
use stored::stored_section;
use volume::volume_section;

#[derive(Parser, Debug)]
#[command(name = "hair-bench", version, about = "GPU benchmarks of on-the-fly hair generation")]
struct Cli {
    /// Small sizes (CI smoke test, well under 2 minutes).
    #[arg(long)]
    quick: bool,
    /// Where the report, CSV files and plots go (`--out docs` updates the project's report).
    #[arg(long, default_value = "target/bench")]
    out: PathBuf,
    /// Device index or name part.
    #[arg(long)]
    device: Option<String>,
    /// Rasterizer of the crowd and passes sections' scenes: auto, triangles or compute (the
    /// raster section always measures both).
    #[arg(long, default_value = "auto")]
    raster: render::scene::Raster,
    /// Run only these sections (comma-separated: generation, memory, stored, accuracy, crowd,
    /// passes, raster, shadows, volume, dynamics) and replace only them in the report.
    #[arg(long, value_name = "SECTION[,SECTION]")]
    only: Option<String>,
}

fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    match run(&Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hair-bench: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn asset(strands: u64) -> Result<HairAsset> {
    let scalp = hairmesh::procedural::head_cap(8, 32);
    let hm = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 6, length: 0.3, droop: 1.4, ..ExtrudeParams::default() },
    )?;
    let style = Style {
        width: 0.0015,
        wave: Wave { amplitude: 0.008, frequency: 8.0, coherence: 0.0 },
        clump: Clump { strength: 0.5, exponent: 1.0 },
        ..Style::default()
    };
    Ok(HairAsset::build(
        &hm,
        &AssetParams { strands: StrandCount::Total(strands), sample_sets: 1, seed: 1, ..Default::default() },
        style,
    )?)
}

/// The benchmark asset of `strands` strands written (f32 textures) to `dir`, which is returned.
fn write_asset_dir(dir: &Path, strands: u64) -> Result<PathBuf> {
    hairmesh::asset_io::write_asset(
        dir,
        &asset(strands)?,
        hairmesh::asset_io::Precision::F32,
        "metres",
        None,
    )?;
    Ok(dir.to_owned())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The report's sections in order, as `--only` names them.
const SECTIONS: [&str; 11] = [
    "generation",
    "collision",
    "memory",
    "stored",
    "accuracy",
    "crowd",
    "passes",
    "raster",
    "shadows",
    "volume",
    "dynamics",
];

/// One section of the report: its markdown (between its own markers), CSV files and plots.
struct Section {
    name: &'static str,
    markdown: String,
    csv: Vec<(&'static str, String)>,
}

/// What every section measures with.
struct Setup<'a> {
    ctx: &'a Context,
    quick: bool,
    width: u32,
    height: u32,
    /// Strand counts of the one-character tables.
    sizes: &'static [u64],
    frames: usize,
    paths: Vec<GenerationPath>,
    camera: Camera,
    character: [Character; 1],
    out: &'a Path,
    /// The rasterizer of the scene-renderer sections (crowd, passes).
    raster: render::scene::Raster,
    /// "measured by … on …" for every section's header.
    provenance: String,
}

fn markers(name: &str) -> (String, String) {
    (format!("<!-- hair-bench:{name}:begin -->"), format!("<!-- hair-bench:{name}:end -->"))
}

/// `existing` with each section's text between its markers replaced; a section without markers
/// goes after the previous section of the run (or at the end). A report of an older hair-bench
/// (one `generation` block holding every table) loses that block on a full run.
fn splice(existing: &str, sections: &[Section], full_run: bool) -> String {
    let mut text = existing.to_owned();
    if full_run && !text.contains("<!-- hair-bench:memory:begin -->") {
        let (b, e) = markers("generation");
        if let (Some(i), Some(j)) = (text.find(&b), text.find(&e))
            && j > i
        {
            text.replace_range(i..j + e.len(), "");
        }
    }
    let mut after: Option<usize> = None;
    for section in sections {
        let (b, e) = markers(section.name);
        let body = format!("{b}\n{}\n{e}", section.markdown.trim());
        match (text.find(&b), text.find(&e)) {
            (Some(i), Some(j)) if j > i => {
                text.replace_range(i..j + e.len(), &body);
                after = Some(i + body.len());
            }
            _ => {
                let at = after.unwrap_or(text.trim_end().len());
                let insert = format!("\n{body}\n");
                text.insert_str(at.min(text.len()), &insert);
                after = Some(at + insert.len());
            }
        }
    }
    if !text.ends_with('\n') {
        text.push('\n');
    }
    text
}

fn run(cli: &Cli) -> Result<()> {
    let only: Vec<&'static str> = match &cli.only {
        None => SECTIONS.to_vec(),
        Some(list) => {
            let mut chosen = Vec::new();
            for name in list.split(',').map(str::trim).filter(|n| !n.is_empty()) {
                let Some(&known) = SECTIONS.iter().find(|s| **s == name) else {
                    anyhow::bail!("--only: unknown section `{name}` (sections: {})", SECTIONS.join(", "));
                };
                chosen.push(known);
            }
            if chosen.is_empty() {
                anyhow::bail!("--only: no section named (sections: {})", SECTIONS.join(", "));
            }
            SECTIONS.iter().copied().filter(|s| chosen.contains(s)).collect()
        }
    };
    let ctx = Context::new(&ContextDesc { validation: Validation::Off, device: cli.device.clone() })?;
    let caps = ctx.capabilities().clone();
    let progress = indicatif::ProgressBar::new(only.len() as u64).with_style(
        indicatif::ProgressStyle::with_template("hair-bench [{bar:30}] {pos}/{len} {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let mut command = String::from("hair-bench");
    if cli.quick {
        command.push_str(" --quick");
    }
    if let Some(list) = &cli.only {
        command.push_str(&format!(" --only {list}"));
    }
    if cli.raster != render::scene::Raster::Auto {
        command.push_str(&format!(" --raster {:?}", cli.raster).to_lowercase());
    }
    command.push_str(&format!(" --out {}", cli.out.display()));
    let (width, height) = if cli.quick { (640, 360) } else { (1280, 720) };
    let mut paths = vec![GenerationPath::Compute];
    if caps.mesh_shader.is_some() {
        paths.push(GenerationPath::Mesh);
    }
    let setup = Setup {
        ctx: &ctx,
        quick: cli.quick,
        width,
        height,
        sizes: if cli.quick { &[2_000, 10_000] } else { &[10_000, 100_000] },
        frames: if cli.quick { 2 } else { 3 },
        paths,
        camera: Camera {
            eye: Vec3::new(0.0, 1.75, 0.55),
            target: Vec3::new(0.0, 1.55, 0.0),
            fov_y: 50f32.to_radians(),
        },
        character: [Character { hair: 0, transform: Mat4::IDENTITY }],
        out: &cli.out,
        raster: cli.raster,
        provenance: format!(
            "`{command}` on **{}** ({}, Vulkan {}.{}), {}",
            caps.device_name,
            caps.driver_info,
            caps.api_version.0,
            caps.api_version.1,
            hairkit_cli::today()
        ),
    };
    std::fs::create_dir_all(&cli.out).with_context(|| format!("creating {}", cli.out.display()))?;
    let mut sections = Vec::new();
    for name in &only {
        progress.set_message(*name);
        sections.push(match *name {
            "generation" => generation_section(&setup, &progress)?,
            "collision" => collision::collision_section(&setup, &progress)?,
            "memory" => memory_section(&setup)?,
            "stored" => stored_section(&setup, &progress)?,
            "accuracy" => accuracy_section(&setup)?,
            "crowd" => crowd_section(&setup, &progress)?,
            "raster" => raster_section(&setup, &progress)?,
            "volume" => volume_section(&setup, &progress)?,
            "dynamics" => dynamics::dynamics_section(&setup, &progress)?,
            "shadows" => shadows::shadows_section(&setup, &progress)?,
            _ => passes_section(&setup)?,
        });
        progress.inc(1);
    }
    progress.finish_and_clear();

    let report = cli.out.join("benchmarks.md");
    let existing = std::fs::read_to_string(&report).unwrap_or_else(|_| "# Benchmarks\n".into());
    write(&report, splice(&existing, &sections, cli.only.is_none()).as_bytes())?;
    for section in &sections {
        for (file, csv) in &section.csv {
            write(&cli.out.join(file), csv.as_bytes())?;
        }
        println!("{}\n", section.markdown.trim());
    }
    println!("wrote {} ({}) and the CSV files beside it", report.display(), only.join(", "));
    Ok(())
}

/// A table's section: its markdown, the command and device that measured it, its plot.
fn table_section(
    name: &'static str,
    csv_file: &'static str,
    table: Table,
    setup: &Setup<'_>,
    plot: Option<(String, String)>,
) -> Section {
    let mut markdown = format!("{}\n\n_{}._\n", table.markdown.trim(), setup.provenance);
    if let Some((file, caption)) = plot {
        markdown.push_str(&format!("\n![{caption}]({file})\n"));
    }
    Section { name, markdown, csv: vec![(csv_file, table.csv)] }
}

/// The camera and the character of the artist's Sintel groom (TressFX, 11,400 × 16) on the Sintel
/// bust (centimetres, 1.195 m below the groom's frame), when the data set holds them; otherwise
/// the rows that need them are left out and the resolver's message (once) says how to get them.
fn sintel_groom() -> Option<(serde_json::Value, serde_json::Value)> {
    static SAID: std::sync::Once = std::sync::Once::new();
    let found = data_set::locate("strands/tressfx/v4/sintel_hair_full_16points.tfx")
        .and_then(|groom| Ok((groom, data_set::locate("heads/sintel/sintel_bust.obj")?)));
    let (groom, bust) = match found {
        Ok(files) => files,
        Err(missing) => {
            SAID.call_once(|| eprintln!("hair-bench: the Sintel groom's rows are left out: {missing}"));
            return None;
        }
    };
    Some((
        serde_json::json!({ "eye": [0.15, 1.62, 0.5], "target": [0.0, 1.52, 0.0], "fov_y_degrees": 40 }),
        serde_json::json!({
            "hair": groom, "color": [0.171, 0.0397, 0.00719], "strand_width": 0.0004,
            "occluder": { "mesh": bust, "transform": { "scale": 0.01, "translation": [0, 1.195, 0] } }
        }),
    ))
}

/// GPU time of a frame's submissions named one of `names` ("scene frame": the frame's
/// batches; "shadow maps": its maps' submission).
fn submissions_ms(frame: &render::frame::RenderedFrame, names: &[&str]) -> f64 {
    frame
        .timings
        .passes
        .iter()
        .filter(|p| names.contains(&p.name.as_str()))
        .filter_map(|p| p.gpu_ms)
        // From +0: an empty f64 sum is -0, printed "-0.00".
        .fold(0.0, |sum, ms| sum + ms)
}

/// GPU time of a frame's passes whose names start with one of `prefixes` (top-level passes of
/// every submission).
fn passes_ms(frame: &render::frame::RenderedFrame, prefixes: &[&str]) -> f64 {
    frame
        .timings
        .passes
        .iter()
        .filter(|p| p.depth == 1 && prefixes.iter().any(|x| p.name.starts_with(x)))
        .filter_map(|p| p.gpu_ms)
        // From +0: an empty f64 sum is -0, printed "-0.00".
        .fold(0.0, |sum, ms| sum + ms)
}

/// The heads crowd of `hairkit crowd` (9 × 3,000 strands with `--quick`, else 100 × 100k)
/// written under `dir`, with strand α 64 / vertex α 1024 (the crowd section's LOD rows), and its
/// name for the tables.
fn heads_crowd(setup: &Setup<'_>, dir: &Path) -> Result<(String, render::scene::LoadedScene)> {
    let base = hairkit_cli::crowd_scenes::CrowdOptions {
        out: dir.join("crowd"),
        teapots: 1,
        teapot_strands: 100,
        teapot_variants: 1,
        size: (setup.width, setup.height),
        ..hairkit_cli::crowd_scenes::CrowdOptions::default()
    };
    let options = if setup.quick {
        hairkit_cli::crowd_scenes::CrowdOptions { characters: 9, strands: 3_000, ..base }
    } else {
        base
    };
    let crowd = hairkit_cli::crowd_scenes::write_crowds(&options, |_, _, _| {})?;
    let name =
        format!("{} heads × {} strands, LOD α 64 / 1024, blended", options.characters, options.strands);
    let mut scene = render::scene::load_scene(&crowd.heads)?;
    scene.scene.lod = LodDesc::alphas(64.0, 1024.0);
    Ok((name, scene))
}

/// Median GPU time of `frames` frames of `renderer` (every submission), and the last frame.
fn timed_frames(
    ctx: &Context,
    renderer: &render::frame::SceneRenderer,
    frames: usize,
) -> Result<(f64, render::frame::RenderedFrame)> {
    let mut total = Vec::new();
    let mut last = None;
    for _ in 0..frames {
        let f = renderer.render(ctx)?;
        total.push(submissions_ms(&f, &["scene frame"]));
        last = Some(f);
    }
    Ok((median(total), last.context("no frame rendered")?))
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    hairmesh::atomic::write_file_atomic(path, |w| w.write_all(bytes))
        .with_context(|| format!("writing {}", path.display()))
}

struct Table {
    markdown: String,
    csv: String,
}

fn flip_mean(reference: &RgbaImage, test: &RgbaImage) -> f64 {
    let rgb =
        |i: &RgbaImage| -> Vec<u8> { i.pixels.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect() };
    let r = nv_flip::FlipImageRgb8::with_data(reference.width, reference.height, &rgb(reference));
    let t = nv_flip::FlipImageRgb8::with_data(test.width, test.height, &rgb(test));
    let map = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    f64::from(nv_flip::FlipPool::from_image(&map).mean())
}
