//! `crowd`: the crowds of `hairkit crowd` with LOD off, explicit α and `"lod": "auto"`.

use super::*;

pub(super) fn crowd_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let (table, rows) = crowd_table(setup.ctx, setup.quick, setup.raster, progress)?;
    let plot = draw_crowd_plot(setup.out, &rows)?;
    Ok(table_section("crowd", "bench-crowd.csv", table, setup, Some(plot)))
}

/// Crowds with LOD off and on: the heads crowd and the teapot crowd of `hairkit crowd`, from
/// the first key of their camera paths, compute path.
pub(super) fn crowd_table(
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

pub(super) fn draw_crowd_plot(out: &Path, crowd: &[CrowdRow]) -> Result<(String, String)> {
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
pub(super) fn lod_kind(lod: &LodDesc) -> &'static str {
    if !lod.enabled {
        "off"
    } else if lod.auto {
        "auto"
    } else {
        "explicit"
    }
}

/// `off`, `auto` or `α_s = 64 / α_v = 1024`.
pub(super) fn lod_label(lod: &LodDesc) -> String {
    match lod_kind(lod) {
        "explicit" => format!("α_s = {} / α_v = {}", lod.strand_alpha, lod.vertex_alpha),
        kind => kind.to_owned(),
    }
}

pub(super) struct CrowdRow {
    scene: String,
    lod: LodDesc,
    strands: u64,
    segments: u64,
    /// Characters drawn as volumes (`auto` on the compute rasterizer).
    volumes: u64,
    frame_ms: f64,
    flip: f64,
}
