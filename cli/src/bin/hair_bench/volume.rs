//! `volume`: strands against the volume LOD path at four screen coverages, AO and volume
//! shadow costs, the heads crowd.

use super::*;

/// Screen coverage (%), strand frame (ms), volume frame (ms).
pub(super) type CoverageTimes = (f64, f64, f64);

pub(super) fn volume_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let (table, rows) = volume_table(setup, progress)?;
    let plot = draw_volume_plot(setup.out, &rows)?;
    Ok(table_section("volume", "bench-volume.csv", table, setup, Some(plot)))
}

/// Frame time against screen coverage: strands (compute rasterizer) and the volume path.
pub(super) fn draw_volume_plot(out: &Path, rows: &[CoverageTimes]) -> Result<(String, String)> {
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
pub(super) fn covered_square(frame: &render::frame::RenderedFrame) -> Option<[u32; 4]> {
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
pub(super) fn tile_row(tiles: &[(&RgbaImage, [u32; 4])], size: u32) -> RgbaImage {
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

/// The GPU time of re-voxelizing the first character's hair after an edit (one outer hair-mesh
/// vertex nudged, then back: the whole hair is voxelized again, as after restyling or a
/// simulation step): median of three edits on `renderer`, warm.
pub(super) fn revoxelize_ms(
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
pub(super) fn volume_table(
    setup: &Setup<'_>,
    progress: &indicatif::ProgressBar,
) -> Result<(Table, Vec<CoverageTimes>)> {
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
