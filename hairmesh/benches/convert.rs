//! Conversion and blue-noise benchmarks (recorded in `docs/benchmarks.md`).
//!
//! `cargo bench -p hairmesh --bench convert`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use hairmesh::ScalpSelector;
use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::import::load_scalp;
use hairmesh::roots::{EliminationParams, SampleDomain, progressive_samples};
use hairmesh::style::Style;

fn lee_perry_smith() -> std::path::PathBuf {
    data_set::require(data_set::SAMPLE_HEAD)
}

fn convert(c: &mut Criterion) {
    let path = lee_perry_smith();
    let selector = ScalpSelector::parse("above:0,1,0,1.5").expect("selector");
    let mut group = c.benchmark_group("convert LeePerrySmith");
    group.sample_size(10);
    group.bench_function("import + weld + select", |b| {
        b.iter(|| load_scalp(black_box(&path), &selector).expect("load"));
    });
    let scalp = load_scalp(&path, &selector).expect("load");
    let hm = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 4, length: 3.0, droop: 0.3, ..ExtrudeParams::default() },
    )
    .expect("extrude");
    group.bench_function("hair mesh (4 layers)", |b| {
        b.iter(|| {
            HairMesh::extrude(
                black_box(&scalp),
                &ExtrudeParams { layers: 4, length: 3.0, droop: 0.3, ..ExtrudeParams::default() },
            )
        });
    });
    group.bench_function("textures + root sets (20k strands)", |b| {
        b.iter(|| {
            HairAsset::build(
                black_box(&hm),
                &AssetParams {
                    strands: StrandCount::Total(20_000),
                    sample_sets: 1,
                    seed: 1,
                    ..Default::default()
                },
                Style::default(),
            )
        });
    });
    group.finish();
}

fn sample_elimination(c: &mut Criterion) {
    let mut group = c.benchmark_group("progressive sample elimination");
    group.sample_size(10);
    let relaxed = EliminationParams::default();
    // The relaxation's share of the time: the same sets without it (the quality of both is in
    // docs/benchmarks.md, from the blue_noise example).
    let eliminated = EliminationParams { relax_rounds: 0, ..relaxed };
    for n in [4096usize, 65536] {
        for (name, params) in [("", relaxed), (", elimination only", eliminated)] {
            group.bench_function(format!("{n} samples, square{name}"), |b| {
                b.iter(|| progressive_samples(black_box(n), SampleDomain::Square, 1, &params));
            });
        }
    }
    group.finish();
}

criterion_group!(benches, convert, sample_elimination);
criterion_main!(benches);
