//! `accuracy`: what accuracy costs in time: texture precision and filtering against the f64
//! reference.

use super::*;

pub(super) fn accuracy_section(setup: &Setup<'_>) -> Result<Section> {
    let table = accuracy_table(setup.ctx, setup.quick, setup.width, setup.height, setup.frames)?;
    let plot = draw_accuracy_plot(setup.out, &table.csv)?;
    Ok(table_section("accuracy", "bench-accuracy.csv", table, setup, Some(plot)))
}

pub(super) fn draw_accuracy_plot(out: &Path, accuracy_csv: &str) -> Result<(String, String)> {
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

/// Every accuracy switch side by side: error against the f64 CPU reference, image error against
/// the most accurate render (exact cubic, manual f32 filtering, LOD off), GPU time, memory.
pub(super) fn accuracy_table(
    ctx: &Context,
    quick: bool,
    width: u32,
    height: u32,
    frames: usize,
) -> Result<Table> {
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
