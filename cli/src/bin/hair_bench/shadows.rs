//! The `shadows` section: the deep opacity maps made by the triangle pipeline and by the compute
//! rasterizer's kernels, on the same scenes in one run (the hair itself always through the
//! compute rasterizer): the maps' time, the frame that makes them, and the FLIP between the two
//! images.

use std::fmt::Write as _;

use anyhow::{Context as _, Result};
use gen_gpu::GenerationPath;

use super::{
    Section, Setup, Table, flip_mean, median, sintel_groom, submissions_ms, table_section, write_asset_dir,
};

/// One scene's maps both ways: (maps ms, frame ms) per way, and the FLIP between the images.
struct ShadowRow {
    name: String,
    strands: u64,
    triangles: (f64, f64),
    compute: (f64, f64),
    flip: f64,
}

fn shadow_rows(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Vec<ShadowRow>> {
    let Setup { ctx, width, height, frames, .. } = *setup;
    if !ctx.capabilities().buffer_int64_atomics {
        anyhow::bail!(
            "{} has no 64-bit buffer atomics: no compute rasterizer",
            ctx.capabilities().device_name
        );
    }
    let dir = std::env::temp_dir().join(format!("hair-bench-shadows-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let near =
        serde_json::json!({ "eye": [0.0, 1.82, 0.62], "target": [0.0, 1.55, 0.0], "fov_y_degrees": 45 });
    let lights = serde_json::json!([ { "directional": { "direction": [0.5, 0.8, 0.6] } } ]);
    let mut scenes: Vec<(String, serde_json::Value)> = Vec::new();
    for &strands in setup.sizes {
        let asset_dir = write_asset_dir(&dir.join(format!("hair_{strands}")), strands)?;
        for (map, transparency) in [(512, "opaque"), (1024, "opaque"), (512, "oit")] {
            let mode = if transparency == "oit" { "OIT" } else { "opaque" };
            scenes.push((
                format!("{strands}-strand character, close-up, {mode}, {map}² map"),
                serde_json::json!({
                    "output": { "width": width, "height": height },
                    "camera": near,
                    "lights": lights,
                    "characters": [ { "hair": asset_dir, "color": [0.0835, 0.0272, 0.00719] } ],
                    "effects": { "transparency": transparency, "shadows": true, "shadow_map_size": map, "raster": "compute" }
                }),
            ));
        }
    }
    if let Some((camera, character)) = sintel_groom() {
        scenes.push((
            "Sintel full groom (11,400 × 16, TressFX) on the bust, OIT, 512² map".into(),
            serde_json::json!({
                "output": { "width": width, "height": height },
                "camera": camera,
                "lights": lights,
                "characters": [ character ],
                "effects": { "transparency": "oit", "shadows": true, "raster": "compute" }
            }),
        ));
    }
    let mut rows = Vec::new();
    for (i, (name, scene)) in scenes.into_iter().enumerate() {
        let path = dir.join(format!("scene_{i}.json"));
        std::fs::write(&path, serde_json::to_vec_pretty(&scene)?)?;
        let loaded = render::scene::load_scene(&path)?;
        let mut renderer = render::frame::SceneRenderer::new(ctx, &loaded, GenerationPath::Compute)?;
        let mut results = Vec::new();
        for way in ["compute", "triangles"] {
            progress.set_message(format!("shadows: {name} ({way})"));
            if way == "triangles" {
                renderer.use_triangle_shadows();
            }
            // Warm-up: pipelines compile at first use.
            renderer.render(ctx)?;
            let (mut maps, mut total) = (Vec::new(), Vec::new());
            let mut last = None;
            for _ in 0..frames {
                renderer.forget_shadow_maps();
                let f = renderer.render(ctx)?;
                maps.push(submissions_ms(&f, &["shadow maps"]));
                total.push(submissions_ms(&f, &["scene frame", "shadow maps"]));
                last = Some(f);
            }
            let f = last.context("no frame rendered")?;
            results.push((median(maps), median(total), f.image, f.stats.strands));
        }
        let [(cm, cf, ci, strands), (tm, tf, ti, _)] =
            <[_; 2]>::try_from(results).map_err(|_| anyhow::anyhow!("two ways, two results"))?;
        rows.push(ShadowRow {
            name,
            strands,
            triangles: (tm, tf),
            compute: (cm, cf),
            flip: flip_mean(&ti, &ci),
        });
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(rows)
}

pub(super) fn shadows_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let rows = shadow_rows(setup, progress)?;
    let mut md = String::from("### Deep opacity maps: triangle pipeline vs compute rasterizer\n\n");
    let _ = writeln!(
        md,
        "{}×{}, one directional light, the hair drawn by the compute rasterizer either way; the maps are made again every frame (as for moving hair or a moving light) by the triangle pipeline (generation into strand buffers, a depth pass and an additive opacity pass of camera-facing strips) or by the compute rasterizer's kernels (generation fused, an atomic-minimum depth pass and a fixed-point opacity pass through the same segment walker as the hair). GPU timestamps, median of {} frames after a warm-up. *maps*: the shadow submission; *frame*: maps + the frame that reads them. FLIP: mean, compute maps' image against the triangle maps' image.\n",
        setup.width, setup.height, setup.frames
    );
    md.push_str("| scene | strands | triangles: maps (ms) | compute: maps (ms) | maps speed-up | triangles: frame (ms) | compute: frame (ms) | FLIP |\n|---|---|---|---|---|---|---|---|\n");
    let mut csv = String::from(
        "scene,strands,triangles_maps_ms,compute_maps_ms,maps_speedup,triangles_frame_ms,compute_frame_ms,flip\n",
    );
    for r in &rows {
        let speedup = r.triangles.0 / r.compute.0;
        let _ = writeln!(
            md,
            "| {} | {} | {:.0} | {:.0} | {:.1}× | {:.0} | {:.0} | {:.4} |",
            r.name, r.strands, r.triangles.0, r.compute.0, speedup, r.triangles.1, r.compute.1, r.flip
        );
        let _ = writeln!(
            csv,
            "{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.5}",
            r.name.replace(',', ";"),
            r.strands,
            r.triangles.0,
            r.compute.0,
            speedup,
            r.triangles.1,
            r.compute.1,
            r.flip
        );
    }
    Ok(table_section("shadows", "bench-shadows.csv", Table { markdown: md, csv }, setup, None))
}
