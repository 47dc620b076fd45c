//! `generation`: strand-coherent against per-vertex evaluation, per path and strand count, and
//! the generate pass alone; the plot of vertices per second.

use super::*;

pub(super) struct Row {
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

/// Generation + raster of one character per path and per evaluation (strand-coherent, the
/// default, and per-vertex hardware filtering), LOD off.
pub(super) fn generation_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
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

pub(super) fn evaluation_name(filtering: Filtering) -> &'static str {
    match filtering {
        Filtering::StrandCoherent => "strand-coherent",
        Filtering::Hardware => "per-vertex (hardware)",
        Filtering::Manual => "per-vertex (manual)",
    }
}

/// Frame time against strands per path and evaluation, as (file name, caption).
pub(super) fn draw_generation_plot(out: &Path, rows: &[Row]) -> Result<(String, String)> {
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
