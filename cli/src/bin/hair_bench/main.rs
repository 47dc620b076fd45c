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

mod dynamics;
mod shadows;

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

struct Row {
    strands: u64,
    path: GenerationPath,
    filtering: Filtering,
    /// Vertices generated per frame.
    vertices: u64,
    /// The generate pass in frames (compute path; the LOD pass alone on the mesh path).
    generate_ms: f64,
    /// The generate pass in submissions of its own (compute path).
    generate_alone_ms: Option<f64>,
    raster_ms: f64,
    total_ms: f64,
}

impl Row {
    /// Generated vertices per second: over the generation pass alone on the compute path, over
    /// the raster pass (generation and drawing) on the mesh path.
    fn vertices_per_s(&self) -> f64 {
        let ms = match self.path {
            GenerationPath::Mesh => self.raster_ms,
            GenerationPath::Compute => self.generate_alone_ms.unwrap_or(self.generate_ms),
        };
        self.vertices as f64 / (ms * 1e-3)
    }
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
const SECTIONS: [&str; 10] = [
    "generation",
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

/// Generation + raster of one character per path and per evaluation (strand-coherent, the
/// default, and per-vertex hardware filtering), LOD off.
fn generation_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let Setup { ctx, width, height, frames, camera, .. } = *setup;
    // Generation is a small part of a frame: more frames for a steadier median.
    let frames = if setup.quick { frames } else { frames.max(5) };
    let alone_runs = if setup.quick { frames } else { 15 };
    let variants = [Filtering::StrandCoherent, Filtering::Hardware];
    let generators: Vec<Generator> =
        variants.iter().map(|&f| Generator::new(ctx, f)).collect::<gen_gpu::Result<_>>()?;
    let mut rows = Vec::new();
    for &strands in setup.sizes {
        let hairs = [GpuHair::upload(ctx, &asset(strands)?, TexturePrecision::Auto)?];
        for &path in &setup.paths {
            let lod = LodParams { enabled: false, ..LodParams::default() };
            let view = FrameView { camera, width, height, path, lod };
            progress.set_message(format!("generation: {strands} strands, {path} path"));
            // Each variant's frame buffers are made once and reused, as a renderer does: fresh
            // buffers every frame would time the first touch of their memory too.
            let buffers: Vec<Vec<gen_gpu::FrameBuffers>> = generators
                .iter()
                .map(|g| prepare_crowd(ctx, g, &hairs, &setup.character, &view))
                .collect::<gen_gpu::Result<_>>()?;
            for (generator, buffers) in generators.iter().zip(&buffers) {
                // Warm-up: pipeline compilation and the buffers' first touch.
                render_prepared(ctx, generator, &hairs, &setup.character, buffers, &view, true)?;
            }
            // Frames of the variants alternate, so that drift of the machine's speed over the
            // run (10-30 % over minutes on a shared CPU) falls on both alike.
            let mut samples = vec![(Vec::new(), Vec::new(), Vec::new(), 0); variants.len()];
            for _ in 0..frames {
                for ((generator, buffers), (generate, raster, total, vertices)) in
                    generators.iter().zip(&buffers).zip(&mut samples)
                {
                    let frame =
                        render_prepared(ctx, generator, &hairs, &setup.character, buffers, &view, true)?;
                    let t = &frame.timings;
                    generate.push(t.pass_ms("generate").unwrap_or(f64::NAN));
                    raster.push(t.pass_ms(&format!("raster ({path})")).unwrap_or(f64::NAN));
                    total.push(t.pass_ms("crowd frame").unwrap_or(f64::NAN));
                    *vertices = frame.stats.vertices;
                }
            }
            // The generate pass alone, the variants alternating, more often than whole frames.
            let mut alone = vec![Vec::new(); variants.len()];
            if path == GenerationPath::Compute {
                for _ in 0..alone_runs {
                    for ((generator, buffers), alone) in generators.iter().zip(&buffers).zip(&mut alone) {
                        alone.push(generate_alone(ctx, generator, &hairs, &setup.character, buffers)?);
                    }
                }
            }
            for ((&filtering, (generate, raster, total, vertices)), alone) in
                variants.iter().zip(samples).zip(alone)
            {
                rows.push(Row {
                    strands: hairs[0].total_strands(),
                    path,
                    filtering,
                    vertices,
                    generate_alone_ms: (!alone.is_empty()).then(|| median(alone)),
                    generate_ms: median(generate),
                    raster_ms: median(raster),
                    total_ms: median(total),
                });
            }
        }
    }
    let mut md = String::new();
    let _ = writeln!(md, "## On-the-fly generation (`gen-gpu`)\n");
    let _ = writeln!(
        md,
        "{}; {width}×{height}, one character (the project's head cap, 6 layers), LOD off, 33 vertices per strand, placeholder shading. GPU timestamps. *Generate alone*: the LOD and generate passes in a submission of their own, median of {alone_runs} with the two evaluations alternating (the vertex rate is computed from it: inside a frame a pass of tens of milliseconds next to a raster pass of seconds varies by a quarter from frame to frame on this machine); the other columns: medians of {frames} whole frames after a warm-up frame, alternating too. *Strand-coherent* (the default) blends each slice's four texels once per strand and evaluates every vertex from those values; *per-vertex* samples the textures at every vertex (6 hardware trilinear fetches: two for the strand's curve, two for its bundle centre's, û with w, v̂). On the mesh path generation happens inside the raster pass, so its rate counts raster time too.\n",
        setup.provenance
    );
    let _ = writeln!(
        md,
        "| strands | path | evaluation | generate alone (ms) | vertices/s | generate in the frame (ms) | raster (ms) | frame (ms) |\n|---|---|---|---|---|---|---|---|"
    );
    let mut csv = String::from(
        "strands,path,evaluation,generate_alone_ms,generate_ms,raster_ms,frame_ms,vertices_per_s\n",
    );
    for r in &rows {
        let alone = r.generate_alone_ms.map_or("—".to_owned(), |ms| format!("{ms:.1}"));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {alone} | {:.1} M | {:.1} | {:.1} | {:.1} |",
            r.strands,
            r.path,
            evaluation_name(r.filtering),
            r.vertices_per_s() * 1e-6,
            r.generate_ms,
            r.raster_ms,
            r.total_ms
        );
        let _ = writeln!(
            csv,
            "{},{},{},{},{:.3},{:.3},{:.3},{:.0}",
            r.strands,
            r.path,
            evaluation_name(r.filtering),
            r.generate_alone_ms.map_or(String::new(), |ms| format!("{ms:.3}")),
            r.generate_ms,
            r.raster_ms,
            r.total_ms,
            r.vertices_per_s()
        );
    }
    for &strands in setup.sizes {
        let find = |p, f| {
            rows.iter().find(|r| {
                r.path == p && r.filtering == f && (r.strands as f64 / strands as f64 - 1.0).abs() < 0.01
            })
        };
        use Filtering::{Hardware, StrandCoherent};
        if let (Some(c), Some(v)) =
            (find(GenerationPath::Compute, StrandCoherent), find(GenerationPath::Compute, Hardware))
        {
            let _ = writeln!(
                md,
                "\nStrand-coherent / per-vertex generation rate at {strands} strands (compute path): **{:.2}×** (goal ≥ 5×); frame time {:.2}×.",
                c.vertices_per_s() / v.vertices_per_s(),
                c.total_ms / v.total_ms
            );
        }
        if let (Some(c), Some(m)) =
            (find(GenerationPath::Compute, StrandCoherent), find(GenerationPath::Mesh, StrandCoherent))
        {
            let _ = writeln!(
                md,
                "\nMesh path / compute path frame time at {strands} strands (strand-coherent): **{:.2}×**.",
                m.total_ms / c.total_ms
            );
        }
    }
    let plot = draw_generation_plot(setup.out, &rows)?;
    let _ = writeln!(md, "\n![{}]({})", plot.1, plot.0);
    Ok(Section { name: "generation", markdown: md, csv: vec![("bench-generation.csv", csv)] })
}

fn evaluation_name(filtering: Filtering) -> &'static str {
    match filtering {
        Filtering::StrandCoherent => "strand-coherent",
        Filtering::Hardware => "per-vertex (hardware)",
        Filtering::Manual => "per-vertex (manual)",
    }
}

/// GPU memory of an asset against the same strands stored, and by hair-mesh resolution.
fn memory_section(setup: &Setup<'_>) -> Result<Section> {
    let ctx = setup.ctx;
    let mut md = String::new();
    let _ = writeln!(md, "### GPU memory: asset vs stored strands\n");
    let _ = writeln!(
        md,
        "{}. Stored strands as the compute path writes them: 33 vertices × 32 bytes (position, width, tangent, parameter); minimal stored form: 33 × 16 bytes (position, width).\n",
        setup.provenance
    );
    let _ = writeln!(
        md,
        "| strands | textures | asset bytes | stored (32 B/vertex) | ratio | stored (16 B/vertex) | ratio |\n|---|---|---|---|---|---|---|"
    );
    for &strands in setup.sizes {
        let asset = asset(strands)?;
        for precision in [TexturePrecision::F32, TexturePrecision::F16] {
            let bytes = GpuHair::upload(ctx, &asset, precision)?.bytes.total();
            let strands = asset.total_strands();
            let (full, minimal) = (strands * 33 * 32, strands * 33 * 16);
            let _ = writeln!(
                md,
                "| {strands} | {precision:?} | {bytes} | {full} | {:.0}× | {minimal} | {:.0}× |",
                full as f64 / bytes as f64,
                minimal as f64 / bytes as f64
            );
        }
    }
    // The ratio is a property of the hair mesh: strands per (bundle × slice). A sweep of hair-mesh
    // resolutions at 100,000 strands shows where it crosses the 2000× goal, for the paper's layout
    // (a 2×2 block per face, 4 sample sets) and the default one (shared-vertex lattice, 1 set).
    let _ = writeln!(
        md,
        "\nThe ratio depends on the hair mesh, not only on the strand count: the textures grow with texels per slice × slices, the root sample sets with the largest bundle's strand count (4 bytes per sample), the stored strands with strands. 100,000 strands on head caps of several resolutions; *blocks* is the paper's layout (one 2×2 texel block per face) with 4 sample sets per domain, *lattice* the default (faces share their vertices' texels; 1 sample set per domain read under a per-bundle symmetry):\n"
    );
    let _ = writeln!(
        md,
        "| hair mesh | bundles | root vertices | layers | texels per slice (blocks → lattice) | asset bytes F16 (blocks) | asset bytes F16 (lattice) | asset bytes F32 (lattice) | stored (32 B/vertex) | ratio F16 blocks | ratio F16 lattice | ratio F32 lattice |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    let mut sweep_csv = String::from(
        "hair_mesh,bundles,root_vertices,layers,texels_blocks,texels_lattice,bytes_f16_blocks,bytes_f16_lattice,bytes_f32_lattice,stored_bytes\n",
    );
    for (rings, segments, layers) in [(2, 8, 3), (3, 12, 3), (4, 16, 4), (6, 24, 4), (8, 32, 6)] {
        let scalp = hairmesh::procedural::head_cap(rings, segments);
        let hm = HairMesh::extrude(
            &scalp,
            &ExtrudeParams { layers, length: 0.3, droop: 1.0, ..ExtrudeParams::default() },
        )?;
        let build = |layout, sample_sets| {
            HairAsset::build(
                &hm,
                &AssetParams { strands: StrandCount::Total(100_000), sample_sets, seed: 1, layout },
                Style::default(),
            )
        };
        let blocks = build(SliceLayout::Blocks, 4)?;
        let lattice = build(SliceLayout::Lattice, 1)?;
        let bytes = |asset: &HairAsset, precision| -> Result<u64> {
            Ok(GpuHair::upload(ctx, asset, precision)?.bytes.total())
        };
        let f16_blocks = bytes(&blocks, TexturePrecision::F16)?;
        let f16 = bytes(&lattice, TexturePrecision::F16)?;
        let f32 = bytes(&lattice, TexturePrecision::F32)?;
        let stored = lattice.total_strands() * 33 * 32;
        let (tb, tl) = (blocks.textures.layout.slice_texels(), lattice.textures.layout.slice_texels());
        let ratio = |bytes: u64| stored as f64 / bytes as f64;
        let _ = writeln!(
            md,
            "| head cap {rings}×{segments} | {} | {} | {layers} | {tb} → {tl} | {f16_blocks} | {f16} | {f32} | {stored} | {:.0}× | **{:.0}×** | {:.0}× |",
            lattice.bundles.len(),
            hm.layers[0].len(),
            ratio(f16_blocks),
            ratio(f16),
            ratio(f32)
        );
        let _ = writeln!(
            sweep_csv,
            "head cap {rings}x{segments},{},{},{layers},{tb},{tl},{f16_blocks},{f16},{f32},{stored}",
            lattice.bundles.len(),
            hm.layers[0].len()
        );
    }
    let _ = writeln!(
        md,
        "\nPer texel of a slice the F16 textures spend 8 bytes per hair-mesh slice (1 + 3L), 16 per layer for û and v̂, 2 per layer for w and 4 for uv; the bundle table 48 bytes per bundle. Coarse meshes are dominated by their sample sets (few bundles, so many strands in the largest one), dense ones by the textures."
    );

    Ok(Section { name: "memory", markdown: md, csv: vec![("bench-memory.csv", sweep_csv)] })
}

/// The same strands generated every frame (both evaluations) or drawn from the buffers an
/// earlier frame filled.
fn stored_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let Setup { ctx, width, height, frames, camera, .. } = *setup;
    // The ratio is of two frames that differ by a small pass: more frames for steadier medians
    // (with 5, a 10k-strand ratio moved by a tenth from run to run).
    let frames = if setup.quick { frames } else { frames.max(11) };
    let mut md = String::new();
    let _ = writeln!(md, "### On-the-fly vs stored strands\n");
    let _ = writeln!(
        md,
        "{}; {width}×{height}, compute generation path, triangle raster; \"stored\" draws the strand buffers an earlier frame generated (vertex pulling, same shading), so only generation differs. Medians of {frames} frames, the three kinds' frames alternating.\n",
        setup.provenance
    );
    let _ = writeln!(
        md,
        "| strands | on the fly, strand-coherent (ms) | on the fly, per-vertex (ms) | stored (ms) | ratio, strand-coherent (goal ≤ 1.05×) | ratio, per-vertex |\n|---|---|---|---|---|---|"
    );
    let mut csv = String::from("strands,on_the_fly_ms,per_vertex_ms,stored_ms,ratio,per_vertex_ratio\n");
    let coherent = Generator::new(ctx, Filtering::StrandCoherent)?;
    let per_vertex = Generator::new(ctx, Filtering::Hardware)?;
    for &strands in setup.sizes {
        progress.set_message(format!("on the fly vs stored: {strands} strands"));
        let hairs = [GpuHair::upload(ctx, &asset(strands)?, TexturePrecision::Auto)?];
        let lod = LodParams { enabled: false, ..LodParams::default() };
        let view = FrameView { camera, width, height, path: GenerationPath::Compute, lod };
        let character = &setup.character;
        let buffers = prepare_crowd(ctx, &coherent, &hairs, character, &view)?;
        let per_vertex_buffers = prepare_crowd(ctx, &per_vertex, &hairs, character, &view)?;
        render_prepared(ctx, &coherent, &hairs, character, &buffers, &view, true)?;
        render_prepared(ctx, &per_vertex, &hairs, character, &per_vertex_buffers, &view, true)?;
        let (mut live, mut live_per_vertex, mut stored) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..frames {
            let frame =
                |generator: &Generator, buffers: &[gen_gpu::FrameBuffers], regenerate| -> Result<f64> {
                    let f = render_prepared(ctx, generator, &hairs, character, buffers, &view, regenerate)?;
                    Ok(f.timings.pass_ms("crowd frame").unwrap_or(f64::NAN))
                };
            live.push(frame(&coherent, &buffers, true)?);
            live_per_vertex.push(frame(&per_vertex, &per_vertex_buffers, true)?);
            stored.push(frame(&coherent, &buffers, false)?);
        }
        let (live, live_per_vertex, stored) = (median(live), median(live_per_vertex), median(stored));
        let n = hairs[0].total_strands();
        let _ = writeln!(
            md,
            "| {n} | {live:.1} | {live_per_vertex:.1} | {stored:.1} | **{:.2}×** | {:.2}× |",
            live / stored,
            live_per_vertex / stored
        );
        let _ = writeln!(
            csv,
            "{n},{live:.3},{live_per_vertex:.3},{stored:.3},{:.4},{:.4}",
            live / stored,
            live_per_vertex / stored
        );
    }
    let mut csv_files = vec![("bench-stored.csv", csv)];
    if ctx.capabilities().buffer_int64_atomics {
        let (table, raster_csv) = stored_compute_raster_table(setup, progress)?;
        md.push_str(&table);
        csv_files.push(("bench-stored-compute.csv", raster_csv));
    }
    Ok(Section { name: "stored", markdown: md, csv: csv_files })
}

/// On the fly vs stored through the compute rasterizer (the default on CPU devices): the hair
/// generated inside the raster kernel every frame, against the same strands (the CPU
/// reference's, LOD off) uploaded once and drawn by the rasterizer's stored-strand kernel.
fn stored_compute_raster_table(
    setup: &Setup<'_>,
    progress: &indicatif::ProgressBar,
) -> Result<(String, String)> {
    let Setup { ctx, width, height, frames, camera, .. } = *setup;
    let frames = if setup.quick { frames } else { frames.max(11) };
    let mut md = String::new();
    let _ = writeln!(
        md,
        "\nThrough the compute rasterizer (opaque, LOD off): *on the fly* generates every strand inside the raster kernel each frame; *stored* draws the same strands (the CPU reference's, uploaded once, root width tapering to 0.3 at the tip) with the rasterizer's stored-strand kernel. Medians of {frames} frames after a warm-up, the two kinds' frames alternating, GPU timestamps.\n"
    );
    let _ = writeln!(
        md,
        "| strands | on the fly, fused (ms) | stored (ms) | ratio (goal ≤ 1.05×) |\n|---|---|---|---|"
    );
    let mut csv = String::from("strands,on_the_fly_ms,stored_ms,ratio\n");
    let json = serde_json::json!({
        "output": { "width": width, "height": height },
        "camera": { "eye": camera.eye.to_array(), "target": camera.target.to_array(), "fov_y_degrees": camera.fov_y.to_degrees() },
        "lights": [ { "directional": { "direction": [0.5, 0.8, 0.6] } } ],
        "characters": [],
        "effects": { "transparency": "opaque", "raster": "compute" }
    });
    let mut settings = render::scene::LoadedScene {
        path: PathBuf::from("stored-vs-fused.json"),
        scene: serde_json::from_value(json)?,
    };
    settings.scene.lod = LodDesc::OFF;
    settings.validate_settings()?;
    for &strands in setup.sizes {
        progress.set_message(format!("on the fly vs stored, compute rasterizer: {strands} strands"));
        let hair = asset(strands)?;
        let inputs = gen_gpu::FrameInputs::looking_at(&hair, camera.eye, width, height);
        let reference =
            hair.generate_reference(&inputs.view, &LodParams { enabled: false, ..LodParams::default() });
        let set = hairmesh::strands::StrandSet::from_reference(&reference);
        let width_at_root = hair.style.width as f32;
        // A warmed-up renderer per kind; their frames alternate, so drift of the machine's speed
        // falls on both alike.
        let renderer = |character: render::instance::CharacterInstance| -> Result<_> {
            let mut instance = render::instance::SceneInstance::new(settings.clone());
            instance.characters.push(character);
            let renderer =
                render::frame::SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?;
            renderer.render(ctx)?;
            Ok(renderer)
        };
        let live_renderer = renderer(render::instance::CharacterInstance::generated("hair", hair))?;
        let stored_renderer = renderer(render::instance::CharacterInstance {
            key: "stored".into(),
            hair: render::instance::CharacterHair::Stored {
                strands: std::sync::Arc::new(set),
                width: width_at_root,
            },
            transform: Mat4::IDENTITY,
            color: render::scene::DEFAULT_HAIR_COLOR,
            color_variation: render::scene::DEFAULT_COLOR_VARIATION,
            occluder: None,
        })?;
        let (mut live, mut stored) = (Vec::new(), Vec::new());
        for _ in 0..frames {
            live.push(timed_frames(ctx, &live_renderer, 1)?.0);
            stored.push(timed_frames(ctx, &stored_renderer, 1)?.0);
        }
        let (live, stored) = (median(live), median(stored));
        let n = reference.len();
        let _ = writeln!(md, "| {n} | {live:.1} | {stored:.1} | **{:.2}×** |", live / stored);
        let _ = writeln!(csv, "{n},{live:.3},{stored:.3},{:.4}", live / stored);
    }
    Ok((md, csv))
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

fn accuracy_section(setup: &Setup<'_>) -> Result<Section> {
    let table = accuracy_table(setup.ctx, setup.quick, setup.width, setup.height, setup.frames)?;
    let plot = draw_accuracy_plot(setup.out, &table.csv)?;
    Ok(table_section("accuracy", "bench-accuracy.csv", table, setup, Some(plot)))
}

fn crowd_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let (table, rows) = crowd_table(setup.ctx, setup.quick, setup.raster, progress)?;
    let plot = draw_crowd_plot(setup.out, &rows)?;
    Ok(table_section("crowd", "bench-crowd.csv", table, setup, Some(plot)))
}

fn passes_section(setup: &Setup<'_>) -> Result<Section> {
    let table = effects_table(setup, setup.width, setup.height, setup.frames)?;
    Ok(table_section("passes", "bench-effects.csv", table, setup, None))
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

fn raster_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let (table, rows) = raster_table(setup, progress)?;
    let plot = draw_raster_plot(setup.out, &rows)?;
    Ok(table_section("raster", "bench-raster.csv", table, setup, Some(plot)))
}

/// Frame time of each scene (numbered as in the table) through both rasterizers.
fn draw_raster_plot(out: &Path, rows: &[(f64, f64)]) -> Result<(String, String)> {
    use hairkit_cli::plots::{Chart, Series, draw};
    let series = [("triangle raster", 0), ("compute rasterizer", 1)]
        .map(|(name, k)| Series {
            name: name.to_owned(),
            points: rows
                .iter()
                .enumerate()
                .map(|(i, r)| ((i + 1) as f64, if k == 0 { r.0 } else { r.1 }))
                .collect(),
        })
        .to_vec();
    let chart = Chart {
        title: "Frame time per scene: triangle raster vs compute rasterizer",
        x_label: "scene (# in the table)",
        y_label: "frame (ms)",
        log_x: false,
        log_y: true,
        lines: false,
    };
    draw(&out.join("plot-raster.png"), &chart, &series)?;
    Ok(("plot-raster.png".to_owned(), chart.title.to_owned()))
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

/// The compute rasterizer's frame in parts (ms): the front raster phase, the phases after it
/// (with a second front eighth where the scene has one; the only phase where tiles are off),
/// shade, resolve — summed over a crowd's batches; zeros on the triangle raster.
fn compute_raster_parts(frame: &render::frame::RenderedFrame) -> [f64; 4] {
    let mut parts = [0.0; 4];
    for p in frame.timings.passes.iter().filter(|p| p.depth == 1) {
        let Some(ms) = p.gpu_ms else { continue };
        let part = if p.name.starts_with("raster hair (compute raster") {
            if p.name.contains(": front strands") { 0 } else { 1 }
        } else if p.name.starts_with("shade hair (compute raster") {
            2
        } else if p.name.starts_with("resolve hair (compute raster") {
            3
        } else {
            continue;
        };
        parts[part] += ms;
    }
    parts
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

/// Frames whose median the raster table gives for the compute rasterizer (at least; the
/// triangle raster's frames, seconds each, use the run's `frames`).
const COMPUTE_RASTER_FRAMES: usize = 9;

/// OIT nodes per pixel of the raster table's close-ups: enough for the triangle OIT to keep every
/// fragment of the 100k-strand close-up at 1280×720.
const OIT_REFERENCE_NODES_PER_PIXEL: f32 = 64.0;

/// The triangle raster against the compute rasterizer on the same scenes, in one run: one
/// character near (a close-up) and far (about 1 % of the screen), the artist's Sintel groom with
/// shadows, the heads crowd with LOD; per scene the hair passes, the whole frame, the speed-up
/// and the FLIP between the two images.
fn raster_table(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<(Table, Vec<(f64, f64)>)> {
    let Setup { ctx, width, height, frames, .. } = *setup;
    if !ctx.capabilities().buffer_int64_atomics {
        anyhow::bail!(
            "{} has no 64-bit buffer atomics: no compute rasterizer",
            ctx.capabilities().device_name
        );
    }
    let dir = std::env::temp_dir().join(format!("hair-bench-raster-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let mut scenes: Vec<(String, PathBuf)> = Vec::new();
    // The rows also timed with straight strands (what generation costs inside the kernel).
    let mut straight_rows: Vec<String> = Vec::new();
    let near =
        serde_json::json!({ "eye": [0.0, 1.82, 0.62], "target": [0.0, 1.55, 0.0], "fov_y_degrees": 45 });
    let far = serde_json::json!({ "eye": [0.0, 1.7, 4.2], "target": [0.0, 1.55, 0.0], "fov_y_degrees": 45 });
    let lights = serde_json::json!([ { "directional": { "direction": [0.5, 0.8, 0.6] } } ]);
    for &strands in setup.sizes {
        let asset_dir = write_asset_dir(&dir.join(format!("hair_{strands}")), strands)?;
        for (label, camera, transparency) in [
            ("close-up", &near, "opaque"),
            ("close-up", &near, "oit"),
            ("far, ~1 % of the screen", &far, "opaque"),
        ] {
            // The triangle OIT's pool holds every fragment of the close-up (about 52 M at 100k
            // strands; 64 nodes per pixel is 59 M at 1280×720, through the pool's device
            // address): the exact reference the compute OIT's FLIP is measured against.
            let mut effects = serde_json::json!({ "transparency": transparency });
            if transparency == "oit" {
                effects["oit_nodes_per_pixel"] = serde_json::json!(OIT_REFERENCE_NODES_PER_PIXEL);
            }
            let scene = serde_json::json!({
                "output": { "width": width, "height": height },
                "camera": camera,
                "lights": lights,
                "characters": [ { "hair": asset_dir, "color": [0.0835, 0.0272, 0.00719] } ],
                "effects": effects
            });
            let path = dir.join(format!("scene_{strands}_{}.json", scenes.len()));
            std::fs::write(&path, serde_json::to_vec_pretty(&scene)?)?;
            let mode = if transparency == "oit" { "OIT (k = 8)" } else { "opaque" };
            let name = format!("{strands}-strand character, {label}, {mode}");
            if label.starts_with("far") {
                straight_rows.push(name.clone());
            }
            scenes.push((name, path));
        }
    }
    if let Some((camera, character)) = sintel_groom() {
        let scene = serde_json::json!({
            "output": { "width": width, "height": height },
            "camera": camera,
            "lights": lights,
            "characters": [ character ],
            "effects": { "transparency": "oit", "shadows": true }
        });
        let path = dir.join("scene_sintel.json");
        std::fs::write(&path, serde_json::to_vec_pretty(&scene)?)?;
        scenes.push(("Sintel full groom (11,400 × 16, TressFX) on the bust, OIT + shadows".into(), path));
    }
    progress.set_message("raster: writing the heads crowd");
    let (crowd_name, crowd_scene) = heads_crowd(setup, &dir)?;
    // The compute rasterizer's frames take a fraction of the triangle raster's: more of them
    // for a steadier median on a machine whose frames vary by a fifth.
    let compute_frames = if setup.quick { frames } else { frames.max(COMPUTE_RASTER_FRAMES) };
    let mut md = String::new();
    let _ = writeln!(md, "\n### Triangle raster vs compute rasterizer\n");
    let _ = writeln!(
        md,
        "{width}×{height}, LOD on, GPU timestamps, median of {frames} frames (the triangle raster) and of {compute_frames} frames (the compute rasterizer) after a warm-up, both rasterizers in one run. *hair passes*: generation (LOD + cull, and the compute path's generation pass for triangles) plus the raster passes (triangles: the strip draw, or the OIT clear, fill and resolve; compute: clear, both fused raster phases, occlusion tiles, shade, resolve); *frame*: every submission of the frame (shadow maps are cached after the first frame). FLIP: mean, compute image against the triangle image. The close-ups' triangle OIT holds {OIT_REFERENCE_NODES_PER_PIXEL} nodes per pixel (`oit_nodes_per_pixel`; the pool reached through its device address, up to {} MiB), so that every fragment enters its pixel's list: the exact reference.\n",
        render::frame::OIT_POOL_BYTES >> 20
    );
    let _ = writeln!(
        md,
        "| # | scene | strands | triangles: hair (ms) | triangles: frame (ms) | compute: hair (ms) | compute: frame (ms) | frame speed-up | FLIP |\n|---|---|---|---|---|---|---|---|---|"
    );
    let mut rows = Vec::new();
    let mut csv = String::from(
        "scene,strands,triangles_hair_ms,triangles_frame_ms,compute_hair_ms,compute_frame_ms,speedup,flip,compute_front_ms,compute_rest_ms,compute_shade_ms,compute_resolve_ms\n",
    );
    // Where the compute rasterizer's frame goes, per scene (its rows numbered as above).
    let mut breakdown = String::from(
        "| # | front phase (ms) | rest phase (ms) | shade (ms) | resolve (ms) | the rest of the frame (ms) | frame (ms) |\n|---|---|---|---|---|---|---|\n",
    );
    let mut all: Vec<(String, render::scene::LoadedScene)> = Vec::new();
    for (name, path) in &scenes {
        all.push((name.clone(), render::scene::load_scene(path)?));
    }
    all.push((crowd_name, crowd_scene));
    let hair_prefixes = [
        "lod+cull",
        "generate",
        "raster hair",
        "hair depth prepass",
        "clear visibility",
        "clear OIT",
        "OIT resolve",
        "occlusion tiles",
        "shade hair",
        "resolve hair",
    ];
    let mut overflows = Vec::new();
    let mut generation_costs = Vec::new();
    for (number, (name, loaded)) in all.into_iter().enumerate() {
        let number = number + 1;
        let mut results = Vec::new();
        for raster in [render::scene::Raster::Triangles, render::scene::Raster::Compute] {
            progress.set_message(format!("raster: {name} ({raster:?})"));
            let mut scene = loaded.clone();
            scene.scene.effects.raster = raster;
            let renderer = render::frame::SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
            renderer.render(ctx)?;
            let mut hair = Vec::new();
            let mut total = Vec::new();
            // The compute rasterizer's front phase, rest phase, shade, resolve, other passes.
            let mut parts: [Vec<f64>; 5] = Default::default();
            let mut last = None;
            let frames = if raster == render::scene::Raster::Compute { compute_frames } else { frames };
            for _ in 0..frames {
                let f = renderer.render(ctx)?;
                hair.push(passes_ms(&f, &hair_prefixes));
                // Every submission of the frame (crowds are drawn in batches).
                let frame_ms = submissions_ms(&f, &["scene frame"]);
                total.push(frame_ms);
                let raster_parts = compute_raster_parts(&f);
                let others = frame_ms - raster_parts.iter().sum::<f64>();
                for (part, ms) in parts.iter_mut().zip(raster_parts.into_iter().chain([others])) {
                    part.push(ms);
                }
                last = Some(f);
            }
            let f = last.context("no frame rendered")?;
            if let (Some(overflow @ 1..), Some(pool)) = (f.oit_overflow, f.oit_pool) {
                overflows.push(format!(
                    "row {number}: {overflow} fragments beyond the triangle OIT's pool of {pool} nodes"
                ));
            }
            results.push((median(hair), median(total), f.image, f.stats.strands, parts.map(median)));
        }
        let [(th, tf, ti, strands, _), (ch, cf, ci, _, [front, rest, shade, resolve, others])] =
            <[_; 2]>::try_from(results).map_err(|_| anyhow::anyhow!("two rasterizers, two results"))?;
        let _ = writeln!(
            breakdown,
            "| {number} | {front:.1} | {rest:.1} | {shade:.1} | {resolve:.1} | {others:.1} | {cf:.1} |"
        );
        if straight_rows.contains(&name) {
            progress.set_message(format!("raster: {name} (straight strands)"));
            let mut scene = loaded.clone();
            scene.scene.effects.raster = render::scene::Raster::Compute;
            let renderer = render::frame::SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?
                .with_fused_strands(ctx, render::raster::FusedStrands::Straight)?;
            renderer.render(ctx)?;
            let mut total = Vec::new();
            for _ in 0..compute_frames {
                total.push(submissions_ms(&renderer.render(ctx)?, &["scene frame"]));
            }
            let straight = median(total);
            // 15× the triangle frame: the compute-rasterizer issue's goal for the far character.
            let goal = tf / 15.0;
            let at_goal = if goal > straight {
                format!("15× ({goal:.1} ms) would leave {:.1} ms for it", goal - straight)
            } else {
                format!("15× ({goal:.1} ms) is out of reach even with straight strands")
            };
            generation_costs.push(format!(
                "row {number}: {straight:.1} ms with straight strands ({:.1}× the triangle frame) against {cf:.1} ms styled ({:.1}×): generating the styled strands costs about {:.1} ms of the frame; {at_goal}",
                tf / straight,
                tf / cf,
                cf - straight,
            ));
        }
        let flip = flip_mean(&ti, &ci);
        let speedup = tf / cf;
        let _ = writeln!(
            md,
            "| {number} | {name} | {strands} | {th:.1} | {tf:.1} | {ch:.1} | {cf:.1} | {speedup:.1}× | {flip:.4} |"
        );
        rows.push((tf, cf));
        let _ = writeln!(
            csv,
            "{},{strands},{th:.3},{tf:.3},{ch:.3},{cf:.3},{speedup:.3},{flip:.5},{front:.3},{rest:.3},{shade:.3},{resolve:.3}",
            name.replace(',', ";")
        );
    }
    let _ = writeln!(
        md,
        "\nWhere the compute rasterizer's frame goes (the same frames; medians per column, so the parts need not add up to the frame's median exactly): the *front phase* generates and draws the first subset of strands (every {}th slot), the *rest phase* the others against the occlusion tiles made before them (with fused generation and one slot per pixel, for characters whose bundles keep many strands, a second eighth of each bundle, then the rest, each after its own tile pass; one phase where tiles are off); *shade* composites each pixel's nearest fragments, *resolve* filters and writes them; *the rest*: every other pass (LOD, clears, occluders, shadow maps, tiles, copies).\n\n{breakdown}",
        gen_gpu::contract::SPARSE_SLOT_STRIDE
    );
    if !generation_costs.is_empty() {
        let _ = writeln!(
            md,
            "What generation costs inside the fused kernel: the far character drawn again (same run, median of {compute_frames} frames) with every strand a straight line from its root to its tip on the hair-mesh curve (`FusedStrands::Straight`: the same vertices, walk and pixels' work, generation reduced to two control-point loads and a lerp per vertex; a different image, not a LOD): {}.",
            generation_costs.join("; ")
        );
    }
    if !overflows.is_empty() {
        let _ = writeln!(
            md,
            "\nWhere the triangle OIT's node pool (`oit_nodes_per_pixel`, capped by the storage-buffer range or the pool budget) overflowed, the fragments beyond it were blended order-independently behind the sorted ones, so that reference's layering is approximate there: {}.",
            overflows.join("; ")
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok((Table { markdown: md, csv }, rows))
}

/// Screen coverage (%), strand frame (ms), volume frame (ms).
type CoverageTimes = (f64, f64, f64);

fn volume_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let (table, rows) = volume_table(setup, progress)?;
    let plot = draw_volume_plot(setup.out, &rows)?;
    Ok(table_section("volume", "bench-volume.csv", table, setup, Some(plot)))
}

/// Frame time against screen coverage: strands (compute rasterizer) and the volume path.
fn draw_volume_plot(out: &Path, rows: &[CoverageTimes]) -> Result<(String, String)> {
    use hairkit_cli::plots::{Chart, Series, draw};
    let series = [("strands (compute rasterizer)", 1), ("volume (raymarch)", 2)]
        .map(|(name, k)| Series {
            name: name.to_owned(),
            points: rows.iter().map(|r| (r.0, if k == 1 { r.1 } else { r.2 })).collect(),
        })
        .to_vec();
    let chart = Chart {
        title: "One character: frame time against screen coverage",
        x_label: "screen coverage (%)",
        y_label: "frame (ms)",
        log_x: true,
        log_y: true,
        lines: true,
    };
    draw(&out.join("plot-volume.png"), &chart, &series)?;
    Ok(("plot-volume.png".to_owned(), chart.title.to_owned()))
}

/// The square around the pixels `frame` covers (alpha > 0), a tenth wider on each side.
fn covered_square(frame: &render::frame::RenderedFrame) -> Option<[u32; 4]> {
    let (w, h) = (frame.image.width, frame.image.height);
    let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
    for (i, p) in frame.linear.rgba.chunks_exact(4).enumerate() {
        if p[3] > 0.02 {
            let (x, y) = (i as u32 % w, i as u32 / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
        }
    }
    if x0 >= x1 {
        return None;
    }
    let side = ((x1 - x0).max(y1 - y0) as f32 * 1.2).ceil() as u32;
    let side = side.min(w).min(h);
    let (cx, cy) = ((x0 + x1) / 2, (y0 + y1) / 2);
    let x = cx.saturating_sub(side / 2).min(w - side);
    let y = cy.saturating_sub(side / 2).min(h - side);
    Some([x, y, side, side])
}

/// Tiles of `size`² pixels side by side: each image's square `[x, y, side, side]` scaled (nearest
/// pixel) to the tile.
fn tile_row(tiles: &[(&RgbaImage, [u32; 4])], size: u32) -> RgbaImage {
    let mut out = RgbaImage { width: size * tiles.len() as u32, height: size, pixels: Vec::new() };
    out.pixels = vec![0; (out.width * out.height * 4) as usize];
    for (t, (image, [x, y, side, _])) in tiles.iter().enumerate() {
        for oy in 0..size {
            for ox in 0..size {
                let sx = (x + ox * side / size).min(image.width - 1);
                let sy = (y + oy * side / size).min(image.height - 1);
                let from = ((sy * image.width + sx) * 4) as usize;
                let to = ((oy * out.width + t as u32 * size + ox) * 4) as usize;
                out.pixels[to..to + 4].copy_from_slice(&image.pixels[from..from + 4]);
            }
        }
    }
    out
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

/// The GPU time of re-voxelizing the first character's hair after an edit (one outer hair-mesh
/// vertex nudged, then back: the whole hair is voxelized again, as after restyling or a
/// simulation step): median of three edits on `renderer`, warm.
fn revoxelize_ms(
    ctx: &Context,
    renderer: &mut render::frame::SceneRenderer,
    instance: &render::instance::SceneInstance,
) -> Result<f64> {
    let character = instance.characters.first().context("no character")?;
    let render::instance::CharacterHair::Generated(asset) = &character.hair else {
        anyhow::bail!("the volume table's character is generated hair")
    };
    let mut edited = (**asset).clone();
    let mut times = Vec::new();
    for edit in 0..3 {
        let mesh = edited.mesh();
        let top = mesh.layers.len().checked_sub(1).context("a hair mesh without layers")?;
        let position = mesh.layers[top].first().context("an empty hair-mesh layer")?;
        let nudge = if edit % 2 == 0 { 1e-3 } else { -1e-3 };
        let moves = [hairmesh::asset::VertexMove {
            layer: top as u32,
            vertex: 0,
            position: *position + glam::DVec3::new(nudge, 0.0, 0.0),
        }];
        let change = edited.move_vertices(&moves)?;
        renderer.update_hair(ctx, &character.key, &edited, &change)?;
        let frame = renderer.render(ctx)?;
        anyhow::ensure!(frame.volumes_voxelized == 1, "an edit did not re-voxelize: {:?}", frame.passes);
        times.push(passes_ms(
            &frame,
            &["lod hair", "clear voxel", "voxelize", "resolve volume", "volume bricks"],
        ));
    }
    Ok(median(times))
}

/// The volume LOD path against the strands (compute rasterizer) for the largest character at
/// about 30 %, 5 %, 1 % and 0.4 % of the screen, opaque, in one run: frame times (the volume
/// cached, as for static hair), FLIP, the voxelization's cost on the first frame and after an
/// edit (warm: restyled or simulated hair), and AO's cost on the strands.
fn volume_table(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<(Table, Vec<CoverageTimes>)> {
    let Setup { ctx, width, height, frames, .. } = *setup;
    if !ctx.capabilities().buffer_int64_atomics {
        anyhow::bail!(
            "{} has no 64-bit buffer atomics: no compute rasterizer, no volumes",
            ctx.capabilities().device_name
        );
    }
    let strands = *setup.sizes.last().context("no strand count")?;
    let dir = std::env::temp_dir().join(format!("hair-bench-volume-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let asset_dir = write_asset_dir(&dir.join("hair"), strands)?;
    let target = Vec3::new(0.0, 1.55, 0.0);
    let near = Vec3::new(0.0, 1.82, 0.62) - target;
    let scene_at = |distance: f32, effects: serde_json::Value| -> Result<render::scene::LoadedScene> {
        let eye = target + near * distance;
        let scene = serde_json::json!({
            "output": { "width": width, "height": height },
            "camera": { "eye": eye.to_array(), "target": target.to_array(), "fov_y_degrees": 45 },
            "lights": [ { "directional": { "direction": [0.5, 0.8, 0.6] } } ],
            "characters": [ { "hair": asset_dir, "color": [0.0835, 0.0272, 0.00719] } ],
            "effects": effects
        });
        let path = dir.join("scene.json");
        std::fs::write(&path, serde_json::to_vec_pretty(&scene)?)?;
        Ok(render::scene::load_scene(&path)?)
    };
    let mut md = String::new();
    let _ = writeln!(md, "\n### Volume LOD path vs strands\n");
    let _ = writeln!(
        md,
        "One {strands}-strand character, {width}×{height}, opaque, LOD on, GPU timestamps, median of {frames} frames after a warm-up, in one run. *strands*: the compute rasterizer (fused generation); *volume*: the same character raymarched through its density volume (`\"volume_lod\"`, every distance forced), the volume voxelized on the first frame and cached (static hair); *voxelize*: that first frame's LOD, clear, voxelization, resolve passes; *re-voxelize*: the same passes and the bricks' after an edit of the hair mesh (one vertex moved, so the whole hair is voxelized again, as after restyling or a simulation step), median of three edits on the warm renderer. Coverage: pixels the strand image covers. FLIP: mean, volume image against the strand image.\n"
    );
    let _ = writeln!(
        md,
        "| distance | coverage | strands: frame (ms) | volume: frame (ms) | speed-up | FLIP | volume grid | voxelize (ms) | re-voxelize (ms) |\n|---|---|---|---|---|---|---|---|---|"
    );
    let mut csv = String::from(
        "distance,coverage_percent,strands_frame_ms,volume_frame_ms,speedup,flip,grid,voxelize_ms,revoxelize_ms\n",
    );
    let mut rows = Vec::new();
    let mut pictures: Vec<(RgbaImage, RgbaImage, [u32; 4])> = Vec::new();
    let volume_effects =
        serde_json::json!({ "transparency": "opaque", "raster": "compute", "volume_lod": true });
    for distance in [1.2f32, 3.0, 6.7, 10.6] {
        progress.set_message(format!("volume: {distance}× the close-up distance"));
        let strand_scene =
            scene_at(distance, serde_json::json!({ "transparency": "opaque", "raster": "compute" }))?;
        let strand_renderer = render::frame::SceneRenderer::new(ctx, &strand_scene, GenerationPath::Compute)?;
        strand_renderer.render(ctx)?;
        let (strand_ms, strand_frame) = timed_frames(ctx, &strand_renderer, frames)?;
        let coverage = strand_frame.linear.rgba.chunks_exact(4).filter(|p| p[3] > 0.5).count() as f64
            / f64::from(width * height)
            * 100.0;
        let volume_scene = scene_at(distance, volume_effects.clone())?;
        let instance = render::instance::SceneInstance::load(&volume_scene)?;
        let mut volume_renderer =
            render::frame::SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?
                .with_volumes_everywhere(true);
        let first = volume_renderer.render(ctx)?;
        let voxelize_ms = passes_ms(&first, &["lod hair", "clear voxel", "voxelize", "resolve volume"]);
        let grid = first
            .graph
            .passes
            .iter()
            .find_map(|p| p.name.strip_prefix("voxelize hair 0 (").and_then(|r| r.split(',').next()))
            .unwrap_or("?")
            .to_owned();
        let (volume_ms, volume_frame) = timed_frames(ctx, &volume_renderer, frames)?;
        let revoxelize_ms = revoxelize_ms(ctx, &mut volume_renderer, &instance)?;
        let flip = flip_mean(&strand_frame.image, &volume_frame.image);
        let speedup = strand_ms / volume_ms;
        if let Some(square) = covered_square(&strand_frame) {
            pictures.push((strand_frame.image.clone(), volume_frame.image.clone(), square));
        }
        let _ = writeln!(
            md,
            "| {distance}× | {coverage:.2} % | {strand_ms:.1} | {volume_ms:.1} | {speedup:.1}× | {flip:.4} | {grid} | {voxelize_ms:.1} | {revoxelize_ms:.1} |"
        );
        let _ = writeln!(
            csv,
            "{distance},{coverage:.3},{strand_ms:.3},{volume_ms:.3},{speedup:.3},{flip:.5},{grid},{voxelize_ms:.3},{revoxelize_ms:.3}"
        );
        rows.push((coverage, strand_ms, volume_ms));
    }
    // Each distance's character cropped and scaled to one size: strands above, volume below.
    if !pictures.is_empty() {
        let size = 240;
        let strands_row = tile_row(&pictures.iter().map(|(s, _, q)| (s, *q)).collect::<Vec<_>>(), size);
        let volume_row = tile_row(&pictures.iter().map(|(_, v, q)| (v, *q)).collect::<Vec<_>>(), size);
        let mut both = strands_row.clone();
        both.height *= 2;
        both.pixels.extend_from_slice(&volume_row.pixels);
        render::output::write_png(&setup.out.join("volume-lod.png"), &both)?;
        let _ = writeln!(
            md,
            "\n![Strands (top) and the volume path (bottom) at each distance of the table, each cropped around the character and scaled to the same size](volume-lod.png)"
        );
    }
    // The crossover: the largest coverage at which the volume is faster.
    let crossover = rows
        .iter()
        .filter(|r| r.2 < r.1)
        .map(|r| r.0)
        .fold(None, |a: Option<f64>, c| Some(a.map_or(c, |a| a.max(c))));
    let _ = writeln!(
        md,
        "\nThe volume is faster at every coverage up to {} in this run.",
        crossover.map_or("none of them".to_owned(), |c| format!("{c:.1} % of the screen"))
    );
    // Re-voxelization at the coarser grids small characters get (`"lod": "auto"` raymarches
    // characters of at most 48 pixels: 64³ or less).
    progress.set_message("volume: re-voxelization at coarser grids");
    let mut coarse = Vec::new();
    for resolution in [64u32, 32] {
        let mut effects = volume_effects.clone();
        effects["volume_resolution"] = serde_json::json!(resolution);
        let instance = render::instance::SceneInstance::load(&scene_at(10.6, effects)?)?;
        let mut renderer =
            render::frame::SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?
                .with_volumes_everywhere(true);
        // The first frame voxelizes cold; the edits are measured on a warm renderer.
        renderer.render(ctx)?;
        renderer.render(ctx)?;
        coarse.push(format!("{resolution}³ {:.1} ms", revoxelize_ms(ctx, &mut renderer, &instance)?));
    }
    let _ = writeln!(
        md,
        "\nRe-voxelization after an edit on coarser grids (the farthest distance, `volume_resolution` lowered): {}.",
        coarse.join(", ")
    );
    // AO's cost on the strands, the close-up (the AO volume cached).
    progress.set_message("volume: AO on the close-up");
    let mut ao_rows = Vec::new();
    for ao in [false, true] {
        let s =
            scene_at(1.2, serde_json::json!({ "transparency": "opaque", "raster": "compute", "ao": ao }))?;
        let r = render::frame::SceneRenderer::new(ctx, &s, GenerationPath::Compute)?;
        let first = r.render(ctx)?;
        let (ms, _) = timed_frames(ctx, &r, frames)?;
        ao_rows.push((
            ms,
            passes_ms(&first, &["lod hair", "clear voxel", "voxelize", "resolve volume", "volume AO"]),
        ));
    }
    let _ = writeln!(
        md,
        "\nAO on the close-up (strands): {:.1} ms per frame without, {:.1} ms with ({:+.1} %; the volume and its AO cached); computing them on the first frame: {:.1} ms.",
        ao_rows[0].0,
        ao_rows[1].0,
        (ao_rows[1].0 / ao_rows[0].0 - 1.0) * 100.0,
        ao_rows[1].1
    );
    // Self-shadowing two ways: deep opacity maps (rendered through the triangle raster, cached
    // after the first frame) and the march through the hair's own volume (every frame).
    let _ = writeln!(md, "\n| shadows | scene | first frame (ms) | frame (ms) |\n|---|---|---|---|");
    for (label, distance, extra, everywhere) in [
        ("close-up, strands", 1.2f32, serde_json::json!({}), false),
        ("0.9 % of the screen, volume", 6.7, serde_json::json!({ "volume_lod": true }), true),
    ] {
        for (shadows, effects) in [
            ("none", serde_json::json!({})),
            ("deep opacity maps", serde_json::json!({ "shadows": true })),
            ("volume", serde_json::json!({ "volume_shadows": true })),
        ] {
            progress.set_message(format!("volume: shadows {shadows}, {label}"));
            let mut e = serde_json::json!({ "transparency": "opaque", "raster": "compute" });
            for source in [&extra, &effects] {
                if let (Some(to), Some(from)) = (e.as_object_mut(), source.as_object()) {
                    to.extend(from.clone());
                }
            }
            let r = render::frame::SceneRenderer::new(ctx, &scene_at(distance, e)?, GenerationPath::Compute)?
                .with_volumes_everywhere(everywhere);
            let first = r.render(ctx)?;
            let first_ms: f64 =
                first.timings.passes.iter().filter(|p| p.depth == 0).filter_map(|p| p.gpu_ms).sum();
            let (ms, _) = timed_frames(ctx, &r, frames)?;
            let _ = writeln!(md, "| {shadows} | {label} | {first_ms:.1} | {ms:.1} |");
        }
    }
    // The heads crowd: strands with LOD against the volume path for the characters it picks.
    progress.set_message("volume: the heads crowd");
    let (crowd_name, crowd) = heads_crowd(setup, &dir)?;
    let strands = render::frame::SceneRenderer::new(ctx, &crowd, GenerationPath::Compute)?;
    strands.render(ctx)?;
    let (strand_ms, strand_frame) = timed_frames(ctx, &strands, frames)?;
    let mut with_volumes = crowd.clone();
    with_volumes.scene.effects.raster = render::scene::Raster::Compute;
    with_volumes.scene.effects.volume_lod = true;
    let volumes = render::frame::SceneRenderer::new(ctx, &with_volumes, GenerationPath::Compute)?;
    let first = volumes.render(ctx)?;
    let first_ms: f64 = first.timings.passes.iter().filter(|p| p.depth == 0).filter_map(|p| p.gpu_ms).sum();
    let (volume_ms, volume_frame) = timed_frames(ctx, &volumes, frames)?;
    let _ = writeln!(
        md,
        "\n{crowd_name}, from the first key of its camera path: {strand_ms:.1} ms per frame with strands (compute rasterizer), {volume_ms:.1} ms with `\"volume_lod\"` ({} of {} characters raymarched, {:.1}× faster, FLIP {:.4}); its first frame, voxelizing {} hairs, took {first_ms:.0} ms.",
        volume_frame.volume_characters,
        volume_frame.volume_fractions.len(),
        strand_ms / volume_ms,
        flip_mean(&strand_frame.image, &volume_frame.image),
        first.volumes_voxelized,
    );
    let _ = std::fs::remove_dir_all(&dir);
    Ok((Table { markdown: md, csv }, rows))
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

/// Crowds with LOD off and on: the heads crowd and the teapot crowd of `hairkit crowd`, from
/// the first key of their camera paths, compute path.
fn crowd_table(
    ctx: &Context,
    quick: bool,
    raster: render::scene::Raster,
    progress: &indicatif::ProgressBar,
) -> Result<(Table, Vec<CrowdRow>)> {
    let dir = std::env::temp_dir().join(format!("hair-bench-crowd-{}", std::process::id()));
    let options = if quick {
        hairkit_cli::crowd_scenes::CrowdOptions {
            out: dir.clone(),
            characters: 9,
            strands: 3_000,
            teapots: 12,
            teapot_strands: 1_500,
            size: (320, 180),
            ..hairkit_cli::crowd_scenes::CrowdOptions::default()
        }
    } else {
        hairkit_cli::crowd_scenes::CrowdOptions {
            out: dir.clone(),
            ..hairkit_cli::crowd_scenes::CrowdOptions::default()
        }
    };
    progress.set_message("writing the crowd scenes");
    let scenes = hairkit_cli::crowd_scenes::write_crowds(&options, |_, _, _| {})?;
    let mut rows = Vec::new();
    for (name, path, count, strands) in [
        ("heads", &scenes.heads, options.characters, options.strands),
        ("teapots", &scenes.teapots, options.teapots, options.teapot_strands),
    ] {
        let mut reference = None;
        // Explicit (strand α, vertex α): vertex LOD's h is the hair length, strand LOD's the root
        // face's size, some 15–30× smaller: a vertex α about 16× the strand α (capped at 1024,
        // below which strands keep at least 4 segments here) costs about the same image error as
        // the strand α alone and makes the frame 2–3× cheaper. Then `"lod": "auto"` (style-aware
        // vertex LOD, and volumes for the smallest characters on the compute rasterizer).
        let alphas: &[(f64, f64)] = if quick {
            &[(16.0, 256.0), (256.0, 1024.0)]
        } else {
            &[(16.0, 256.0), (64.0, 1024.0), (128.0, 1024.0), (256.0, 1024.0)]
        };
        let lods: Vec<LodDesc> = std::iter::once(LodDesc::OFF)
            .chain(alphas.iter().map(|&(s, v)| LodDesc::alphas(s, v)))
            .chain([LodDesc::AUTO])
            .collect();
        let loaded = render::scene::load_scene(path)?;
        for &lod in &lods {
            progress.set_message(format!("crowd: {count} {name}, LOD {}", lod_label(&lod)));
            let mut scene = loaded.clone();
            scene.scene.effects.raster = raster;
            scene.scene.lod = lod;
            let renderer = render::frame::SceneRenderer::new(ctx, &scene, GenerationPath::Compute)?;
            // A warm-up frame (shader JIT, first-touch allocation; the volumes of `auto`) except
            // for the full crowd at full detail, whose minutes-long frame dwarfs that.
            if quick || lod.enabled {
                renderer.render(ctx)?;
            }
            let frame = renderer.render(ctx)?;
            // Every submission of the frame (characters are drawn in batches).
            let ms = submissions_ms(&frame, &["scene frame"]);
            let flip = reference.as_ref().map_or(0.0, |r| flip_mean(r, &frame.image));
            rows.push(CrowdRow {
                scene: format!("{count} {name} × {strands} strands"),
                lod,
                strands: frame.stats.strands,
                segments: frame.stats.vertices.saturating_sub(frame.stats.strands),
                volumes: frame.volume_characters as u64,
                frame_ms: ms,
                flip,
            });
            if reference.is_none() {
                reference = Some(frame.image);
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    let mut md = String::new();
    let (w, h) = options.size;
    let _ = writeln!(md, "\n### Crowds: LOD off vs on\n");
    let _ = writeln!(
        md,
        "Scenes written by `hairkit crowd` (seed {}), {w}×{h}, blended transparency (coverage AA; only strands a pixel wide write depth, so thinner ones keep their density under LOD), scalp occluders, compute path, from the first key of each camera path; one frame each (GPU timestamps of every batch). Image error: mean FLIP of the LOD render against the LOD-off render. LOD α_s / α_v (strand / vertex α) trade detail for time: L = h·R/(α·d·tan(θ/2)) with h the root face's size for strand LOD (α_s = 1 keeps every strand of a bundle taller than about two pixels) and the hair length for vertex LOD, some 15–30× longer, so α_v is set 16× α_s (at most 1024). *auto*: `\"lod\": \"auto\"` — α_s = {} / α_v = {} with style-aware vertex LOD (no curl, wave or frizz deviates more than {} px from its polyline) and, on the compute rasterizer, the volume LOD path for characters at most `volume_lod_pixels` on screen (*volumes*: characters raymarched, wholly or in the transition band). Goal: ≥ 30× faster with LOD at mean FLIP ≤ 0.05.\n",
        options.seed,
        LodDesc::AUTO.strand_alpha,
        LodDesc::AUTO.vertex_alpha,
        LodDesc::AUTO.vertex_error_pixels,
    );
    let _ = writeln!(
        md,
        "| scene | LOD | strands drawn | segments drawn | volumes | frame (ms) | speed-up | FLIP vs LOD off |\n|---|---|---|---|---|---|---|---|"
    );
    let mut csv = String::from(
        "scene,lod,strand_alpha,vertex_alpha,vertex_error_pixels,strands,segments,volumes,frame_ms,flip\n",
    );
    for group in rows.chunk_by(|a, b| a.scene == b.scene) {
        for r in group {
            let speedup = group[0].frame_ms / r.frame_ms;
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {:.0} | {:.1}× | {} |",
                r.scene,
                lod_label(&r.lod),
                r.strands,
                r.segments,
                r.volumes,
                r.frame_ms,
                speedup,
                if r.lod.enabled { format!("{:.3}", r.flip) } else { "—".into() }
            );
            let _ = writeln!(
                csv,
                "{},{},{},{},{},{},{},{},{:.3},{:.4}",
                r.scene.replace(',', ""),
                lod_kind(&r.lod),
                if r.lod.enabled { r.lod.strand_alpha } else { 0.0 },
                if r.lod.enabled { r.lod.vertex_alpha } else { 0.0 },
                if r.lod.enabled { r.lod.vertex_error_pixels } else { 0.0 },
                r.strands,
                r.segments,
                r.volumes,
                r.frame_ms,
                r.flip
            );
        }
        // The fastest α within the image-error goal.
        if let Some(best) = group
            .iter()
            .filter(|r| r.lod.enabled && r.flip <= 0.05)
            .max_by(|a, b| (group[0].frame_ms / a.frame_ms).total_cmp(&(group[0].frame_ms / b.frame_ms)))
        {
            let _ = writeln!(
                md,
                "| **{}: best within FLIP ≤ 0.05** | {} | | | | | **{:.1}×** | {:.3} |",
                best.scene,
                lod_label(&best.lod),
                group[0].frame_ms / best.frame_ms,
                best.flip
            );
        }
    }
    Ok((Table { markdown: md, csv }, rows))
}

/// Frame time against strands per path and evaluation, as (file name, caption).
fn draw_generation_plot(out: &Path, rows: &[Row]) -> Result<(String, String)> {
    use hairkit_cli::plots::{Chart, Series, draw};
    let mut series: Vec<Series> = Vec::new();
    for path in [GenerationPath::Compute, GenerationPath::Mesh] {
        for filtering in [Filtering::StrandCoherent, Filtering::Hardware] {
            let points: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.path == path && r.filtering == filtering)
                .map(|r| (r.strands as f64, r.total_ms))
                .collect();
            if !points.is_empty() {
                series.push(Series { name: format!("{path} path, {}", evaluation_name(filtering)), points });
            }
        }
    }
    let chart = Chart {
        title: "Frame time vs strands (one character, LOD off)",
        x_label: "strands",
        y_label: "GPU frame time (ms)",
        log_x: true,
        log_y: true,
        lines: true,
    };
    draw(&out.join("plot-generation.png"), &chart, &series)?;
    Ok(("plot-generation.png".to_owned(), chart.title.to_owned()))
}

fn draw_accuracy_plot(out: &Path, accuracy_csv: &str) -> Result<(String, String)> {
    use hairkit_cli::plots::{Chart, Series, draw};
    // configuration, max_widths, mean_widths, max_percent, strands, flip, frame_ms, bytes
    let accuracy: Vec<Series> = accuracy_csv
        .lines()
        .skip(1)
        .filter_map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            let (error, ms) = (f.get(1)?.parse::<f64>().ok()?, f.get(6)?.parse::<f64>().ok()?);
            // Exact configurations have no error: plot them at the axis floor.
            Some(Series { name: (*f.first()?).to_owned(), points: vec![(ms, error.max(1e-4))] })
        })
        .collect();
    let chart = Chart {
        title: "Accuracy vs time (error against the f64 CPU reference)",
        x_label: "GPU frame time (ms)",
        y_label: "max position error (strand widths)",
        log_x: false,
        log_y: true,
        lines: false,
    };
    draw(&out.join("plot-accuracy.png"), &chart, &accuracy)?;
    Ok(("plot-accuracy.png".to_owned(), chart.title.to_owned()))
}

fn draw_crowd_plot(out: &Path, crowd: &[CrowdRow]) -> Result<(String, String)> {
    use hairkit_cli::plots::{Chart, Series, draw};
    let mut crowd_series: Vec<Series> = Vec::new();
    for group in crowd.chunk_by(|a, b| a.scene == b.scene) {
        let point = |r: &CrowdRow| (r.flip.max(1e-4), group[0].frame_ms / r.frame_ms);
        crowd_series.push(Series {
            name: format!("{} (strand LOD α = 16 … 256)", group[0].scene),
            points: group.iter().filter(|r| r.lod.enabled && !r.lod.auto).map(point).collect(),
        });
        // A point of its own: auto is not on the α line.
        crowd_series.push(Series {
            name: format!("{}: \"lod\": \"auto\"", group[0].scene),
            points: group.iter().filter(|r| r.lod.auto).map(point).collect(),
        });
    }
    let chart = Chart {
        title: "Crowds: LOD speed-up vs image error",
        x_label: "mean FLIP against LOD off",
        y_label: "speed-up over LOD off",
        log_x: true,
        log_y: true,
        lines: true,
    };
    draw(&out.join("plot-crowd.png"), &chart, &crowd_series)?;
    Ok(("plot-crowd.png".to_owned(), chart.title.to_owned()))
}

/// `off`, `auto` or `explicit`.
fn lod_kind(lod: &LodDesc) -> &'static str {
    if !lod.enabled {
        "off"
    } else if lod.auto {
        "auto"
    } else {
        "explicit"
    }
}

/// `off`, `auto` or `α_s = 64 / α_v = 1024`.
fn lod_label(lod: &LodDesc) -> String {
    match lod_kind(lod) {
        "explicit" => format!("α_s = {} / α_v = {}", lod.strand_alpha, lod.vertex_alpha),
        kind => kind.to_owned(),
    }
}

struct CrowdRow {
    scene: String,
    lod: LodDesc,
    strands: u64,
    segments: u64,
    /// Characters drawn as volumes (`auto` on the compute rasterizer).
    volumes: u64,
    frame_ms: f64,
    flip: f64,
}

/// Every accuracy switch side by side: error against the f64 CPU reference, image error against
/// the most accurate render (exact cubic, manual f32 filtering, LOD off), GPU time, memory.
fn accuracy_table(ctx: &Context, quick: bool, width: u32, height: u32, frames: usize) -> Result<Table> {
    let strands = if quick { 1_000 } else { 10_000 };
    let asset = asset(strands)?;
    // Far enough that LOD has something to drop.
    let camera = Camera {
        eye: Vec3::new(0.0, 1.8, 1.6),
        target: Vec3::new(0.0, 1.55, 0.0),
        fov_y: 50f32.to_radians(),
    };
    let character = [Character { hair: 0, transform: Mat4::IDENTITY }];
    let off = LodParams { enabled: false, ..LodParams::default() };
    let lod = |alpha: f64| LodParams { strand_alpha: alpha, vertex_alpha: alpha, ..LodParams::default() };
    let hardware = GeneratorOptions { filtering: Filtering::Hardware, ..GeneratorOptions::default() };
    let configs: Vec<(&str, TexturePrecision, GeneratorOptions, LodParams)> = vec![
        (
            "exact cubic / f32 / manual filtering",
            TexturePrecision::F32,
            GeneratorOptions {
                filtering: Filtering::Manual,
                exact_cubic: true,
                ..GeneratorOptions::default()
            },
            off,
        ),
        (
            "quadratics / f32 / per-vertex manual filtering",
            TexturePrecision::F32,
            GeneratorOptions { filtering: Filtering::Manual, ..GeneratorOptions::default() },
            off,
        ),
        ("quadratics / f32 / strand-coherent", TexturePrecision::F32, GeneratorOptions::default(), off),
        ("quadratics / f32 / hardware trilinear", TexturePrecision::F32, hardware, off),
        ("quadratics / f16 / strand-coherent", TexturePrecision::F16, GeneratorOptions::default(), off),
        ("quadratics / f16 / hardware trilinear", TexturePrecision::F16, hardware, off),
        ("f32 strand-coherent / LOD α = 1", TexturePrecision::F32, GeneratorOptions::default(), lod(1.0)),
        ("f32 strand-coherent / LOD α = 4", TexturePrecision::F32, GeneratorOptions::default(), lod(4.0)),
        ("f32 strand-coherent / LOD α = 16", TexturePrecision::F32, GeneratorOptions::default(), lod(16.0)),
    ];
    let mut md = String::new();
    let _ = writeln!(md, "\n### Accuracy vs time\n");
    let _ = writeln!(
        md,
        "{} strands, {width}×{height}, compute path, camera 1.6 m away. Position error against the f64 CPU reference at the same LOD (so LOD rows show the generation error; what LOD drops shows in the image error), in strand widths ({:.1} mm) and in % of the hair length; image error: mean FLIP against the first row. Medians of {frames} frames.\n",
        asset.total_strands(),
        asset.style.width * 1e3
    );
    let _ = writeln!(
        md,
        "| configuration | max error (widths) | mean (widths) | max (% of length) | strands drawn | FLIP mean | frame (ms) | asset bytes |\n|---|---|---|---|---|---|---|---|"
    );
    let mut csv = String::from(
        "configuration,max_widths,mean_widths,max_percent_length,strands,flip_mean,frame_ms,asset_bytes\n",
    );
    let mut reference: Option<RgbaImage> = None;
    for (name, precision, options, lod) in configs {
        let generator = Generator::with_options(ctx, options)?;
        let hair = GpuHair::upload(ctx, &asset, precision)?;
        let view = FrameView { camera, width, height, path: GenerationPath::Compute, lod };
        let inputs = render::camera::character_inputs(&camera, &character[0], width, height, lod);
        let capture = generator.capture(
            ctx,
            &hair,
            &gen_gpu::FrameInputs { cull: false, ..inputs },
            GenerationPath::Compute,
        )?;
        let mut oracle_asset = asset.clone();
        oracle_asset.curve = if options.exact_cubic {
            hairmesh::texture::CurveEvaluation::Cubic
        } else {
            hairmesh::texture::CurveEvaluation::Quadratic
        };
        let a = gen_gpu::accuracy::compare_to_reference(
            &oracle_asset,
            &gen_gpu::FrameInputs { cull: false, ..inputs },
            &capture,
        )?;
        let hairs = [hair];
        render_crowd(ctx, &generator, &hairs, &character, &view)?;
        let mut times = Vec::new();
        let mut image = None;
        for _ in 0..frames {
            let frame = render_crowd(ctx, &generator, &hairs, &character, &view)?;
            times.push(frame.timings.pass_ms("crowd frame").unwrap_or(f64::NAN));
            image = Some(frame.image);
        }
        let image = image.context("no frame rendered")?;
        let flip = match &reference {
            None => {
                reference = Some(image);
                0.0
            }
            Some(r) => flip_mean(r, &image),
        };
        let t = median(times);
        let bytes = hairs[0].bytes.total();
        let _ = writeln!(
            md,
            "| {name} | {:.4} | {:.5} | {:.5} | {} | {flip:.4} | {t:.1} | {bytes} |",
            a.max_position_widths,
            a.mean_position_widths,
            a.max_position_of_length * 100.0,
            a.strands
        );
        let _ = writeln!(
            csv,
            "{name},{:.6},{:.6},{:.6},{},{flip:.6},{t:.3},{bytes}",
            a.max_position_widths,
            a.mean_position_widths,
            a.max_position_of_length * 100.0,
            a.strands
        );
    }
    Ok(Table { markdown: md, csv })
}

/// One generated character (opaque, OIT, OIT + shadows) and the artist's full Sintel groom
/// (OIT + shadows) through `hair-render`'s scene renderer: per-pass times.
fn effects_table(setup: &Setup<'_>, width: u32, height: u32, frames: usize) -> Result<Table> {
    let (ctx, quick) = (setup.ctx, setup.quick);
    let dir = std::env::temp_dir().join(format!("hair-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let strands = if quick { 5_000 } else { 100_000 };
    let asset_dir = write_asset_dir(&dir.join("hair"), strands)?;
    let sintel = sintel_groom();
    let mut scenes = vec![
        (
            format!("{strands}-strand character, opaque"),
            serde_json::json!({ "transparency": "opaque" }),
            false,
        ),
        (format!("{strands}-strand character, OIT"), serde_json::json!({ "transparency": "oit" }), false),
        (
            format!("{strands}-strand character, OIT + shadows"),
            serde_json::json!({ "transparency": "oit", "shadows": true }),
            false,
        ),
    ];
    if sintel.is_some() {
        scenes.push((
            "Sintel full groom (11,400 × 16, TressFX) on the bust, OIT + shadows".to_owned(),
            serde_json::json!({ "transparency": "oit", "shadows": true }),
            true,
        ));
    }
    let mut md = String::new();
    let _ = writeln!(md, "\n### Render passes (`hair-render` scenes)\n");
    let _ = writeln!(
        md,
        "{width}×{height}, compute path, LOD on, one directional light. Frame time is the whole submission (GPU timestamps); shadow maps are computed on the first frame and cached for a static scene, so their cost is listed separately from the first frame. *resolve*: the triangle raster's OIT resolve, or the compute rasterizer's shade and resolve passes. Other renderers measured on this machine take 0.3–1 s per frame for scenes of the Sintel groom's size (issue note).\n"
    );
    let _ = writeln!(
        md,
        "| scene | strands | generate (ms) | raster / OIT fill (ms) | resolve (ms) | shadow maps, first frame (ms) | frame (ms) |\n|---|---|---|---|---|---|---|"
    );
    let mut csv = String::from("scene,strands,generate_ms,raster_ms,resolve_ms,shadow_ms,frame_ms\n");
    for (name, effects, is_sintel) in scenes {
        let (camera, character) = if let (true, Some(groom)) = (is_sintel, &sintel) {
            groom.clone()
        } else {
            (
                serde_json::json!({ "eye": [0.0, 1.82, 0.62], "target": [0.0, 1.55, 0.0], "fov_y_degrees": 45 }),
                serde_json::json!({ "hair": asset_dir, "color": [0.0835, 0.0272, 0.00719] }),
            )
        };
        let scene = serde_json::json!({
            "output": { "width": width, "height": height },
            "camera": camera,
            "lights": [ { "directional": { "direction": [0.5, 0.8, 0.6] } } ],
            "characters": [ character ],
            "effects": effects
        });
        let path = dir.join("scene.json");
        std::fs::write(&path, serde_json::to_vec_pretty(&scene)?)?;
        let mut loaded = render::scene::load_scene(&path)?;
        loaded.scene.effects.raster = setup.raster;
        // `compute` where the compute rasterizer cannot draw the effects (OIT) falls back to
        // the triangle raster, and the table says which drew each row.
        if loaded.validate().is_err() {
            loaded.scene.effects.raster = render::scene::Raster::Triangles;
        }
        let renderer = render::frame::SceneRenderer::new(ctx, &loaded, GenerationPath::Compute)?;
        let name = format!("{name} [{}]", renderer.raster());
        let first = renderer.render(ctx)?;
        let shadow_ms = first.shadow_ms;
        let mut generate = Vec::new();
        let mut raster = Vec::new();
        let mut resolve = Vec::new();
        let mut total = Vec::new();
        let mut strands_drawn = 0;
        for _ in 0..frames {
            let f = renderer.render(ctx)?;
            let sum = |prefix: &str| {
                f.timings
                    .passes
                    .iter()
                    .filter(|p| p.depth == 1 && p.name.starts_with(prefix))
                    .filter_map(|p| p.gpu_ms)
                    .fold(0.0, |a, b| a + b)
            };
            generate.push(sum("lod+cull") + sum("generate"));
            raster.push(sum("raster hair"));
            resolve.push(sum("OIT resolve") + sum("shade hair") + sum("resolve hair"));
            total.push(f.timings.pass_ms("scene frame").unwrap_or(f64::NAN));
            strands_drawn = f.stats.strands;
        }
        let (g, r, o, t) = (median(generate), median(raster), median(resolve), median(total));
        let shadow = shadow_ms.map_or("—".to_owned(), |ms| format!("{ms:.0}"));
        let _ = writeln!(md, "| {name} | {strands_drawn} | {g:.1} | {r:.1} | {o:.1} | {shadow} | {t:.1} |");
        let _ = writeln!(
            csv,
            "{},{strands_drawn},{g:.3},{r:.3},{o:.3},{},{t:.3}",
            name.replace(',', ";"),
            shadow_ms.unwrap_or(0.0)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(Table { markdown: md, csv })
}
