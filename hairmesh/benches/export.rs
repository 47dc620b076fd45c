//! Export benchmarks (recorded in `docs/benchmarks.md`): generating the strands, writing them
//! as USD text and as TressFX, and reading the TressFX file back, at 20k and 100k strands of
//! the procedural head cap's long hair; the file sizes are printed once.
//!
//! `cargo bench -p hairmesh --bench export`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
use hairmesh::export::{ExportOptions, export_strands, write_tfx, write_usda};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::style::Style;

fn asset() -> HairAsset {
    let scalp = hairmesh::procedural::head_cap(8, 32);
    let hm = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 6, length: 0.3, droop: 1.4, ..ExtrudeParams::default() },
    )
    .expect("extrude");
    let params = AssetParams { strands: StrandCount::Total(100_000), ..AssetParams::default() };
    HairAsset::build(&hm, &params, Style::default()).expect("asset")
}

fn export(c: &mut Criterion) {
    let asset = asset();
    let mut group = c.benchmark_group("export");
    group.sample_size(10);
    let dir = tempfile::tempdir().expect("temp dir");
    for strands in [20_000u64, 100_000] {
        let options = ExportOptions { strands: Some(strands), ..ExportOptions::default() };
        group.bench_with_input(BenchmarkId::new("generate strands", strands), &options, |b, o| {
            b.iter(|| export_strands(black_box(&asset), o));
        });
        let exported = export_strands(&asset, &options);
        let mut usda = Vec::new();
        write_usda(&mut usda, &exported, &options).expect("usda");
        let mut tfx = Vec::new();
        write_tfx(&mut tfx, &exported).expect("tfx");
        eprintln!(
            "export {strands}: {} curves, {} points; .usda {} bytes, .tfx {} bytes",
            exported.len(),
            hairmesh::export::exported_points(&exported),
            usda.len(),
            tfx.len()
        );
        group.bench_with_input(BenchmarkId::new("write .usda", strands), &exported, |b, e| {
            b.iter(|| write_usda(&mut std::io::sink(), black_box(e), &options).expect("usda"));
        });
        group.bench_with_input(BenchmarkId::new("write .tfx", strands), &exported, |b, e| {
            b.iter(|| write_tfx(&mut std::io::sink(), black_box(e)).expect("tfx"));
        });
        let path = dir.path().join(format!("hair-{strands}.tfx"));
        std::fs::write(&path, &tfx).expect("write");
        group.bench_with_input(BenchmarkId::new("read .tfx back", strands), &path, |b, p| {
            b.iter(|| hairmesh::strands::load_strands(black_box(p)).expect("read"));
        });
    }
    group.finish();
}

criterion_group!(benches, export);
criterion_main!(benches);
