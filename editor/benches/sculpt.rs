//! What a drag costs on the CPU before the preview (`cargo bench -p editor --bench sculpt`):
//! the sample head (LeePerrySmith, its scalp selection, hair laid over the head as the demo
//! does), a tip dragged with a soft selection of about 200 columns:
//!
//! * **start**: the drag's set-up when the button goes down (the soft selection, the
//!   inner-vertex system of the whole hair mesh);
//! * **solve**: one pointer move — every moved column by the column rule, the inner vertices
//!   placed by the surface (warm-started from the last move);
//! * **re-bake**: the asset's touched texels and bundle bounds re-made from the moved vertices.
//!
//! Then the same for a G/R/S of a 200-tip selection (a scale about its median, the transform
//! changing with every pointer move) and for a comb stroke (a 120-pixel brush in a 1280×720
//! view dragged across the back of the head, a dab per 8-pixel move: the tips under it, their
//! displacements, the moves, each dab from the mesh the last one left).
//!
//! Medians over the moves of one stroke; recorded in `docs/benchmarks.md`.

use std::time::Instant;

use anyhow::{Context, Result};
use editor::sculpt::TipDrag;
use hairmesh::convert::{convert_scalp, sample_head};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

fn main() -> Result<()> {
    let head = sample_head::locate()?;
    let settings = sample_head::long_hair(20_000);
    let mut asset = convert_scalp(&head, &settings, &mut |_| {})?.asset;
    let mesh = asset.mesh().clone();
    let tip = mesh.layers.len() - 1;
    // The tip furthest back (−z), and the radius whose soft selection holds ~200 columns.
    let (vertex, centre) = mesh.layers[tip]
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.z.total_cmp(&b.1.z))
        .map(|(v, p)| (v as u32, *p))
        .context("no vertices")?;
    let mut distances: Vec<f64> = mesh.layers[tip].iter().map(|p| p.distance(centre)).collect();
    distances.sort_by(f64::total_cmp);
    let radius = distances[200.min(distances.len() - 1)];

    let start = Instant::now();
    let mut drag = TipDrag::new(&mesh, vertex, None, radius);
    let start_ms = ms(start);
    let columns = drag.columns().count();
    let (mut solve, mut rebake) = (Vec::new(), Vec::new());
    for step in 1..=30 {
        let delta = glam::DVec3::new(0.0, 0.02, 0.03) * f64::from(step);
        let t = Instant::now();
        let moves = drag.moves(delta);
        solve.push(ms(t));
        let t = Instant::now();
        asset.move_vertices(&moves)?;
        rebake.push(ms(t));
    }
    println!(
        "sample head: {} hair-mesh vertices ({} per layer × {} layers), {} of them inner",
        mesh.vertex_count() * mesh.layers.len(),
        mesh.vertex_count(),
        mesh.layers.len(),
        hairmesh::inner::InnerVertices::new(&mesh).inner_count()
    );
    println!("| edit | start | solve per move | re-bake per move |");
    println!("|---|---:|---:|---:|");
    println!(
        "| drag, soft selection of {columns} columns | {start_ms:.1} ms | {:.2} ms | {:.2} ms |",
        median(solve),
        median(rebake)
    );

    // G/R/S: the 200 tips nearest the back scaled about their median.
    let mut asset = convert_scalp(&head, &settings, &mut |_| {})?.asset;
    let mut order: Vec<u32> = (0..mesh.vertex_count() as u32).collect();
    order.sort_by(|&a, &b| {
        mesh.layers[tip][a as usize]
            .distance(centre)
            .total_cmp(&mesh.layers[tip][b as usize].distance(centre))
    });
    let selection: Vec<u32> = order.into_iter().take(200).collect();
    let pivot = editor::transform::median_point(selection.iter().map(|&v| mesh.layers[tip][v as usize]))
        .context("a pivot")?;
    let start = Instant::now();
    let mut edit = TipDrag::selection(&mesh, &selection, |_| None, 0.0);
    let start_ms = ms(start);
    let (mut solve, mut rebake) = (Vec::new(), Vec::new());
    for step in 1..=30 {
        let s = 1.0 - 0.02 * f64::from(step);
        let transform = glam::DAffine3::from_translation(pivot)
            * glam::DAffine3::from_scale(glam::DVec3::splat(s))
            * glam::DAffine3::from_translation(-pivot);
        let t = Instant::now();
        let moves = edit.moves_with(&transform);
        solve.push(ms(t));
        let t = Instant::now();
        asset.move_vertices(&moves)?;
        rebake.push(ms(t));
    }
    println!(
        "| S of a {}-tip selection | {start_ms:.1} ms | {:.2} ms | {:.2} ms |",
        selection.len(),
        median(solve),
        median(rebake)
    );

    // A comb stroke across the back of the head, seen from behind.
    let mut asset = convert_scalp(&head, &settings, &mut |_| {})?.asset;
    let (lo, hi) = asset.bounds();
    let mut camera =
        editor::camera::OrbitCamera { yaw: std::f32::consts::PI, pitch: 0.1, ..Default::default() };
    camera.frame(lo.as_vec3(), hi.as_vec3());
    let size = glam::Vec2::new(1280.0, 720.0);
    let projection = editor::camera::Projection::new(&camera, size);
    let (mut dabs, mut rebake, mut touched) = (Vec::new(), Vec::new(), Vec::new());
    for step in 0..30 {
        let centre = glam::Vec2::new(500.0 + 8.0 * step as f32, 330.0);
        let t = Instant::now();
        let current = asset.mesh().clone();
        let tips: Vec<glam::Vec3> = current.layers[tip].iter().map(|p| p.as_vec3()).collect();
        let weighted = editor::brush::under_brush(&projection, &tips, centre, 60.0);
        let at =
            editor::transform::median_point(weighted.iter().map(|(v, _)| current.layers[tip][*v as usize]))
                .context("tips under the brush")?;
        let world = camera.drag_point(at.as_vec3(), glam::Vec2::new(8.0, 0.0), size.y).as_dvec3() - at;
        let d =
            editor::brush::dab(editor::brush::BrushKind::Comb, &current, &weighted, world, 1.0, false, 4.5);
        let held: Vec<(u32, f64)> = d.iter().map(|(v, _)| (*v, 1.0)).collect();
        let moves = TipDrag::weighted(&current, &held).moves_by(&d);
        dabs.push(ms(t));
        touched.push(d.len() as f64);
        let t = Instant::now();
        asset.move_vertices(&moves)?;
        rebake.push(ms(t));
    }
    println!(
        "| comb stroke, {:.0} tips under the brush | — | {:.2} ms per dab | {:.2} ms |",
        median(touched),
        median(dabs),
        median(rebake)
    );
    Ok(())
}
