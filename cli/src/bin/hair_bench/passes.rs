//! `passes`: the GPU time of each render pass for the example scenes' effects.

use super::*;

pub(super) fn passes_section(setup: &Setup<'_>) -> Result<Section> {
    let table = effects_table(setup, setup.width, setup.height, setup.frames)?;
    Ok(table_section("passes", "bench-effects.csv", table, setup, None))
}

/// One generated character (opaque, OIT, OIT + shadows) and the artist's full Sintel groom
/// (OIT + shadows) through `hair-render`'s scene renderer: per-pass times.
pub(super) fn effects_table(setup: &Setup<'_>, width: u32, height: u32, frames: usize) -> Result<Table> {
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
