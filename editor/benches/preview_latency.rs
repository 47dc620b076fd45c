//! Preview latency of the editor's worker, as the UI sees it (`cargo bench -p editor`): a
//! 20k-strand asset at 640×360 on whatever device is here (lavapipe on the CI machine).
//!
//! * **first feedback**: a style change → the draft frame (half resolution, strand LOD ×8);
//! * **refined**: the same change → the full frame;
//! * **drag**: frames per second while a hair-mesh vertex is dragged (one draft request per
//!   frame, each waiting for the previous frame, as the UI's latest-request-wins does).
//!
//! Numbers are medians over several changes, after a warm-up frame (pipeline creation).

use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use editor::camera::OrbitCamera;
use editor::document::{Document, Gesture};
use editor::preview::{PreviewEvent, PreviewRequest, PreviewScene, PreviewWorker};
use hairmesh::asset::VertexMove;
use hairmesh::convert::ConvertSettings;

fn frame(
    worker: &mut PreviewWorker,
    doc: &Document,
    scene: &PreviewScene,
    camera: OrbitCamera,
    draft: bool,
) -> Result<f64> {
    let start = Instant::now();
    let id = worker.request(PreviewRequest::for_document(doc, scene.clone(), camera, [640, 360], draft));
    loop {
        match worker.wait(Duration::from_secs(300)).context("no preview frame within 300 s")? {
            PreviewEvent::Frame(f) if f.id == id => return Ok(start.elapsed().as_secs_f64() * 1e3),
            PreviewEvent::Failed { message, .. } | PreviewEvent::Unavailable { message } => {
                bail!("{message}")
            }
            _ => {}
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<()> {
    println!(
        "editor preview, 20k strands (head cap), 640×360 (targets: first feedback ≤ 100 ms, refined ≤ 500 ms):"
    );
    println!("| scene | first frame (pipelines) | style change → draft | → refined | vertex drag |");
    println!("|---|---|---|---|---|");
    let shadowed = PreviewScene::default();
    let plain = PreviewScene {
        effects: render::scene::Effects { shadows: false, ..shadowed.effects },
        ..shadowed.clone()
    };
    for (name, scene) in [("default (self-shadowing)", shadowed), ("without shadows", plain)] {
        measure(name, &scene)?;
    }
    Ok(())
}

fn measure(name: &str, scene: &PreviewScene) -> Result<()> {
    let scalp = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/head_cap.gltf");
    let settings = ConvertSettings { strands: 20_000, ..ConvertSettings::default() };
    let mut doc = Document::convert_scalp(&scalp, &settings, None, &mut |_| {})?;
    let mut worker = PreviewWorker::start(|| {});
    let mut camera = OrbitCamera::default();
    let (lo, hi) = doc.asset().bounds();
    camera.frame(lo.as_vec3(), hi.as_vec3());
    let warm = frame(&mut worker, &doc, scene, camera, false)?;
    frame(&mut worker, &doc, scene, camera, true)?;
    let (mut first, mut refined) = (Vec::new(), Vec::new());
    for k in 1..=5 {
        let mut style = doc.style();
        style.curl.radius = 0.002 * k as f64;
        doc.set_style(style, None);
        let draft = frame(&mut worker, &doc, scene, camera, true)?;
        first.push(draft);
        refined.push(draft + frame(&mut worker, &doc, scene, camera, false)?);
    }
    let mesh = doc.asset().mesh().clone();
    let outer = mesh.layers.len() - 1;
    let column = mesh.column(0);
    let drag_start = Instant::now();
    let drags = 10;
    for k in 1..=drags {
        let d = glam::DVec3::new(0.01 * k as f64, 0.0, 0.0);
        let moves: Vec<VertexMove> = (1..=outer)
            .map(|l| VertexMove {
                layer: l as u32,
                vertex: 0,
                position: column[l] + d * (l as f64 / outer as f64),
            })
            .collect();
        doc.move_vertices(&moves, Some(Gesture::Drag))?;
        frame(&mut worker, &doc, scene, camera, true)?;
    }
    let fps = drags as f64 / drag_start.elapsed().as_secs_f64();
    println!(
        "| {name} | {warm:.0} ms | {:.0} ms | {:.0} ms | {fps:.1} frames/s |",
        median(first),
        median(refined)
    );
    Ok(())
}
