//! `hairmesh`: scalp → hair asset, and reports on assets and strand files.
//!
//! ```text
//! hairmesh convert INPUT -o DIR [--layers N] [--length X] [--droop X] [--density D | --strands N]
//!                  [--scalp SELECTOR] [--morph-layers | --drape CX,CY,CZ [--comb X,Y,Z] [--lift X]] [--up X,Y,Z] [--style FILE] [--seed N] [--sample-sets N] [--layout lattice|blocks]
//!                  [--f16]
//! hairmesh info PATH          (an asset folder, hair.json, .tfx, .tfxbone or .hair)
//! hairmesh check ASSET [--head HEAD]   (strands entering the head, exit status 1 if any; strands over its face)
//! hairmesh head-cap -o FILE   (write the project's procedural head cap as glTF)
//! ```

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use hairmesh::asset::LayerSource;
use hairmesh::asset_io::{Precision, read_asset, write_asset_replacing};
use hairmesh::convert::{ConvertSettings, Converted, LayerShape, convert_scalp, file_units};
use hairmesh::hair_mesh::BundleFace;
use hairmesh::input::References;
use hairmesh::output::{FileKind, Replace};
use hairmesh::style::Style;
use hairmesh::texture::SliceLayout;

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum LayoutArg {
    Lattice,
    Blocks,
}

#[derive(Parser, Debug)]
#[command(
    name = "hairmesh",
    version,
    about = "Turn scalp meshes into hair assets (hair mesh + textures + root sets)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args, Debug)]
struct ConvertArgs {
    input: PathBuf,
    /// Output asset folder. An existing one is replaced (atomically) only if it is a hair asset
    /// and holds nothing else; anything else needs --force.
    #[arg(short, long)]
    out: PathBuf,
    /// Replace the output even if it is not a hair asset (never the folder holding the input).
    #[arg(long)]
    force: bool,
    /// Read glTF buffers from absolute paths and `file:` URIs too (only files in the input's
    /// folder are read otherwise).
    #[arg(long)]
    trust_paths: bool,
    /// Layers above the scalp (1..=64).
    #[arg(long, default_value_t = 4)]
    layers: u32,
    /// Hair length along the normal, in the file's units, 1e-4..=100 × the scalp's size
    /// (its bounding-box diagonal) [default: 0.6 × the scalp's size].
    #[arg(long)]
    length: Option<f64>,
    /// Downward pull at the tip as a fraction of the length (-10..=10).
    #[arg(long, default_value_t = 0.3)]
    droop: f64,
    /// Strands per unit² of scalp area.
    #[arg(long, conflicts_with = "strands")]
    density: Option<f64>,
    /// Total strands, shared by area [default: 20000].
    #[arg(long)]
    strands: Option<u64>,
    /// Which faces are scalp: all, auto (the hairline suggested by the head's estimated frame:
    /// crown, back and sides, not the face), name:NAME, above:NX,NY,NZ,OFFSET,
    /// sphere:CX,CY,CZ,R, faces:LIST (indices and ranges, e.g. 4,10-20).
    #[arg(long, default_value = "all")]
    scalp: String,
    /// Take the layers from the file's morph targets (one per layer) instead of extruding.
    #[arg(long, conflicts_with = "drape")]
    morph_layers: bool,
    /// Lay the hair over the head around this centre (CX,CY,CZ, the skull's centre) instead of
    /// extruding along the normals: it flows towards gravity + `--comb`, then hangs.
    #[arg(long, value_name = "CX,CY,CZ", value_parser = parse_vec3, allow_hyphen_values = true)]
    drape: Option<glam::DVec3>,
    /// With `--drape`: the direction the hair is combed, added to gravity (e.g. 0,0,-2 combs it
    /// back when the face looks along +Z); each component -100..=100.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, default_value = "0,0,0", allow_hyphen_values = true)]
    comb: glam::DVec3,
    /// With `--drape`: how far the hair moves off the head per unit of length (0..=10).
    #[arg(long, default_value_t = 0.05)]
    lift: f64,
    /// The head's up (gravity pulls the other way), e.g. 0,0,1 for a Z-up file.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, default_value = "0,1,0", allow_hyphen_values = true)]
    up: glam::DVec3,
    /// Style as JSON (fields of hairmesh::style::Style; unknown fields and values outside
    /// their ranges, `Style::fields`, are errors).
    #[arg(long)]
    style: Option<PathBuf>,
    /// Seed of the root sample sets.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Root sample sets per domain (each bundle also reads its set under one of its domain's
    /// symmetries; every set costs 4 bytes per strand of the largest bundle on the GPU).
    #[arg(long, default_value_t = 1)]
    sample_sets: u32,
    /// Slice layout: `lattice` (faces share their vertices' texels) or `blocks` (a 2×2 block per face).
    #[arg(long, value_enum, default_value_t = LayoutArg::Lattice)]
    layout: LayoutArg,
    /// Store textures as half floats.
    #[arg(long)]
    f16: bool,
    /// No strand-level collision: the asset carries no head distance field, and strands may
    /// dip into the head between the hair mesh's vertices.
    #[arg(long)]
    no_collision: bool,
}

/// Warnings printed before the rest are summarized in one line.
const MAX_WARNINGS_SHOWN: usize = 10;

fn parse_vec3(text: &str) -> Result<glam::DVec3, String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>().map_err(|e| format!("`{s}`: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(glam::DVec3::new(x, y, z)),
        _ => Err(format!("`{text}`: expected three finite numbers X,Y,Z")),
    }
}

impl ConvertArgs {
    fn style(&self) -> Result<Style> {
        let Some(path) = &self.style else { return Ok(Style::default()) };
        let bytes = hairmesh::input::read_regular(path, 1 << 20)
            .with_context(|| format!("reading {}", path.display()))?;
        serde_json::from_slice::<Style>(&bytes)
            .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), hairmesh::input::json_error(&e)))
    }
}

/// `hairmesh export`.
#[derive(clap::Args, Debug)]
struct ExportArgs {
    /// The asset folder (or its hair.json).
    asset: PathBuf,
    /// The file to write: `.usda` or `.tfx` (strands) or `.gltf` (the hair mesh).
    #[arg(short, long)]
    out: PathBuf,
    /// Strands to export [default: all]; each bundle keeps the same share of its roots.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=100_000_000))]
    strands: Option<u64>,
    /// The hair colour (linear RGB, 0–1) of `groom_color` and `displayColor`.
    #[arg(long, value_parser = parse_color, allow_hyphen_values = true)]
    color: Option<[f32; 3]>,
    /// The stage's metersPerUnit [default: 1; say it for an asset in file units, e.g. 0.01 for
    /// centimetres].
    #[arg(long)]
    meters_per_unit: Option<f64>,
    /// The stage's up axis: y or z.
    #[arg(long, default_value = "y", value_parser = ["y", "z"])]
    up_axis: String,
    /// Replace the output even if it is not a USD text file.
    #[arg(long)]
    force: bool,
}

fn parse_color(s: &str) -> Result<[f32; 3], String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{s:?}: {e}"))?;
    match parts[..] {
        [r, g, b] if [r, g, b].iter().all(|c| (0.0..=1.0).contains(c)) => Ok([r, g, b]),
        _ => Err(format!("{s:?}: expected R,G,B with each in 0..1")),
    }
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Convert a scalp mesh (.gltf, .glb, .obj) into a hair asset folder.
    Convert(Box<ConvertArgs>),
    /// Describe an asset or a strand file.
    Info { path: PathBuf },
    /// Check an asset's strands against the head: how many enter it (exit status 1 if any).
    Check {
        /// The asset folder (or its hair.json).
        asset: PathBuf,
        /// The head mesh (.gltf, .glb, .obj) [default: the scalp file the asset was converted from].
        #[arg(long)]
        head: Option<PathBuf>,
    },
    /// Export an asset for other tools: `.usda` (its strands as the renderer generates them, USD
    /// BasisCurves with Unreal's groom attributes), `.tfx` (the same strands, TressFX 4.0) or
    /// `.gltf` (its hair mesh, the layers as morph targets).
    Export(ExportArgs),
    /// Write the project's procedural head cap (the demo's scalp) as glTF.
    HeadCap {
        #[arg(short, long)]
        out: PathBuf,
        /// Replace the output even if it is not a glTF file.
        #[arg(long)]
        force: bool,
    },
}

fn main() -> std::process::ExitCode {
    hairmesh::terminal::exit_quietly_on_closed_pipe();
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hairmesh: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Convert(args) => convert(&args),
        Command::Info { path } => info(&path),
        Command::Check { asset, head } => check(&asset, head.as_deref()),
        Command::Export(args) => export(&args),
        Command::HeadCap { out, force } => {
            hairmesh::output::check_file(&out, FileKind::GLTF, &[], Replace::from_force(force))?;
            hairmesh::procedural::write_gltf(&out, &hairmesh::procedural::head_cap(8, 32), "head cap")
                .with_context(|| format!("writing {}", out.display()))?;
            println!("wrote {}", out.display());
            Ok(())
        }
    }
}

fn export(o: &ExportArgs) -> Result<()> {
    use hairmesh::export::{ExportOptions, UpAxis};
    let ext = o.out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let kind = match ext.as_deref() {
        Some("usda") => FileKind::Usda,
        Some("gltf") => FileKind::GLTF,
        Some("tfx") => FileKind::Tfx,
        _ => anyhow::bail!(
            "{}: the output must end in .usda (the strands, USD text), .tfx (the strands, TressFX 4.0) or .gltf (the hair mesh, its layers as morph targets)",
            o.out.display()
        ),
    };
    let inputs = [o.asset.as_path()];
    hairmesh::output::check_file(&o.out, kind, &inputs, Replace::from_force(o.force))?;
    let (asset, manifest) = step(&format!("reading {}", o.asset.display()), || Ok(read_asset(&o.asset)?))?;
    if kind == FileKind::GLTF {
        let hm = asset.mesh();
        if hm.tip_layers.is_some() {
            eprintln!(
                "warning: {} has bundles of different lengths; a glTF hair mesh does not carry tip layers, so read back every bundle reaches the last layer",
                o.asset.display()
            );
        }
        step(&format!("writing {}", o.out.display()), || {
            hairmesh::procedural::write_gltf(&o.out, &hairmesh::export::hair_mesh_as_scalp(hm), "hair mesh")
                .with_context(|| format!("writing {}", o.out.display()))
        })?;
        println!(
            "wrote {}: the hair mesh, {} vertices × {} layers as morph targets, {} faces (read it back with `hairmesh convert {} --morph-layers`)",
            o.out.display(),
            hm.vertex_count(),
            hm.layer_count(),
            hm.faces.len(),
            o.out.display()
        );
        return Ok(());
    }
    let meters_per_unit = match (o.meters_per_unit, manifest.units.as_str()) {
        (Some(m), _) if m.is_finite() && m > 0.0 => m,
        (Some(m), _) => anyhow::bail!("--meters-per-unit {m}: expected a positive number"),
        (None, "metres") => 1.0,
        (None, _) if kind != FileKind::Usda => 1.0,
        (None, units) => {
            eprintln!(
                "note: {} is in {units}: writing metersPerUnit = 1 (give --meters-per-unit, e.g. 0.01 for centimetres)",
                o.asset.display()
            );
            1.0
        }
    };
    let options = ExportOptions {
        strands: o.strands,
        color: o.color.unwrap_or(hairmesh::export::DEFAULT_COLOR),
        meters_per_unit,
        up_axis: if o.up_axis == "z" { UpAxis::Z } else { UpAxis::Y },
    };
    let wanted = o.strands.unwrap_or_else(|| asset.total_strands()).min(asset.total_strands());
    let strands = step(&format!("generating {wanted} strands"), || {
        Ok(hairmesh::export::export_strands(&asset, &options))
    })?;
    let points = hairmesh::export::exported_points(&strands);
    // TressFX: 16 bytes per point and 12 per strand after its header. USD text: a point's
    // position, width and colour take up to about 100 bytes as decimals (about 70 typically).
    let needed = match kind {
        FileKind::Tfx => points * 16 + strands.len() as u64 * 12 + 160,
        _ => points * 100 + strands.len() as u64 * 40 + 4096,
    };
    hairmesh::output::check_space(&o.out, needed)?;
    step(&format!("writing {}", o.out.display()), || {
        hairmesh::atomic::write_file_atomic(&o.out, |w| match kind {
            FileKind::Tfx => hairmesh::export::write_tfx(w, &strands),
            _ => hairmesh::export::write_usda(w, &strands, &options),
        })
        .with_context(|| format!("writing {}", o.out.display()))
    })?;
    let bytes = std::fs::metadata(&o.out).map_or(0, |m| m.len());
    println!(
        "wrote {}: {} curves, {points} points, {}",
        o.out.display(),
        strands.len(),
        hairmesh::terminal::bytes(bytes)
    );
    Ok(())
}

fn step<T>(what: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    eprint!("{what}… ");
    let start = Instant::now();
    let value = f()?;
    eprintln!("{:.2} s", start.elapsed().as_secs_f64());
    Ok(value)
}

fn convert(o: &ConvertArgs) -> Result<()> {
    let (input, out) = (o.input.as_path(), o.out.as_path());
    // Before any work: the output must be safe to replace.
    let replace = Replace::from_force(o.force);
    let inputs: Vec<&Path> = std::iter::once(input).chain(o.style.as_deref()).collect();
    hairmesh::output::check_asset_folder(out, &inputs, replace)?;
    let settings = ConvertSettings {
        scalp: o.scalp.clone(),
        layers: o.layers,
        length: o.length,
        shape: if o.morph_layers {
            LayerShape::MorphTargets
        } else if let Some(centre) = o.drape {
            LayerShape::Drape { centre, comb: o.comb, lift: o.lift }
        } else {
            LayerShape::Extrude { droop: o.droop }
        },
        up: o.up,
        strands: o.strands.unwrap_or(20_000),
        density: o.density,
        seed: o.seed,
        sample_sets: o.sample_sets,
        layout: match o.layout {
            LayoutArg::Lattice => SliceLayout::Lattice,
            LayoutArg::Blocks => SliceLayout::Blocks,
        },
        style: o.style()?,
        collision: !o.no_collision,
        references: if o.trust_paths { References::Anywhere } else { References::InsideFolder },
    };
    // Each step's time is printed when the next one starts, the last one's after the call.
    let mut started: Option<Instant> = None;
    let finish_step = |started: &mut Option<Instant>| {
        if let Some(t) = started.take() {
            eprintln!("{:.2} s", t.elapsed().as_secs_f64());
        }
    };
    let converted = convert_scalp(input, &settings, &mut |step: &str| {
        finish_step(&mut started);
        eprint!("{step}… ");
        started = Some(Instant::now());
    });
    finish_step(&mut started);
    let Converted { asset, scalp, length, pushed_out } = converted?;
    for w in hairmesh::terminal::summarized(&scalp.warnings, MAX_WARNINGS_SHOWN) {
        eprintln!("warning: {w}");
    }
    let hm = asset.mesh();
    let units = file_units(input, &scalp.positions);
    let precision = if o.f16 { Precision::F16 } else { Precision::F32 };
    step(&format!("writing {}", out.display()), || {
        Ok(write_asset_replacing(out, &asset, precision, units, input.to_str(), replace)?)
    })?;
    let quads = hm.faces.iter().filter(|f| matches!(f, BundleFace::Quad(_))).count();
    let t = &asset.textures;
    let bytes_per = if o.f16 { 2 } else { 4 };
    let texture_bytes = (t.hair_mesh.data.len() / 3 * 4
        + t.uv.data.len()
        + t.w.data.len()
        + t.u.data.len() / 3 * 4
        + t.v.data.len() / 3 * 4)
        * bytes_per;
    println!("asset:          {}", out.display());
    println!(
        "scalp:          {} vertices, {} faces, area {:.4} {units}²",
        scalp.positions.len(),
        scalp.faces.len(),
        scalp.area()
    );
    println!("bundles:        {} ({quads} quads, {} triangles)", hm.faces.len(), hm.faces.len() - quads);
    println!("layers:         {} (hair length {length:.4})", hm.layer_count());
    if pushed_out > 0 {
        println!("kept outside:   {pushed_out} hair-mesh vertices moved out of the head");
    }
    if let Some(f) = &asset.head_field {
        println!(
            "head field:     {}×{}×{} points, cell {:.4} {units}, strands kept {:.4} {units} out ({} bytes on the GPU)",
            f.distance.width,
            f.distance.height,
            f.distance.depth,
            f.cell,
            f.margin,
            f.texels() * 2
        );
    }
    println!("strands:        {}", asset.total_strands());
    println!(
        "textures:       {}×{} texels, {} curve slices, {texture_bytes} bytes on the GPU ({})",
        t.layout.width,
        t.layout.height,
        t.layout.curve_slices(),
        if o.f16 { "RGBA16F" } else { "RGBA32F" }
    );
    println!(
        "slice layout:   {:?}: {} texels per slice for {} root vertices ({} as 2×2 blocks)",
        settings.layout,
        t.layout.slice_texels(),
        hm.layers[0].len(),
        {
            let (w, h) = hairmesh::lattice::Lattice::block_slice(hm.faces.len());
            u64::from(w) * u64::from(h)
        }
    );
    Ok(())
}

fn check(path: &Path, head: Option<&Path>) -> Result<()> {
    let (asset, _) = read_asset(path)?;
    let dir = if path.is_dir() { path } else { path.parent().unwrap_or(Path::new(".")) };
    let head = match head {
        Some(h) => h.to_owned(),
        None => asset.provenance.as_ref().and_then(|p| p.locate(dir)).with_context(|| {
            format!(
                "{}: the asset names no scalp file that exists here; give the head with --head",
                path.display()
            )
        })?,
    };
    let mesh = hairmesh::import::load_scalp(&head, &hairmesh::ScalpSelector::All)?;
    let surface = hairmesh::head::HeadSurface::from_mesh(&mesh);
    let frame = step("estimating the head's frame", || Ok(hairmesh::head_frame::HeadFrame::estimate(&mesh)))?;
    let c =
        step("checking the strands", || Ok(hairmesh::head::check_strands(&asset, &surface, frame.as_ref())))?;
    let share = |n: u64| 100.0 * n as f64 / c.strands.max(1) as f64;
    println!("{} against {}", path.display(), head.display());
    println!("strands:                  {}", c.strands);
    match &asset.head_field {
        Some(f) => println!(
            "collision:                head field of {}×{}×{} points, strands kept {:.4} out (file units)",
            f.distance.width, f.distance.height, f.distance.depth, f.margin
        ),
        None => println!(
            "collision:                none (no head field: converted with --no-collision or before it)"
        ),
    }
    println!("strands entering the head: {} ({:.2} %)", c.entering, share(c.entering));
    if c.entering > 0 {
        println!("deepest point inside:     {:.4} (file units)", c.deepest);
    }
    println!("hair-mesh vertices inside: {}", c.vertices_inside);
    match frame {
        Some(f) => {
            let [x, y, z] = f.centre.to_array();
            println!(
                "head frame:               centre {x:.4},{y:.4},{z:.4}, radius {:.4}, up {}, front {}",
                f.radius, f.up, f.front
            );
            println!("strands over the face:    {} ({:.2} %)", c.over_face, share(c.over_face));
        }
        None => println!("head frame:               none (the head has no face with area)"),
    }
    // Hair over the face is a look (a fringe), reported; hair inside the head is an error.
    if c.entering > 0 || c.vertices_inside > 0 {
        bail!(
            "{}: {} of {} strands enter the head {}",
            path.display(),
            c.entering,
            c.strands,
            head.display()
        );
    }
    Ok(())
}

fn info(path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
    match ext.as_str() {
        "tfx" | "hair" => {
            let set = hairmesh::strands::load_strands(path)?;
            let (lo, hi) = set.bounds().context("no points")?;
            println!("{}: {}", path.display(), set.format);
            println!("strands:  {}", set.strand_count());
            println!(
                "points:   {} ({}–{} per strand)",
                set.points.len(),
                set.strand_points.iter().min().unwrap_or(&0),
                set.strand_points.iter().max().unwrap_or(&0)
            );
            println!("bounds:   {lo} .. {hi}");
            println!("extras:   thickness {}, root uv {}", set.thickness.is_some(), set.root_uv.is_some());
        }
        "tfxbone" => {
            let bones = hairmesh::strands::load_tfxbone(path)?;
            println!("{}: TressFX bone skinning", path.display());
            println!(
                "bones:    {} ({})",
                bones.bones.len(),
                bones.bones.iter().map(|(_, n)| n.as_str()).collect::<Vec<_>>().join(", ")
            );
            println!("strands:  {}", bones.strands.len());
        }
        _ if path.is_dir() || ext == "json" => {
            let (asset, manifest) = read_asset(path)?;
            let t = &asset.textures;
            println!("{}: {} v{}", path.display(), manifest.format, manifest.format_version);
            println!("source:   {}", manifest.source.as_deref().unwrap_or("-"));
            println!("units:    {}", manifest.units);
            let mesh = asset.mesh();
            println!(
                "mesh:     {} vertices × {} layers, {} faces",
                mesh.vertex_count(),
                mesh.layers.len(),
                mesh.faces.len()
            );
            if let Some(p) = &asset.provenance {
                let layers = match p.layers {
                    LayerSource::Extruded(e) => {
                        format!("extruded ({} layers, length {}, droop {})", e.layers, e.length, e.droop)
                    }
                    LayerSource::Draped(d) => format!(
                        "draped around {} ({} layers, length {}, comb {}, lift {})",
                        d.centre, d.layers, d.length, d.comb, d.lift
                    ),
                    LayerSource::MorphTargets => "morph targets".into(),
                };
                println!("scalp:    {} (faces `{}`), {layers}", p.file, p.selector);
            }
            println!("bundles:  {} ({} layers)", asset.bundles.len(), t.layout.layers);
            if let Some(tips) = &mesh.tip_layers {
                let mut counts = std::collections::BTreeMap::<u32, usize>::new();
                for &t in tips {
                    *counts.entry(t).or_default() += 1;
                }
                let counts: Vec<String> = counts.iter().map(|(t, n)| format!("{n} at layer {t}")).collect();
                println!("lengths:  bundles end at different layers: {}", counts.join(", "));
            }
            println!("strands:  {}", asset.total_strands());
            println!(
                "textures: {}×{} texels, {} curve slices, {:?}",
                t.layout.width,
                t.layout.height,
                t.layout.curve_slices(),
                manifest.precision
            );
            for (name, sets) in [("square", &asset.square_sets), ("triangle", &asset.triangle_sets)] {
                for (i, s) in sets.iter().enumerate() {
                    let worst = s.quality.iter().map(|(_, q)| *q).fold(f64::INFINITY, f64::min);
                    let listing: Vec<String> = s.quality.iter().map(|(n, q)| format!("{n}:{q:.2}")).collect();
                    println!(
                        "{name} set {i}: {} samples, worst prefix min-distance {worst:.3} ({})",
                        s.points.len(),
                        listing.join(" ")
                    );
                }
            }
        }
        _ => bail!("{}: not an asset folder, hair.json, .tfx, .tfxbone or .hair file", path.display()),
    }
    Ok(())
}
