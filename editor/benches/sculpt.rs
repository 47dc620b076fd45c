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
    println!("| soft selection | drag start | solve per move | re-bake per move |");
    println!("|---|---:|---:|---:|");
    println!("| {columns} columns | {start_ms:.1} ms | {:.2} ms | {:.2} ms |", median(solve), median(rebake));
    Ok(())
}
