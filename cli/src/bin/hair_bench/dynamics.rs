//! The `dynamics` section: what hair-mesh dynamics cost per character (simulation, re-bake,
//! staging of the upload) against the hair mesh's size, and what they add to an animated crowd's
//! frame next to the same crowd with motion only and standing still.

use std::fmt::Write as _;
use std::time::Instant;

use anyhow::{Context as _, Result};
use gen_gpu::{GpuHair, TexturePrecision};
use glam::{Affine3A, Vec3};
use hairmesh::asset::{AssetParams, HairAsset, StrandCount, VertexMove};
use hairmesh::dynamics::{Collider, DynamicsParams, HairSim, Wind};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};

use super::{Section, Setup, Table, median, passes_ms, submissions_ms, table_section};

/// A head turning and nodding about a pivot at the neck (as the scenes' procedural motion).
fn head_motion(t: f64) -> Affine3A {
    let (turn, nod) = ((t * 2.0).sin() as f32 * 0.6, (t * 3.1).sin() as f32 * 0.25);
    let pivot = Vec3::new(0.0, 1.45, 0.0);
    Affine3A::from_translation(pivot)
        * Affine3A::from_rotation_y(turn)
        * Affine3A::from_rotation_x(nod)
        * Affine3A::from_translation(-pivot)
}

/// One character's costs per frame, medians over the measured frames.
struct CharacterCost {
    vertices: usize,
    texels: usize,
    simulate_ms: f64,
    rebake_ms: f64,
    texels_rebaked: f64,
    stage_ms: f64,
    bytes: u64,
}

/// Simulation (one core), re-bake of every moved vertex's texels and staging of their upload,
/// per frame, for head-cap hair meshes of growing size (6 layers, 30 fps, 4 substeps, wind with
/// gusts, one sphere collider, the head turning and nodding).
fn character_costs(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Vec<CharacterCost>> {
    let caps: &[(u32, u32)] =
        if setup.quick { &[(4, 10), (8, 20)] } else { &[(4, 10), (8, 20), (12, 30), (20, 52)] };
    let frames = if setup.quick { 8 } else { 48 };
    let mut rows = Vec::new();
    for &(rings, segments) in caps {
        let cap = hairmesh::procedural::head_cap(rings, segments);
        let mesh = HairMesh::extrude(
            &cap,
            &ExtrudeParams { layers: 6, length: 0.25, droop: 0.5, ..ExtrudeParams::default() },
        )?;
        let params = AssetParams {
            strands: StrandCount::Total(3_000),
            sample_sets: 1,
            seed: 5,
            ..AssetParams::default()
        };
        let mut asset = HairAsset::build(&mesh, &params, hairmesh::style::Style::default())?;
        let mut gpu = GpuHair::upload(setup.ctx, &asset, TexturePrecision::Auto)?;
        let dynamics = DynamicsParams {
            wind: Wind { velocity: [1.5, 0.0, 0.5], turbulence: 0.5, ..Wind::default() },
            colliders: vec![Collider::Sphere { centre: [0.0, 1.55, 0.0], radius: 0.08 }],
            ..DynamicsParams::default()
        };
        let mut sim = HairSim::new(&mesh, &dynamics, &[], &head_motion)?;
        let per_layer = mesh.vertex_count();
        progress.set_message(format!("dynamics: {} hair-mesh vertices", sim.vertex_count()));
        let (mut simulate, mut rebake, mut stage, mut texels) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut bytes = Vec::new();
        for frame in 0..frames {
            let started = Instant::now();
            sim.step(1.0 / 30.0, &head_motion);
            let positions = sim.object_positions(head_motion(sim.time()));
            let simulated = Instant::now();
            // Every vertex above the roots moves, as in a simulated frame (Player::show).
            let moves = VertexMove::above_roots(&positions, per_layer);
            let change = asset.move_vertices(&moves)?;
            let rebaked = Instant::now();
            let staged = gpu.stage_update(setup.ctx, &asset, &change)?;
            let done = Instant::now();
            // The first frames pay for allocations and page faults.
            if frame >= 2 {
                simulate.push((simulated - started).as_secs_f64() * 1e3);
                rebake.push((rebaked - simulated).as_secs_f64() * 1e3);
                stage.push((done - rebaked).as_secs_f64() * 1e3);
                texels.push(change.texels.len() as f64);
                bytes.push(staged.report.bytes as f64);
            }
        }
        rows.push(CharacterCost {
            vertices: sim.vertex_count(),
            texels: asset.textures.layout.slice_texels() as usize,
            simulate_ms: median(simulate),
            rebake_ms: median(rebake),
            texels_rebaked: median(texels),
            stage_ms: median(stage),
            bytes: median(bytes) as u64,
        });
    }
    Ok(rows)
}

/// One variant of the animated crowd, per frame (medians).
struct CrowdCost {
    name: &'static str,
    simulate_ms: f64,
    rebake_ms: f64,
    upload_ms: f64,
    gpu_ms: f64,
    wall_ms: f64,
    upload_passes: usize,
}

/// The animated heads crowd of `hairkit crowd --animated` three ways: standing still (no motion,
/// no dynamics), heads moving (motion only) and heads moving with dynamics. Per frame: the
/// simulation (all characters, in parallel on every core), re-bake + staging, the upload passes'
/// GPU time, the whole frame's GPU time and the wall time of everything.
fn crowd_costs(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<(String, Vec<CrowdCost>)> {
    let dir = setup.out.join("bench-dynamics-crowd");
    let characters = if setup.quick { 9 } else { 100 };
    let options = hairkit_cli::crowd_scenes::CrowdOptions {
        out: dir.clone(),
        characters,
        strands: 3_000,
        teapots: 1,
        teapot_strands: 100,
        teapot_variants: 1,
        size: (640, 360),
        animated: true,
        ..hairkit_cli::crowd_scenes::CrowdOptions::default()
    };
    progress.set_message("dynamics: writing the animated crowd");
    let crowd = hairkit_cli::crowd_scenes::write_crowds(&options, |_, _, _| {})?;
    let path = crowd.heads_animated.context("the crowd writer wrote no animated scene")?;
    let animated = render::scene::load_scene(&path)?;
    let frames = if setup.quick { 3 } else { 6 };
    let mut rows = Vec::new();
    let mut mean_vertices = 0;
    for name in ["still", "motion only", "motion + dynamics"] {
        progress.set_message(format!("dynamics: crowd, {name}"));
        let mut scene = animated.clone();
        for c in &mut scene.scene.characters {
            if name != "motion + dynamics" {
                c.dynamics = None;
            }
            if name == "still" {
                c.motion = None;
            }
        }
        scene.scene.effects.dynamics = name == "motion + dynamics";
        scene.validate()?;
        let length = scene.scene.animation.map_or(1, |a| a.frames);
        let mut instance = render::instance::SceneInstance::load(&scene)?;
        let animation = render::animation::Animation::new(&mut instance)?;
        if animation.dynamic_characters() > 0 {
            let counts = animation.vertex_counts();
            mean_vertices = counts.iter().map(|&c| u64::from(c)).sum::<u64>() / counts.len() as u64;
        }
        let gen_path = gen_gpu::PathChoice::Auto.resolve_with_env(setup.ctx.capabilities())?;
        let mut renderer = render::frame::SceneRenderer::from_instance(setup.ctx, &instance, gen_path)?;
        let mut live = animation.start();
        let mut player = render::animation::Player::new(&animation);
        let (mut simulate, mut rebake, mut upload, mut gpu, mut wall) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut upload_passes = 0;
        // Frame 0 pays for shader compilation, shadow maps and first uploads: not measured.
        for frame in 0..=frames {
            let started = Instant::now();
            let mut update = None;
            let mut simulate_ms = 0.0;
            if animation.moves() {
                while live.frame() < frame {
                    live.advance();
                }
                let positions = live.positions();
                if animation.dynamic_characters() > 0 {
                    simulate_ms = started.elapsed().as_secs_f64() * 1e3;
                }
                update = Some(player.show(&animation, &mut renderer, setup.ctx, frame, &positions)?);
            }
            let (eye, target) = scene.frame_camera(frame, length);
            let rendered = renderer.render_camera(setup.ctx, eye, target)?;
            if frame == 0 {
                continue;
            }
            wall.push(started.elapsed().as_secs_f64() * 1e3);
            simulate.push(simulate_ms);
            // Motion alone re-bakes nothing (its few µs of bookkeeping are not a re-bake).
            rebake.push(update.filter(|u| u.rebaked > 0).map_or(0.0, |u| u.rebake_ms));
            upload.push(passes_ms(&rendered, &["update hair"]));
            gpu.push(submissions_ms(&rendered, &["scene frame"]));
            upload_passes = rendered.passes.iter().filter(|p| p.starts_with("update hair")).count();
        }
        rows.push(CrowdCost {
            name,
            simulate_ms: median(simulate),
            rebake_ms: median(rebake),
            upload_ms: median(upload),
            gpu_ms: median(gpu),
            wall_ms: median(wall),
            upload_passes,
        });
    }
    // The assets are large for the full crowd and the scenes say nothing the table does not.
    std::fs::remove_dir_all(&dir).with_context(|| format!("removing {}", dir.display()))?;
    let label =
        format!("{characters} heads × 3,000 strands (~{mean_vertices} hair-mesh vertices each), 640×360");
    Ok((label, rows))
}

pub(super) fn dynamics_section(setup: &Setup<'_>, progress: &indicatif::ProgressBar) -> Result<Section> {
    let characters = character_costs(setup, progress)?;
    let (crowd_label, crowd) = crowd_costs(setup, progress)?;
    let mut md = String::from("### Dynamics: simulation, re-bake and upload\n\n");
    let mut csv = String::from(
        "table,row,vertices,texels,simulate_ms,rebake_ms,texels_rebaked,stage_ms,upload_bytes,upload_gpu_ms,frame_gpu_ms,wall_ms\n",
    );
    md.push_str(
        "One character per frame (30 fps: 4 substeps, wind with gusts, one sphere collider, the head turning and nodding; head-cap hair meshes with 6 layers, 3,000 strands): the simulation on one core, the re-bake of every texel the moved vertices reach (`HairAsset::move_vertices`; every vertex above the roots moves) and the staging of their upload (`GpuHair::stage_update`: packing the texels into a staging buffer, copying the CPU side of the asset). Medians of the frames after two warm-up frames.\n\n\
         | hair-mesh vertices | texels per slice | simulation | re-bake | texels re-baked | staging | bytes sent |\n|---|---|---|---|---|---|---|\n",
    );
    for c in &characters {
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} ms | {:.3} ms | {:.0} | {:.3} ms | {:.1} KB |",
            c.vertices,
            c.texels,
            c.simulate_ms,
            c.rebake_ms,
            c.texels_rebaked,
            c.stage_ms,
            c.bytes as f64 / 1e3
        );
        let _ = writeln!(
            csv,
            "character,{},{},{},{:.4},{:.4},{:.0},{:.4},{},,,",
            c.vertices,
            c.vertices,
            c.texels,
            c.simulate_ms,
            c.rebake_ms,
            c.texels_rebaked,
            c.stage_ms,
            c.bytes
        );
    }
    if let Some(c) = characters.iter().find(|c| c.vertices >= 2_000).or(characters.last()) {
        let per_vertex = c.simulate_ms / c.vertices as f64;
        let _ = writeln!(
            md,
            "\nSimulation: {:.2} µs per vertex per frame, so a 2,000-vertex hair mesh takes about {:.2} ms (goal ≤ 1 ms per character on one core: {}).",
            per_vertex * 1e3,
            per_vertex * 2_000.0,
            if per_vertex * 2_000.0 <= 1.0 { "met" } else { "**not met**" }
        );
    }
    let _ = write!(
        md,
        "\nThe animated crowd of `hairkit crowd --animated` ({crowd_label}), three ways: standing still, heads moving (motion only: placements change, nothing is simulated, re-baked or uploaded) and heads moving with dynamics. Per frame (medians of the frames after the first): the simulation of every character (in parallel on every core), re-bake + staging (CPU), the `update hair` passes (GPU copies), the whole frame on the GPU and the wall time of all of it.\n\n\
         | crowd | simulation | re-bake + staging | upload passes | upload GPU | frame GPU | wall |\n|---|---|---|---|---|---|---|\n"
    );
    for c in &crowd {
        let _ = writeln!(
            md,
            "| {} | {:.1} ms | {:.1} ms | {} | {:.2} ms | {:.0} ms | {:.0} ms |",
            c.name, c.simulate_ms, c.rebake_ms, c.upload_passes, c.upload_ms, c.gpu_ms, c.wall_ms
        );
        let _ = writeln!(
            csv,
            "crowd,{},,,{:.4},{:.4},,,,{:.4},{:.4},{:.4}",
            c.name, c.simulate_ms, c.rebake_ms, c.upload_ms, c.gpu_ms, c.wall_ms
        );
    }
    if let Some(sim) = crowd.iter().find(|c| c.name == "motion + dynamics") {
        let _ = writeln!(
            md,
            "\nSimulation of the whole crowd: {:.1} ms per frame (goal ≤ 50 ms for 100 characters on 2 cores{}).",
            sim.simulate_ms,
            if setup.quick {
                ": not judged with --quick".to_owned()
            } else if sim.simulate_ms <= 50.0 {
                ": met".to_owned()
            } else {
                ": **not met**".to_owned()
            }
        );
    }
    Ok(table_section("dynamics", "bench-dynamics.csv", Table { markdown: md, csv }, setup, None))
}
