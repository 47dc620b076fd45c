//! Animated scenes (`render::animation`): scenes without dynamics record no upload pass and keep
//! their caches; one dynamic character among static ones re-bakes, uploads and re-voxelizes only
//! itself; simulation caches are refused when damaged or made from another scene. GPU harness,
//! validation layer on.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context as _, ensure};
use gen_gpu::GenerationPath;
use hairkit_tests::harness::{GpuTest, Requirements, run_gpu_tests};
use hairkit_tests::scenes::scene_with;
use render::animation::{Animation, Player};
use render::frame::{RenderedFrame, SceneRenderer};
use render::instance::SceneInstance;
use render::scene::load_scene;
use render::sim_cache::{SimCache, cache_bytes, write_sim_cache};

/// `assets/scenes/dynamics.json` at 96×72 with `effects` (dynamics on), changed by `edit`.
fn dynamics_scene(
    dir: &Path,
    effects: serde_json::Value,
    edit: impl FnOnce(&mut serde_json::Value),
) -> anyhow::Result<PathBuf> {
    let path = scene_with(dir, "dynamics", 96, 72, effects)?;
    let mut json: serde_json::Value = serde_json::from_slice(&std::fs::read(&path)?)?;
    edit(&mut json);
    std::fs::write(&path, serde_json::to_vec_pretty(&json)?)?;
    Ok(path)
}

/// The process's peak resident memory (Linux: `VmHWM` of /proc/self/status).
fn peak_memory_bytes() -> anyhow::Result<u64> {
    let status = std::fs::read_to_string("/proc/self/status")?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).context("no VmHWM")?;
    let kb: u64 = line.split_whitespace().nth(1).context("VmHWM value")?.parse()?;
    Ok(kb * 1024)
}

fn uploads(frame: &RenderedFrame) -> Vec<&String> {
    frame.passes.iter().filter(|p| p.starts_with("update hair")).collect()
}

/// Sets up the scene's renderer and animation, then renders `frames` frames from the live
/// simulation, returning each frame and what the player did.
fn play(
    ctx: &gen_gpu::Context,
    scene: &Path,
    frames: u32,
) -> anyhow::Result<Vec<(RenderedFrame, render::animation::FrameUpdate)>> {
    let scene = load_scene(scene)?;
    let mut instance = SceneInstance::load(&scene)?;
    let animation = Animation::new(&mut instance)?;
    let mut renderer = SceneRenderer::from_instance(ctx, &instance, GenerationPath::Compute)?;
    let mut player = Player::new(&animation);
    let mut live = animation.start();
    let mut out = Vec::new();
    for f in 0..frames {
        while live.frame() < f {
            live.advance();
        }
        let update = player.show(&animation, &mut renderer, ctx, f, &live.positions())?;
        out.push((renderer.render(ctx)?, update));
    }
    Ok(out)
}

fn main() -> ExitCode {
    run_gpu_tests(vec![
        GpuTest::new("a_scene_without_dynamics_records_no_upload_pass", Requirements::NONE, |ctx| {
            let dir = tempfile::tempdir()?;
            let effects = serde_json::json!({ "shadows": true, "shadow_map_size": 64 });
            // Static: no motion, no dynamics.
            let still = dynamics_scene(dir.path(), effects.clone(), |v| {
                let c = &mut v["characters"][0];
                c.as_object_mut().map(|c| (c.remove("dynamics"), c.remove("motion")));
            })?;
            let frames = play(ctx, &still, 3)?;
            for (i, (frame, update)) in frames.iter().enumerate() {
                ensure!(uploads(frame).is_empty(), "frame {i}: {:?}", frame.passes);
                ensure!(update.rebaked == 0 && update.moved == 0, "frame {i}: {update:?}");
                ensure!(
                    !frame.graph.passes.iter().any(|p| p.name.starts_with("update hair")),
                    "frame {i}: the graph has an upload pass"
                );
                ensure!(
                    i == 0 || frame.shadow_cached,
                    "frame {i}: the shadow maps of a still scene stay cached"
                );
            }
            // Head motion without dynamics: the hair moves rigidly, nothing is re-baked or
            // uploaded; the shadow maps follow the head.
            let moving = dynamics_scene(dir.path(), effects, |v| {
                v["characters"][0].as_object_mut().map(|c| c.remove("dynamics"));
            })?;
            let frames = play(ctx, &moving, 3)?;
            for (i, (frame, update)) in frames.iter().enumerate() {
                ensure!(uploads(frame).is_empty(), "frame {i}: {:?}", frame.passes);
                ensure!(update.rebaked == 0 && update.moved == 1, "frame {i}: {update:?}");
                ensure!(!frame.shadow_cached, "frame {i}: the head moved, so its shadows did");
            }
            ensure!(frames[0].0.image != frames[2].0.image, "the head moves");
            Ok(())
        }),
        GpuTest::new("one_dynamic_character_rebakes_only_itself", Requirements::INT64_ATOMICS, |ctx| {
            // Two characters with the same hair, the first simulated, the second static beside it,
            // with AO (both hairs have volumes): every frame uploads and re-voxelizes the first
            // hair alone; the second's volume stays cached.
            let dir = tempfile::tempdir()?;
            let effects = serde_json::json!({ "raster": "compute", "ao": true, "volume_resolution": 32, "dynamics": true });
            let scene = dynamics_scene(dir.path(), effects, |v| {
                let mut second = v["characters"][0].clone();
                if let Some(c) = second.as_object_mut() {
                    c.remove("dynamics");
                    c.remove("motion");
                }
                second["transform"] = serde_json::json!({ "translation": [0.3, 0.0, 0.0] });
                if let Some(a) = v["characters"].as_array_mut() {
                    a.push(second);
                }
            })?;
            let frames = play(ctx, &scene, 4)?;
            for (i, (frame, update)) in frames.iter().enumerate() {
                ensure!(update.rebaked == 1, "frame {i}: {update:?}");
                let uploaded = uploads(frame);
                ensure!(
                    uploaded.len() == 1 && uploaded[0].starts_with("update hair 0 "),
                    "frame {i}: {uploaded:?}"
                );
                let expected = if i == 0 { 2 } else { 1 };
                ensure!(
                    frame.volumes_voxelized == expected,
                    "frame {i}: {} volumes voxelized, expected {expected}: {:?}",
                    frame.volumes_voxelized,
                    frame.passes
                );
            }
            ensure!(frames[1].0.image != frames[3].0.image, "the simulated hair moves");
            Ok(())
        }),
        GpuTest::new("simulation_caches_are_checked", Requirements::NONE, |_| {
            let dir = tempfile::tempdir()?;
            let path = dynamics_scene(dir.path(), serde_json::json!({ "dynamics": true }), |_| {})?;
            let scene = load_scene(&path)?;
            let mut instance = SceneInstance::load(&scene)?;
            let animation = Animation::new(&mut instance)?;
            let file = dir.path().join("scene.sim");
            let written = std::sync::atomic::AtomicU32::new(0);
            write_sim_cache(&animation, 6, &file, &|f| {
                written.store(f, std::sync::atomic::Ordering::Relaxed);
            })?;
            ensure!(written.into_inner() == 6, "progress reaches the last frame");
            ensure!(
                std::fs::metadata(&file)?.len() == cache_bytes(&animation, 6),
                "the size the estimate says"
            );
            let back = SimCache::open(&file, &animation)?;
            ensure!(back.frames() == 6);
            // The cache equals stepping the simulation in memory, bit for bit.
            let mut live = animation.start();
            for f in 0..6 {
                while live.frame() < f {
                    live.advance();
                }
                ensure!(back.positions(f)? == Some(live.positions()), "frame {f} differs from the live run");
            }
            let bytes = std::fs::read(&file)?;
            let damaged = dir.path().join("damaged.sim");
            let name = damaged.display().to_string();
            for (what, data, expected) in [
                ("truncated", bytes[..bytes.len() - 5].to_vec(), "damaged"),
                ("not a cache", b"{\"frames\": 3}".to_vec(), "not a hairkit simulation cache"),
                ("empty", Vec::new(), "not a hairkit simulation cache"),
            ] {
                std::fs::write(&damaged, &data)?;
                let e = SimCache::open(&damaged, &animation).expect_err(what).to_string();
                ensure!(e.contains(&name) && e.contains(expected), "{what}: {e}");
            }
            // Another scene (stiffer hair) must not read this one's cache.
            let other = dynamics_scene(dir.path(), serde_json::json!({ "dynamics": true }), |v| {
                v["characters"][0]["dynamics"]["bend_compliance"] = 1e-6.into();
            })?;
            let mut other_instance = SceneInstance::load(&load_scene(&other)?)?;
            let other_animation = Animation::new(&mut other_instance)?;
            let e = SimCache::open(&file, &other_animation).expect_err("other scene").to_string();
            ensure!(e.contains("simulate again"), "{e}");
            let missing = SimCache::open(&dir.path().join("none.sim"), &animation).expect_err("missing");
            ensure!(missing.to_string().contains("none.sim"), "{missing}");
            ensure!(back.positions(6)?.is_none(), "frames past the end are absent");
            let frame = back.positions(5)?.context("frame 5")?;
            ensure!(frame.len() == 1 && frame[0].iter().all(|p| p.is_finite()));
            Ok(())
        }),
        // A long animation used to be simulated whole into memory before its cache was written
        // (growing until the process aborted): now each frame is written as it is made.
        GpuTest::new("a_long_simulation_streams_its_cache_in_constant_memory", Requirements::NONE, |_| {
            let dir = tempfile::tempdir()?;
            let path = dynamics_scene(dir.path(), serde_json::json!({ "dynamics": true }), |v| {
                v["animation"]["frames"] = 1500.into();
            })?;
            let mut instance = SceneInstance::load(&load_scene(&path)?)?;
            let animation = Animation::new(&mut instance)?;
            let bytes = cache_bytes(&animation, animation.frames());
            let peak_before = peak_memory_bytes()?;
            let file = dir.path().join("long.sim");
            write_sim_cache(&animation, animation.frames(), &file, &|_| {})?;
            let grown = peak_memory_bytes()?.saturating_sub(peak_before);
            ensure!(std::fs::metadata(&file)?.len() == bytes);
            ensure!(bytes > 20 << 20, "the cache ({bytes} bytes) is too small to tell");
            ensure!(grown < bytes / 4, "the peak memory grew by {grown} bytes for a {bytes}-byte cache");
            Ok(())
        }),
    ])
}
