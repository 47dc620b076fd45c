//! Hair-mesh simulation cost per character per frame against the hair mesh's vertex count
//! (recorded in `docs/benchmarks.md`; the goal: ≤ 1 ms for 2,000 vertices on one core).
//!
//! `cargo bench -p hairmesh --bench dynamics`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use glam::Affine3A;
use hairmesh::dynamics::{Collider, DynamicsParams, HairSim, Wind};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::procedural::head_cap;

/// A head turning and nodding, as the scenes' procedural motion does.
fn head_motion(t: f64) -> Affine3A {
    let (turn, nod) = ((t * 2.0).sin() as f32 * 0.6, (t * 3.1).sin() as f32 * 0.25);
    Affine3A::from_translation(glam::Vec3::new(0.0, 1.5, 0.0))
        * Affine3A::from_rotation_y(turn)
        * Affine3A::from_rotation_x(nod)
        * Affine3A::from_translation(glam::Vec3::new(0.0, -1.5, 0.0))
}

fn simulate(c: &mut Criterion) {
    let mut group = c.benchmark_group("dynamics: one frame (30 fps, 4 substeps, wind, one collider)");
    for (rings, segments) in [(4, 10), (8, 20), (12, 30), (20, 52)] {
        let cap = head_cap(rings, segments);
        let mesh = HairMesh::extrude(
            &cap,
            &ExtrudeParams { layers: 6, length: 0.25, droop: 0.5, ..ExtrudeParams::default() },
        )
        .expect("extrude");
        let params = DynamicsParams {
            wind: Wind { velocity: [1.5, 0.0, 0.5], ..Wind::default() },
            colliders: vec![Collider::Sphere { centre: [0.0, 1.55, 0.0], radius: 0.08 }],
            ..DynamicsParams::default()
        };
        let mut sim = HairSim::new(&mesh, &params, &[], &head_motion).expect("sim");
        let vertices = sim.vertex_count();
        group.bench_function(BenchmarkId::from_parameter(format!("{vertices} vertices")), |b| {
            b.iter(|| sim.step(black_box(1.0 / 30.0), &head_motion));
        });
    }
    group.finish();
}

criterion_group!(benches, simulate);
criterion_main!(benches);
