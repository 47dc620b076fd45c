//! `stored`: strands generated every frame against the same strands stored and drawn.

use super::*;

/// The same strands generated every frame (both evaluations) or drawn from the buffers an
/// earlier frame filled.
pub(super) fn stored_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
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
pub(super) fn stored_compute_raster_table(
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
