//! Hair volumes (`render::volume`): the voxelization against its CPU port and the projected
//! area it must conserve, the AO kernel against its port, the volume LOD path against the strands
//! at several distances (FLIP tolerances shrinking with distance), the hard cases (an empty
//! volume, a single strand, behind the camera, the near plane, the camera inside, the smallest
//! and largest volumes), caching, and the graph of scenes without the effects. GPU harness,
//! validation layer on.

use std::process::ExitCode;
use std::sync::Arc;

use anyhow::{Context as _, ensure};
use gen_gpu::GenerationPath;
use glam::Vec3;
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};
use hairkit_tests::image_compare::{Tolerance, compare, output_dir};
use hairkit_tests::scenes::scene_with;
use hairmesh::asset::HairAsset;
use hairmesh::reference::LodParams;
use render::cpu::volume as cpu;
use render::frame::{RenderedFrame, SceneRenderer};
use render::instance::{CharacterHair, SceneInstance};
use render::scene::{AUTO_LOD_FLIP, LoadedScene, LodDesc, load_scene};

/// `one_character` at `size` with `effects` (the compute rasterizer unless they say otherwise)
/// and the camera `distance` times as far from its target as the scene's.
fn scene(size: (u32, u32), effects: serde_json::Value, distance: f32) -> anyhow::Result<LoadedScene> {
    let dir = tempfile::tempdir()?;
    let mut effects = effects;
    if let Some(e) = effects.as_object_mut() {
        e.entry("raster").or_insert_with(|| serde_json::json!("compute"));
    }
    let mut scene = load_scene(&scene_with(dir.path(), "one_character", size.0, size.1, effects)?)?;
    let c = &mut scene.scene.camera;
    let (eye, target) = (Vec3::from_array(c.eye), Vec3::from_array(c.target));
    c.eye = (target + (eye - target) * distance).to_array();
    Ok(scene)
}

fn write(frame: &RenderedFrame, name: &str) -> anyhow::Result<()> {
    render::output::write_png(&output_dir().join(format!("volume-{name}.png")), &frame.image)?;
    Ok(())
}

/// The scene's generated hair asset (style merged).
fn asset_of(instance: &SceneInstance) -> anyhow::Result<Arc<HairAsset>> {
    match &instance.characters.first().context("no character")?.hair {
        CharacterHair::Generated(a) => Ok(a.clone()),
        CharacterHair::Stored { .. } => anyhow::bail!("stored strands"),
    }
}

/// Mean of the frame's linear luminance over the pixels where hair or occluders are.
fn mean_covered_luminance(frame: &RenderedFrame) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for p in frame.linear.rgba.chunks_exact(4) {
        if p[3] > 0.5 {
            sum += f64::from(0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]);
            n += 1.0;
        }
    }
    sum / f64::max(n, 1.0)
}

/// The same character drawn by its strands and raymarched through its volume at each distance
/// (`load(volume, distance)`): `check` passes on the volume frame, no strand is rasterized, and
/// the mean FLIP stays within each distance's tolerance and falls with distance. Images go to
/// `volume-{name}-{distance}[-strands].png`.
fn strands_against_volume(
    ctx: &gen_gpu::Context,
    name: &str,
    tolerances: [(f32, f32); 3],
    load: impl Fn(bool, f32) -> anyhow::Result<LoadedScene>,
    check: impl Fn(&RenderedFrame) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut previous = f32::INFINITY;
    for (distance, tolerance) in tolerances {
        let s = SceneRenderer::new(ctx, &load(false, distance)?, GenerationPath::Compute)?.render(ctx)?;
        let v = SceneRenderer::new(ctx, &load(true, distance)?, GenerationPath::Compute)?.render(ctx)?;
        write(&v, &format!("{name}-{distance}"))?;
        write(&s, &format!("{name}-{distance}-strands"))?;
        check(&v)?;
        ensure!(v.stats.strands == 0, "a raymarched character rasterizes {} strands", v.stats.strands);
        let any = Tolerance { mean: 1.0, percentile: (0.99, 1.0) };
        let flip = compare(&format!("volume_{name}_{distance}"), &v.image, &s.image, any)
            .map_err(anyhow::Error::msg)?;
        eprintln!("  {name}, {distance}× the distance: FLIP mean {:.4} (allowed {tolerance})", flip.mean);
        ensure!(flip.mean <= tolerance, "FLIP {} over {tolerance}", flip.mean);
        ensure!(flip.mean <= previous * 1.1, "the error should fall with distance");
        previous = flip.mean;
    }
    Ok(())
}

fn main() -> ExitCode {
    run_gpu_tests(vec![
        GpuTest::new("voxelization_and_ao_match_their_cpu_ports", Requirements::INT64_ATOMICS, |ctx| {
            let settings = scene((96, 72), serde_json::json!({ "ao": true }), 1.0)?;
            let instance = SceneInstance::load(&settings)?;
            let asset = asset_of(&instance)?;
            let renderer = SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?;
            let frame = renderer.render(ctx)?;
            ensure!(frame.volumes_voxelized == 1, "{:?}", frame.passes);
            let gpu = renderer.read_volume(ctx, 0)?.context("no volume after a frame with AO")?;
            let grid = gpu.grid;
            // The strands the voxelization's LOD pass asks for (strand LOD at a voxel per pixel).
            let inputs = render::volume::voxelization_inputs(&asset, grid.resolution);
            let strands = asset.generate_reference(&inputs.view, &inputs.lod);
            let full =
                asset.generate_reference(&inputs.view, &LodParams { enabled: false, ..LodParams::default() });
            let sums =
                cpu::voxelize(&grid, strands.iter().map(|s| (s.positions.as_slice(), s.widths.as_slice())));
            // Conservation: the area every segment carries (in voxel units), all inside the grid.
            let voxel = f64::from(grid.voxel);
            let area = |strands: &[hairmesh::reference::Strand]| -> f64 {
                strands
                    .iter()
                    .flat_map(|s| {
                        s.positions
                            .windows(2)
                            .zip(s.widths.windows(2))
                            .map(|(p, w)| (p[1] - p[0]).length() * 0.5 * (w[0] + w[1]))
                    })
                    .sum::<f64>()
                    / (voxel * voxel)
            };
            let (carried, full_area) = (area(&strands), area(&full));
            let port_total: f64 = sums.area.iter().sum();
            eprintln!(
                "  strand LOD keeps {} of {} strands, {:.4} of the full-detail area",
                strands.len(),
                full.len(),
                carried / full_area
            );
            let gpu_total: f64 = gpu.volume.iter().map(|v| f64::from(v[3])).sum();
            eprintln!(
                "  grid {:?}: area carried {carried:.3}, CPU port {port_total:.3}, GPU {gpu_total:.3} (voxel units)",
                grid.dims
            );
            ensure!(
                (port_total - carried).abs() <= 1e-6 * carried,
                "the port loses area: {port_total} of {carried}"
            );
            ensure!(
                (gpu_total - carried).abs() <= 2e-3 * carried,
                "the GPU loses area: {gpu_total} of {carried}"
            );
            // Voxel by voxel (the GPU generates in f32: a few samples land one voxel over).
            let port = cpu::resolve(&sums);
            let l1: f64 = gpu.volume.iter().zip(&port).map(|(g, p)| (f64::from(g[3]) - p[3]).abs()).sum();
            eprintln!("  voxel-wise |GPU − port| / total: {:.5}", l1 / carried);
            ensure!(l1 <= 0.01 * carried, "voxels differ by {l1} of {carried}");
            // Mean directions: within the unit ball, zero where there is no hair.
            for (i, v) in gpu.volume.iter().enumerate() {
                let length = Vec3::new(v[0], v[1], v[2]).length();
                ensure!(length <= 1.0 + 1e-5, "voxel {i}: mean direction of length {length}");
                ensure!(v[3] > 0.0 || length == 0.0, "voxel {i}: a direction without hair");
            }
            // AO from the GPU's own densities through the port.
            let radius = render::volume::ao_radius_voxels(&grid, settings.scene.effects.ao_radius);
            let sigma: Vec<f64> = gpu.volume.iter().map(|v| f64::from(v[3])).collect();
            let ao = cpu::ambient_occlusion(&grid, &sigma, radius, 1.0);
            let worst = gpu.ao.iter().zip(&ao).map(|(&g, &p)| (f64::from(g) - p).abs()).fold(0.0, f64::max);
            let darkest = gpu.ao.iter().copied().fold(1.0, f32::min);
            eprintln!("  AO radius {radius} voxels: darkest {darkest:.3}, worst |GPU − port| {worst:.2e}");
            ensure!(worst <= 1e-4, "AO differs from its port by {worst}");
            ensure!(darkest < 0.9, "the hair occludes nothing? darkest AO {darkest}");
            // The bricks the raymarch skips: exactly the port's.
            let occupied = cpu::occupied_bricks(&grid, &sigma);
            ensure!(
                gpu.bricks.len() == occupied.len(),
                "{} bricks, the port has {}",
                gpu.bricks.len(),
                occupied.len()
            );
            let differ = gpu.bricks.iter().zip(&occupied).filter(|(g, p)| (**g == 1) != **p).count();
            let empty = occupied.iter().filter(|o| !**o).count();
            eprintln!("  bricks: {empty} of {} empty, {differ} differ from the port", occupied.len());
            ensure!(differ == 0, "{differ} bricks differ");
            Ok(())
        }),
        GpuTest::new(
            "lod_auto_stays_within_its_flip_and_raymarches_only_small_characters",
            Requirements::INT64_ATOMICS,
            |ctx| {
                // `"lod": "auto"` against LOD off, near (strands, thinned) and far (the volume).
                let mut saved = Vec::new();
                for (distance, volumes) in [(1.0, 0), (2.0, 0), (8.0, 1)] {
                    let mut auto = scene((256, 192), serde_json::json!({}), distance)?;
                    auto.scene.lod = LodDesc::AUTO;
                    let mut off = auto.clone();
                    off.scene.lod = LodDesc::OFF;
                    let a = SceneRenderer::new(ctx, &auto, GenerationPath::Compute)?.render(ctx)?;
                    let o = SceneRenderer::new(ctx, &off, GenerationPath::Compute)?.render(ctx)?;
                    write(&a, &format!("auto-{distance}"))?;
                    let any = Tolerance { mean: 1.0, percentile: (0.99, 1.0) };
                    let flip = compare(&format!("lod_auto_{distance}"), &a.image, &o.image, any)
                        .map_err(anyhow::Error::msg)?;
                    eprintln!(
                        "  {distance}× the distance: auto draws {} strands / {} vertices ({} volumes), LOD off {} / {}; FLIP {:.4}",
                        a.stats.strands,
                        a.stats.vertices,
                        a.volume_characters,
                        o.stats.strands,
                        o.stats.vertices,
                        flip.mean
                    );
                    saved.push(a.stats.vertices as f64 / o.stats.vertices as f64);
                    ensure!(
                        f64::from(flip.mean) <= AUTO_LOD_FLIP,
                        "{distance}×: FLIP {} over {AUTO_LOD_FLIP}",
                        flip.mean
                    );
                    ensure!(a.volume_characters == volumes, "{distance}×: {} volumes", a.volume_characters);
                    let voxelizes = a.passes.iter().any(|p| p.starts_with("voxelize"));
                    ensure!(voxelizes == (volumes > 0), "{distance}×: {:?}", a.passes);
                }
                ensure!(saved[1] < 0.7, "auto should thin the hair at twice the distance: {saved:?}");
                // On the triangle raster auto keeps strands (the volume path draws through the compute
                // rasterizer's buffers), and plans no volume at all.
                let mut triangles = scene((256, 192), serde_json::json!({ "raster": "triangles" }), 8.0)?;
                triangles.scene.lod = LodDesc::AUTO;
                let t = SceneRenderer::new(ctx, &triangles, GenerationPath::Compute)?.render(ctx)?;
                ensure!(
                    t.volume_characters == 0 && !t.passes.iter().any(|p| p.contains("voxel")),
                    "{:?}",
                    t.passes
                );
                Ok(())
            },
        ),
        GpuTest::new("volume_lod_matches_the_strands_at_a_distance", Requirements::INT64_ATOMICS, |ctx| {
            // The tolerances shrink with distance: up close a voxel is several pixels.
            let load = |volume: bool, distance: f32| {
                let effects = if volume {
                    serde_json::json!({ "volume_lod": true, "volume_lod_pixels": 1.0e6 })
                } else {
                    serde_json::json!({})
                };
                scene((256, 192), effects, distance)
            };
            strands_against_volume(ctx, "far", [(3.0, 0.02), (6.0, 0.01), (12.0, 0.005)], load, |v| {
                ensure!(
                    v.volume_characters == 1
                        && v.passes.iter().any(|p| p.starts_with("raymarch character 0"))
                );
                Ok(())
            })?;
            Ok(())
        }),
        GpuTest::new(
            "the_transition_band_switches_pixel_by_pixel_along_a_dolly",
            Requirements::INT64_ATOMICS,
            |ctx| {
                // A dolly away from the character across the band: strands, then both (each on its
                // share of the pixels), then the volume; no frame may jump more than its
                // neighbours do (a pop would).
                let settings = scene(
                    (128, 96),
                    serde_json::json!({ "volume_lod": true, "volume_lod_pixels": 40 }),
                    1.0,
                )?;
                let renderer = SceneRenderer::new(ctx, &settings, GenerationPath::Compute)?;
                let target = Vec3::new(0.0, 1.55, 0.0);
                let offset = Vec3::new(0.0, 0.27, 0.62);
                let mut fractions = Vec::new();
                let mut images = Vec::new();
                let steps = 16;
                for k in 0..=steps {
                    let distance = 2.0 * 3f32.powf(k as f32 / steps as f32);
                    let f = renderer.render_camera(ctx, target + offset * distance, target)?;
                    fractions.push(f.volume_fractions[0]);
                    images.push(f.image);
                }
                eprintln!("  volume fractions along the dolly: {fractions:.2?}");
                ensure!(
                    fractions.windows(2).all(|w| w[1] >= w[0]),
                    "the volume's share should grow as the character shrinks"
                );
                ensure!(
                    fractions[0] == 0.0 && fractions[steps] == 1.0,
                    "the dolly should start on strands and end on the volume"
                );
                let inside = fractions.iter().filter(|&&f| f > 0.0 && f < 1.0).count();
                ensure!(inside >= 2, "only {inside} frames inside the band");
                let diffs: Vec<f64> = images
                    .windows(2)
                    .map(|w| {
                        let sum: u64 = w[0]
                            .pixels
                            .iter()
                            .zip(&w[1].pixels)
                            .map(|(a, b)| u64::from(a.abs_diff(*b)))
                            .sum();
                        sum as f64 / w[0].pixels.len() as f64
                    })
                    .collect();
                eprintln!("  frame-to-frame mean |Δ| (8-bit): {diffs:.3?}");
                // A pop is a step much larger than the steps around it (the steps shrink with the
                // character as it recedes).
                for k in 1..diffs.len() - 1 {
                    let around = diffs[k - 1].max(diffs[k + 1]);
                    ensure!(
                        diffs[k] <= 1.5 * around,
                        "step {k} jumps {:.3} (around it {around:.3}): popping",
                        diffs[k]
                    );
                }
                // What a switch without the band would have been at its middle: strands against
                // the volume there.
                let middle = fractions.iter().position(|&f| f > 0.0).unwrap_or(steps / 2);
                let distance = 2.0 * 3f32.powf(middle as f32 / steps as f32);
                let eye = target + offset * distance;
                let strands = SceneRenderer::new(
                    ctx,
                    &scene((128, 96), serde_json::json!({}), 1.0)?,
                    GenerationPath::Compute,
                )?
                .render_camera(ctx, eye, target)?;
                let volume = SceneRenderer::new(ctx, &settings, GenerationPath::Compute)?
                    .with_volumes_everywhere(true)
                    .render_camera(ctx, eye, target)?;
                let pop: u64 = strands
                    .image
                    .pixels
                    .iter()
                    .zip(&volume.image.pixels)
                    .map(|(a, b)| u64::from(a.abs_diff(*b)))
                    .sum();
                eprintln!(
                    "  a switch without the band would change the frame by {:.3}",
                    pop as f64 / strands.image.pixels.len() as f64
                );
                Ok(())
            },
        ),
        GpuTest::new(
            "volumes_are_cached_and_absent_without_the_effects",
            Requirements::INT64_ATOMICS,
            |ctx| {
                let plain = SceneRenderer::new(
                    ctx,
                    &scene((64, 48), serde_json::json!({}), 1.0)?,
                    GenerationPath::Compute,
                )?;
                let frame = plain.render(ctx)?;
                ensure!(
                    !frame.graph.passes.iter().any(|p| p.name.contains("voxel") || p.name.contains("volume")),
                    "a scene without ao or volume_lod has volume passes: {:?}",
                    frame.passes
                );
                let ao = SceneRenderer::new(
                    ctx,
                    &scene((64, 48), serde_json::json!({ "ao": true }), 1.0)?,
                    GenerationPath::Compute,
                )?;
                let first = ao.render(ctx)?;
                let second = ao.render(ctx)?;
                ensure!(
                    first.volumes_voxelized == 1
                        && first.passes.iter().any(|p| p.starts_with("voxelize hair 0"))
                );
                ensure!(
                    second.volumes_voxelized == 0 && !second.passes.iter().any(|p| p.starts_with("voxelize")),
                    "static hair is voxelized once: {:?}",
                    second.passes
                );
                ensure!(
                    second.graph.passes.iter().any(|p| p.name.starts_with("voxelize hair 0") && p.cached),
                    "the cached voxelization stays in the graph, marked cached"
                );
                ensure!(
                    first.image.pixels == second.image.pixels,
                    "the cached volume renders the same frame"
                );
                // An edit of the asset (the editor's loop) re-voxelizes it on the next frame, once.
                let settings = scene((64, 48), serde_json::json!({ "ao": true }), 1.0)?;
                let instance = SceneInstance::load(&settings)?;
                let key = instance.characters[0].key.clone();
                let mut edited = (*asset_of(&instance)?).clone();
                let mut renderer = SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?;
                renderer.render(ctx)?;
                let before = renderer.read_volume(ctx, 0)?.context("no volume")?;
                let moves = hairkit_tests::scenes::pull_tips(&edited);
                let change = edited.move_vertices(&moves)?;
                renderer.update_hair(ctx, &key, &edited, &change)?;
                let after_edit = renderer.render(ctx)?;
                let settled = renderer.render(ctx)?;
                ensure!(after_edit.volumes_voxelized == 1, "an edit re-voxelizes: {:?}", after_edit.passes);
                ensure!(settled.volumes_voxelized == 0, "and only once");
                let after = renderer.read_volume(ctx, 0)?.context("no volume")?;
                ensure!(after.volume != before.volume, "the edited hair's volume did not change");
                Ok(())
            },
        ),
        GpuTest::new("ao_darkens_the_hair_and_keeps_its_coverage", Requirements::INT64_ATOMICS, |ctx| {
            let without = SceneRenderer::new(
                ctx,
                &scene((128, 96), serde_json::json!({}), 1.0)?,
                GenerationPath::Compute,
            )?
            .render(ctx)?;
            let with = SceneRenderer::new(
                ctx,
                &scene((128, 96), serde_json::json!({ "ao": true }), 1.0)?,
                GenerationPath::Compute,
            )?
            .render(ctx)?;
            write(&with, "ao")?;
            let (a, b) = (mean_covered_luminance(&without), mean_covered_luminance(&with));
            let alpha =
                |f: &RenderedFrame| f.linear.rgba.chunks_exact(4).map(|p| f64::from(p[3])).sum::<f64>();
            eprintln!("  mean luminance without AO {a:.4}, with {b:.4}");
            ensure!(b < 0.95 * a && b > 0.2 * a, "AO should darken, not blacken: {a} → {b}");
            ensure!(
                (alpha(&with) - alpha(&without)).abs() <= 1e-3 * alpha(&without),
                "AO changed the coverage"
            );
            Ok(())
        }),
        GpuTest::new("volume_shadows_agree_with_the_deep_opacity_maps", Requirements::INT64_ATOMICS, |ctx| {
            // The same light through the hair two ways: the march through the volume and the
            // deep opacity maps (triangle-rendered). Both darken the hair; they agree with each
            // other better than either agrees with no shadows.
            let frame = |effects: serde_json::Value| -> anyhow::Result<RenderedFrame> {
                Ok(SceneRenderer::new(ctx, &scene((160, 120), effects, 1.0)?, GenerationPath::Compute)?
                    .render(ctx)?)
            };
            let none = frame(serde_json::json!({}))?;
            let maps = frame(serde_json::json!({ "shadows": true, "shadow_map_size": 256 }))?;
            let volume = frame(serde_json::json!({ "volume_shadows": true }))?;
            write(&volume, "volume-shadows")?;
            write(&maps, "map-shadows")?;
            let any = Tolerance { mean: 1.0, percentile: (0.99, 1.0) };
            let flip = |a: &RenderedFrame, b: &RenderedFrame, name: &str| {
                compare(name, &a.image, &b.image, any).map(|s| s.mean).map_err(anyhow::Error::msg)
            };
            let (volume_vs_maps, none_vs_maps) =
                (flip(&volume, &maps, "volume_vs_map_shadows")?, flip(&none, &maps, "none_vs_map_shadows")?);
            let (l_none, l_maps, l_volume) = (
                mean_covered_luminance(&none),
                mean_covered_luminance(&maps),
                mean_covered_luminance(&volume),
            );
            // Where each darkens: per hair pixel, the light it lets through (against no shadows).
            let luminance = |p: &[f32]| f64::from(0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]);
            let mut pairs = Vec::new();
            for ((n, m), v) in none
                .linear
                .rgba
                .chunks_exact(4)
                .zip(maps.linear.rgba.chunks_exact(4))
                .zip(volume.linear.rgba.chunks_exact(4))
            {
                if n[3] > 0.9 && luminance(n) > 1e-3 {
                    pairs.push((luminance(m) / luminance(n), luminance(v) / luminance(n)));
                }
            }
            let count = pairs.len() as f64;
            let (mx, my) = pairs.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x / count, b + y / count));
            let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
            for (x, y) in &pairs {
                sxy += (x - mx) * (y - my);
                sxx += (x - mx) * (x - mx);
                syy += (y - my) * (y - my);
            }
            let correlation = sxy / (sxx * syy).sqrt().max(1e-12);
            eprintln!(
                "  mean luminance: no shadows {l_none:.4}, maps {l_maps:.4}, volume {l_volume:.4}; FLIP vs the maps: volume {volume_vs_maps:.4}, none {none_vs_maps:.4}; correlation of the light let through, maps vs volume, over {count} pixels: {correlation:.3}"
            );
            ensure!(l_volume < 0.95 * l_none, "volume shadows should darken the hair");
            ensure!(
                correlation > 0.5,
                "the volume shadows fall elsewhere than the maps' (correlation {correlation:.3})"
            );
            ensure!(volume.passes.iter().any(|p| p.starts_with("voxelize hair 0")), "{:?}", volume.passes);
            ensure!(
                !volume.passes.iter().any(|p| p.contains("shadow")),
                "no shadow-map pass: {:?}",
                volume.passes
            );
            Ok(())
        }),
        GpuTest::new("volume_hard_cases", Requirements::INT64_ATOMICS, |ctx| {
            let volume = serde_json::json!({ "volume_lod": true, "volume_lod_pixels": 1.0e6, "ao": true });
            let finite = |f: &RenderedFrame| f.linear.rgba.iter().all(|x| x.is_finite());
            let hair_pixels = |f: &RenderedFrame, background: [f32; 3]| {
                f.linear
                    .rgba
                    .chunks_exact(4)
                    .filter(|p| (0..3).any(|c| (p[c] - background[c]).abs() > 1e-3))
                    .count()
            };
            // Behind the camera: nothing drawn, no work beyond the empty march.
            let mut behind = scene((64, 48), volume.clone(), 1.0)?;
            behind.scene.camera.target = [0.0, 1.82, 5.0];
            let background = behind.scene.output.background;
            let f = SceneRenderer::new(ctx, &behind, GenerationPath::Compute)?.render(ctx)?;
            ensure!(finite(&f) && hair_pixels(&f, background) == 0, "hair behind the camera was drawn");
            // Camera inside the volume, and one whose near plane cuts it.
            for (name, eye) in [("inside", [0.0, 1.55, 0.0]), ("near-plane", [0.0, 1.62, 0.08])] {
                let mut s = scene((64, 48), volume.clone(), 1.0)?;
                s.scene.camera.eye = eye;
                s.scene.camera.target = [0.0, 1.55, -1.0];
                let f = SceneRenderer::new(ctx, &s, GenerationPath::Compute)?
                    .with_volumes_everywhere(true)
                    .render(ctx)?;
                write(&f, name)?;
                ensure!(finite(&f), "{name}: non-finite pixels");
                ensure!(f.passes.iter().any(|p| p.starts_with("raymarch")), "{name}: {:?}", f.passes);
            }
            // The smallest and the largest volume (the largest lowered to fit one storage buffer).
            for resolution in [16, 256] {
                let mut s = scene((64, 48), volume.clone(), 1.0)?;
                s.scene.effects.volume_resolution = resolution;
                let renderer = SceneRenderer::new(ctx, &s, GenerationPath::Compute)?;
                let f = renderer.render(ctx)?;
                let grid = renderer.read_volume(ctx, 0)?.context("no volume")?.grid;
                let bytes = grid.voxels() * render::volume::SUM_VOXEL_BYTES;
                eprintln!("  volume_resolution {resolution}: grid {:?}, {bytes} bytes of sums", grid.dims);
                ensure!(grid.dims.iter().all(|&d| d <= resolution));
                ensure!(bytes <= u64::from(ctx.capabilities().max_storage_buffer_range));
                ensure!(finite(&f) && hair_pixels(&f, background) > 50, "resolution {resolution}: no hair");
            }
            // An empty hair (every bundle without strands) and a single strand.
            for strands in [0u32, 1] {
                let settings = scene((64, 48), volume.clone(), 1.0)?;
                let mut instance = SceneInstance::load(&settings)?;
                let mut asset = (*asset_of(&instance)?).clone();
                for (b, bundle) in asset.bundles.iter_mut().enumerate() {
                    bundle.strands = if b == 40 { strands } else { 0 };
                }
                instance.characters[0].hair = CharacterHair::Generated(Arc::new(asset));
                instance.characters[0].occluder = None;
                let renderer = SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?;
                let f = renderer.render(ctx)?;
                let v = renderer.read_volume(ctx, 0)?.context("no volume")?;
                let total: f32 = v.volume.iter().map(|x| x[3]).sum();
                let drawn = hair_pixels(&f, background);
                eprintln!("  {strands} strand(s): total σ {total:.4}, {drawn} pixels drawn");
                ensure!(finite(&f) && v.ao.iter().all(|a| a.is_finite() && *a <= 1.0));
                if strands == 0 {
                    ensure!(total == 0.0 && drawn == 0, "an empty hair drew {drawn} pixels");
                } else {
                    ensure!(total > 0.0, "a single strand left no density");
                }
            }
            Ok(())
        }),
        GpuTest::new("strand_files_get_ao_and_volume_shadows", Requirements::INT64_ATOMICS, |ctx| {
            // The artist's Sintel groom (TressFX, stored strands) on its bust: its volume holds
            // the projected area of its segments, and AO darkens it on both rasterizers.
            let dir = tempfile::tempdir()?;
            let luminance =
                |effects: serde_json::Value| -> anyhow::Result<(f64, RenderedFrame, SceneRenderer)> {
                    let path = hairkit_tests::scenes::sintel_scene(dir.path(), "sintel", effects)?;
                    let renderer = SceneRenderer::new(ctx, &load_scene(&path)?, GenerationPath::Compute)?;
                    let f = renderer.render(ctx)?;
                    Ok((mean_covered_luminance(&f), f, renderer))
                };
            for raster in ["compute", "triangles"] {
                let (plain, ..) = luminance(serde_json::json!({ "raster": raster }))?;
                let (ao, frame, renderer) = luminance(serde_json::json!({ "raster": raster, "ao": true }))?;
                write(&frame, &format!("sintel-ao-{raster}"))?;
                eprintln!("  Sintel groom, {raster}: AO keeps {:.3} of the light", ao / plain);
                // (The bust, which AO leaves alone, covers more pixels than the hair.)
                ensure!(ao < 0.97 * plain, "{raster}: AO does not darken the groom");
                ensure!(frame.passes.iter().any(|p| p.contains("stored strands")), "{:?}", frame.passes);
                if raster == "compute" {
                    let v = renderer.read_volume(ctx, 0)?.context("no volume for the groom")?;
                    let settings = load_scene(&hairkit_tests::scenes::sintel_scene(
                        dir.path(),
                        "sintel",
                        serde_json::json!({}),
                    )?)?;
                    let instance = SceneInstance::load(&settings)?;
                    let CharacterHair::Stored { strands, width } = &instance.characters[0].hair else {
                        anyhow::bail!("the groom is stored strands")
                    };
                    // As uploaded: the root width tapering to 0.3 of it at the tip.
                    let mut carried = 0.0;
                    let mut first = 0usize;
                    for &n in &strands.strand_points {
                        let points = &strands.points[first..first + n as usize];
                        first += n as usize;
                        for (k, w) in points.windows(2).enumerate() {
                            let tau = |k: usize| k as f64 / (n as f64 - 1.0).max(1.0);
                            let width = |k: usize| f64::from(*width) * (1.0 - 0.7 * tau(k));
                            carried += f64::from((w[1] - w[0]).length()) * 0.5 * (width(k) + width(k + 1));
                        }
                    }
                    let voxel = f64::from(v.grid.voxel);
                    let total: f64 = v.volume.iter().map(|x| f64::from(x[3])).sum::<f64>() * voxel * voxel;
                    eprintln!("  groom area carried {carried:.6}, in the volume {total:.6}");
                    ensure!((total - carried).abs() <= 5e-3 * carried, "the groom's volume loses area");
                }
            }
            Ok(())
        }),
        GpuTest::new("strand_files_take_the_volume_lod_path", Requirements::INT64_ATOMICS, |ctx| {
            // The artist's Sintel groom (TressFX, stored strands) on its bust, far away: raymarched
            // through its volume instead of rasterized strand by strand, within FLIP tolerances
            // that shrink with distance; across the transition band drawn by both, each on its
            // share of the pixels; and `"lod": "auto"` raymarches it once it is small.
            let dir = tempfile::tempdir()?;
            let sintel = |effects: serde_json::Value, distance: f32| -> anyhow::Result<LoadedScene> {
                let mut scene =
                    load_scene(&hairkit_tests::scenes::sintel_scene(dir.path(), "sintel", effects)?)?;
                let c = &mut scene.scene.camera;
                let (eye, target) = (Vec3::from_array(c.eye), Vec3::from_array(c.target));
                c.eye = (target + (eye - target) * distance).to_array();
                Ok(scene)
            };
            let load = |volume: bool, distance: f32| {
                let effects = if volume {
                    serde_json::json!({ "raster": "compute", "volume_lod": true, "volume_lod_pixels": 1.0e6 })
                } else {
                    serde_json::json!({ "raster": "compute" })
                };
                sintel(effects, distance)
            };
            strands_against_volume(
                ctx,
                "sintel-far",
                [(3.0, 0.01), (6.0, 0.005), (12.0, 0.0025)],
                load,
                |v| {
                    ensure!(
                        v.volume_characters == 1
                            && v.volume_fractions == [1.0]
                            && v.passes.iter().any(|p| p.starts_with("raymarch stored character 0"))
                            && v.passes.iter().any(|p| p.contains("stored strands)")),
                        "{:?} {:?}",
                        v.volume_fractions,
                        v.passes
                    );
                    Ok(())
                },
            )?;
            // A dolly across the band: strands, both, then the volume.
            let band = sintel(
                serde_json::json!({ "raster": "compute", "volume_lod": true, "volume_lod_pixels": 40 }),
                1.0,
            )?;
            let renderer = SceneRenderer::new(ctx, &band, GenerationPath::Compute)?;
            let (eye, target) =
                (Vec3::from_array(band.scene.camera.eye), Vec3::from_array(band.scene.camera.target));
            let mut fractions = Vec::new();
            let mut both = 0;
            for k in 0..=12 {
                let distance = 2.0 * 4f32.powf(k as f32 / 12.0);
                let f = renderer.render_camera(ctx, target + (eye - target) * distance, target)?;
                let fraction = f.volume_fractions[0];
                let marched = f.passes.iter().any(|p| p.starts_with("raymarch stored character 0"));
                ensure!(marched == (fraction > 0.0), "{fraction}: {:?}", f.passes);
                if fraction > 0.0 && fraction < 1.0 {
                    ensure!(f.stats.strands > 0, "inside the band the strands draw their share too");
                    both += 1;
                }
                fractions.push(fraction);
            }
            eprintln!("  groom's volume fractions along the dolly: {fractions:.2?}");
            ensure!(fractions.windows(2).all(|w| w[1] >= w[0]), "{fractions:?}");
            ensure!(fractions[0] == 0.0 && fractions[12] == 1.0 && both >= 2, "{fractions:?}");
            // `"lod": "auto"` on the compute rasterizer: strands up close, the volume when small.
            for (distance, volumes) in [(1.0, 0), (16.0, 1)] {
                let mut auto = sintel(serde_json::json!({ "raster": "compute" }), distance)?;
                auto.scene.lod = LodDesc::AUTO;
                let f = SceneRenderer::new(ctx, &auto, GenerationPath::Compute)?.render(ctx)?;
                ensure!(
                    f.volume_characters == volumes,
                    "auto at {distance}×: {} volumes",
                    f.volume_characters
                );
            }
            Ok(())
        }),
        GpuTest::new("the_hair_ao_darkens_the_occluders", Requirements::INT64_ATOMICS, |ctx| {
            // The Sintel bust where no hair covers it (the same pixel with the groom in place and
            // moved far away) gets darker with AO near the hair, as skin beside dense hair does.
            let dir = tempfile::tempdir()?;
            let frame = |ao: bool, away: bool| -> anyhow::Result<RenderedFrame> {
                let path = hairkit_tests::scenes::sintel_scene(
                    dir.path(),
                    "sintel",
                    serde_json::json!({ "ao": ao }),
                )?;
                let mut instance = SceneInstance::load(&load_scene(&path)?)?;
                if away {
                    instance.characters[0].transform =
                        glam::Mat4::from_translation(Vec3::new(0.0, 100.0, 0.0));
                }
                Ok(SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?.render(ctx)?)
            };
            let (bare, plain, ao) = (frame(false, true)?, frame(false, false)?, frame(true, false)?);
            write(&ao, "occluder-ao")?;
            let luminance = |p: &[f32]| f64::from(0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]);
            let (mut bare_pixels, mut darker, mut brighter) = (0, 0, 0);
            let pixels = bare
                .linear
                .rgba
                .chunks_exact(4)
                .zip(plain.linear.rgba.chunks_exact(4))
                .zip(ao.linear.rgba.chunks_exact(4));
            for ((b, p), a) in pixels {
                if b[3] > 0.5 && b.iter().zip(p).all(|(x, y)| (x - y).abs() < 1e-4) {
                    bare_pixels += 1;
                    let (l_plain, l_ao) = (luminance(p), luminance(a));
                    darker += usize::from(l_ao < 0.98 * l_plain);
                    brighter += usize::from(l_ao > l_plain * 1.0001 + 1e-6);
                }
            }
            eprintln!(
                "  {bare_pixels} bare bust pixels: {darker} darker by over 2 % with AO, {brighter} brighter"
            );
            ensure!(bare_pixels > 1000, "too few bare bust pixels ({bare_pixels})");
            ensure!(darker > 100, "the hair's AO does not reach the bust");
            ensure!(brighter == 0, "AO brightened {brighter} pixels");
            Ok(())
        }),
        GpuTest::new("the_volume_lod_path_needs_the_compute_rasterizer", Requirements::NONE, |_ctx| {
            let dir = tempfile::tempdir()?;
            let path =
                scene_with(dir.path(), "one_character", 64, 48, serde_json::json!({ "volume_lod": true }))?;
            let error =
                load_scene(&path).err().context("volume_lod with raster \"triangles\" was accepted")?;
            ensure!(
                error.to_string().contains("effects.volume_lod")
                    && error.to_string().contains("compute rasterizer"),
                "{error}"
            );
            Ok(())
        }),
        GpuTest::new(
            "ao_and_volume_shadows_work_on_the_triangle_raster",
            Requirements::INT64_ATOMICS,
            |ctx| {
                // Both rasterizers read the same volumes: AO darkens the hair by about as much on
                // each (the fragment stage samples it in object space, the compute shade pass in
                // world space), and volume shadows darken it on the triangle raster too, in every
                // transparency mode.
                let luminance = |effects: serde_json::Value| -> anyhow::Result<(f64, RenderedFrame)> {
                    let f =
                        SceneRenderer::new(ctx, &scene((128, 96), effects, 1.0)?, GenerationPath::Compute)?
                            .render(ctx)?;
                    Ok((mean_covered_luminance(&f), f))
                };
                let mut ratios = Vec::new();
                for raster in ["compute", "triangles"] {
                    let (plain, _) = luminance(serde_json::json!({ "raster": raster }))?;
                    let (ao, frame) = luminance(serde_json::json!({ "raster": raster, "ao": true }))?;
                    write(&frame, &format!("ao-{raster}"))?;
                    ratios.push(ao / plain);
                }
                eprintln!(
                    "  AO keeps {:.3} of the light on the compute rasterizer, {:.3} on triangles",
                    ratios[0], ratios[1]
                );
                ensure!(ratios[1] < 0.95, "AO does not darken the triangle raster");
                ensure!(
                    (ratios[0] - ratios[1]).abs() <= 0.15 * ratios[0],
                    "the rasterizers disagree on AO: {ratios:?}"
                );
                for transparency in ["opaque", "blended", "oit"] {
                    let base = serde_json::json!({ "raster": "triangles", "transparency": transparency });
                    let mut shadowed = base.clone();
                    shadowed["volume_shadows"] = true.into();
                    let ((plain, _), (dark, frame)) = (luminance(base)?, luminance(shadowed)?);
                    write(&frame, &format!("volume-shadows-triangles-{transparency}"))?;
                    eprintln!(
                        "  volume shadows, triangles, {transparency}: {:.3} of the light",
                        dark / plain
                    );
                    ensure!(
                        dark < 0.97 * plain,
                        "{transparency}: volume shadows do not darken the triangle raster"
                    );
                }
                Ok(())
            },
        ),
    ])
}
