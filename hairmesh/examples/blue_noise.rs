//! Times progressive sample elimination and prints the quality (normalized minimum distance ρ)
//! of the whole set and of every power-of-two prefix, and how dense the set is along the
//! domain's edges.
//!
//! `cargo run --release -p hairmesh --example blue_noise -- [COUNT] [SEED] [--png OUT.png]`
//!
//! `--png` draws the square set twice — elimination only (`relax_rounds = 0`) above, relaxed
//! below — as its first 256 and 1,024 samples, the whole set, and the whole set's periodogram
//! (docs/blue-noise.png is `-- 4096 1 --png docs/blue-noise.png`).
//!
//! For tuning, `HK_ALPHA`, `HK_BETA`, `HK_GAMMA`, `HK_CANDIDATES`, `HK_ROUNDS` and `HK_SPACING`
//! override the parameters (`hairmesh::roots::EliminationParams`).

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, bail};
use glam::DVec2;
use hairmesh::roots::{EliminationParams, SampleDomain, prefix_quality, progressive_samples, r_max};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let png = match args.iter().position(|a| a == "--png") {
        Some(i) => Some(args.get(i + 1).context("--png needs a file name")?.clone()),
        None => None,
    };
    let positional: Vec<&String> = args
        .iter()
        .enumerate()
        .filter(|(i, a)| !a.starts_with("--") && (*i == 0 || args[i - 1] != "--png"))
        .map(|(_, a)| a)
        .collect();
    let number = |k: usize, default: u64| -> anyhow::Result<u64> {
        positional.get(k).map_or(Ok(default), |a| a.parse().with_context(|| format!("{a:?} is not a number")))
    };
    let count = number(0, 65536)? as usize;
    let seed = number(1, 1)?;
    let params = params_from_env()?;
    for domain in [SampleDomain::Square, SampleDomain::Triangle] {
        let start = Instant::now();
        let points = progressive_samples(count, domain, seed, &params);
        let elapsed = start.elapsed().as_secs_f64();
        let quality = prefix_quality(&points, domain);
        let worst = quality.iter().filter(|(n, _)| *n >= 16).map(|(_, q)| *q).fold(f64::INFINITY, f64::min);
        let full = quality.last().map_or(0.0, |q| q.1);
        println!(
            "  full {full:.3}; prefixes {:?}",
            quality.iter().map(|(n, q)| format!("{n}:{q:.2}")).collect::<Vec<_>>()
        );
        if domain == SampleDomain::Square {
            println!("  {}", edge_profile(&points));
        }
        println!(
            "{domain:?}: {} progressive samples in {elapsed:.3} s; worst power-of-two prefix (≥ 16) normalized min distance {worst:.3}",
            points.len()
        );
    }
    if let Some(out) = png {
        let relaxed = progressive_samples(count, SampleDomain::Square, seed, &params);
        let eliminated = progressive_samples(
            count,
            SampleDomain::Square,
            seed,
            &EliminationParams { relax_rounds: 0, ..params },
        );
        write_picture(Path::new(&out), &[eliminated, relaxed])?;
        println!("wrote {out}");
    }
    Ok(())
}

fn params_from_env() -> anyhow::Result<EliminationParams> {
    let env = |k: &str| -> anyhow::Result<Option<f64>> {
        std::env::var(k)
            .ok()
            .map(|v| v.parse().with_context(|| format!("{k}={v:?} is not a number")))
            .transpose()
    };
    let d = EliminationParams::default();
    Ok(EliminationParams {
        alpha: env("HK_ALPHA")?.unwrap_or(d.alpha),
        beta: env("HK_BETA")?.unwrap_or(d.beta),
        gamma: env("HK_GAMMA")?.unwrap_or(d.gamma),
        candidates_per_sample: env("HK_CANDIDATES")?.map_or(d.candidates_per_sample, |c| c as u32),
        relax_rounds: env("HK_ROUNDS")?.map_or(d.relax_rounds, |c| c as u32),
        relax_spacing: env("HK_SPACING")?.unwrap_or(d.relax_spacing),
    })
}

/// Density in bands a quarter of the packing distance wide along the square's edges, relative
/// to a uniform density (elimination keeps edge samples more often: they have fewer neighbours).
fn edge_profile(points: &[DVec2]) -> String {
    let n = points.len();
    let band = 0.25 * 2.0 * r_max(1.0, n);
    let mut counts = [0usize; 6];
    let mut on_edge = 0;
    for p in points {
        let to_edge = SampleDomain::Square.edge_distance(*p);
        on_edge += usize::from(to_edge == 0.0);
        if let Some(c) = counts.get_mut((to_edge / band) as usize) {
            *c += 1;
        }
    }
    let uniform = |k: usize| {
        let (a, b) = (k as f64 * band, (k + 1) as f64 * band);
        ((1.0 - 2.0 * a).powi(2) - (1.0 - 2.0 * b).powi(2)) * n as f64
    };
    let ratios: Vec<String> =
        (0..counts.len()).map(|k| format!("{:.2}", counts[k] as f64 / uniform(k))).collect();
    format!(
        "edge bands (density / uniform, quarter packing distance each): {ratios:?}; on the edge: {on_edge}"
    )
}

/// Rows of four 256² panels: the first 256 and 1,024 samples, all of them, the periodogram.
fn write_picture(path: &Path, rows: &[Vec<DVec2>]) -> anyhow::Result<()> {
    const PANEL: usize = 256;
    let width = 4 * PANEL + 3 * 4;
    let height = rows.len() * PANEL + (rows.len() - 1) * 4;
    let mut pixels = vec![255u8; width * height];
    for (r, points) in rows.iter().enumerate() {
        let top = r * (PANEL + 4);
        for (c, prefix) in [256usize, 1024, points.len()].into_iter().enumerate() {
            let left = c * (PANEL + 4);
            let panel_fill = |pixels: &mut Vec<u8>, x: usize, y: usize, v: u8| {
                pixels[(top + y) * width + left + x] = v;
            };
            for y in 0..PANEL {
                for x in 0..PANEL {
                    panel_fill(&mut pixels, x, y, 250);
                }
            }
            let radius = (0.3 * PANEL as f64 / (prefix as f64).sqrt()).clamp(0.7, 3.0);
            for p in &points[..prefix.min(points.len())] {
                let (cx, cy) = (p.x * (PANEL - 1) as f64, (1.0 - p.y) * (PANEL - 1) as f64);
                let reach = radius.ceil() as i64 + 1;
                for dy in -reach..=reach {
                    for dx in -reach..=reach {
                        let (x, y) = (cx.round() as i64 + dx, cy.round() as i64 + dy);
                        if x < 0 || y < 0 || x >= PANEL as i64 || y >= PANEL as i64 {
                            continue;
                        }
                        let d = ((x as f64 - cx).powi(2) + (y as f64 - cy).powi(2)).sqrt();
                        let ink = (radius + 0.5 - d).clamp(0.0, 1.0);
                        let at = (top + y as usize) * width + left + x as usize;
                        pixels[at] = pixels[at].min((250.0 * (1.0 - ink)) as u8);
                    }
                }
            }
        }
        // The periodogram |Σ e^(−2πi f·x)|² / N at integer frequencies |f| ≤ 64, log-scaled so
        // that 1 (white noise) is mid-grey; blue noise shows a dark disc around the centre.
        let half = 64i64;
        let left = 3 * (PANEL + 4);
        for fy in -half..half {
            for fx in -half..half {
                let (mut re, mut im) = (0.0f64, 0.0f64);
                for p in points {
                    let phase = -2.0 * std::f64::consts::PI * (fx as f64 * p.x + fy as f64 * p.y);
                    re += phase.cos();
                    im += phase.sin();
                }
                let power = if fx == 0 && fy == 0 { 1.0 } else { (re * re + im * im) / points.len() as f64 };
                let v = (128.0 + 60.0 * power.max(1e-3).log10()).clamp(0.0, 255.0) as u8;
                for sy in 0..2 {
                    for sx in 0..2 {
                        let x = ((fx + half) * 2 + sx) as usize;
                        let y = ((half - 1 - fy) * 2 + sy) as usize;
                        pixels[(top + y) * width + left + x] = v;
                    }
                }
            }
        }
    }
    if path.extension().is_none_or(|e| e != "png") {
        bail!("{}: expected a .png file name", path.display());
    }
    let file = std::fs::File::create(path).with_context(|| format!("{}", path.display()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(&pixels)?;
    writer.finish()?;
    Ok(())
}
