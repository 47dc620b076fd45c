//! Asset folders: round trips and hostile files.

use std::path::Path;

use glam::DVec3;
use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
use hairmesh::asset_io::{MANIFEST, Precision, read_asset, write_asset};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::rng::SplitMix64;
use hairmesh::style::{Curl, Style};

mod common;

fn asset() -> HairAsset {
    let scalp = common::patch(3, DVec3::new(0.5, 1.0, 0.0), 1.0, &mut SplitMix64::new(11));
    let hm = HairMesh::extrude(
        &scalp,
        &ExtrudeParams { layers: 3, length: 2.0, droop: 0.3, gravity: DVec3::NEG_Y },
    )
    .expect("extrude");
    let style = Style { curl: Curl { radius: 0.05, frequency: 2.0, phase: 0.1 }, ..Style::default() };
    HairAsset::build(
        &hm,
        &AssetParams { strands: StrandCount::Total(200), sample_sets: 2, seed: 9, ..Default::default() },
        style,
    )
    .expect("asset")
}

/// Equality with a short message naming the first differing part (the assets are large).
fn assert_same(a: &HairAsset, b: &HairAsset) {
    let t = |x: &HairAsset| {
        [
            x.textures.hair_mesh.clone(),
            x.textures.uv.clone(),
            x.textures.w.clone(),
            x.textures.u.clone(),
            x.textures.v.clone(),
        ]
    };
    for (i, (ta, tb)) in t(a).iter().zip(t(b).iter()).enumerate() {
        assert_eq!(
            (ta.width, ta.height, ta.depth, ta.channels),
            (tb.width, tb.height, tb.depth, tb.channels),
            "texture {i} size"
        );
        if let Some(k) = ta.data.iter().zip(&tb.data).position(|(x, y)| x.to_bits() != y.to_bits()) {
            panic!("texture {i} differs at value {k}: {} vs {}", ta.data[k], tb.data[k]);
        }
    }
    assert_eq!(a.textures.layout, b.textures.layout);
    assert_eq!(a.textures.normalization, b.textures.normalization);
    assert_eq!(a.bundles, b.bundles, "bundles");
    assert_eq!(a.square_sets, b.square_sets, "square sets");
    assert_eq!(a.triangle_sets, b.triangle_sets, "triangle sets");
    assert_eq!(a.style, b.style);
}

fn as_f32(mut a: HairAsset) -> HairAsset {
    for t in [
        &mut a.textures.hair_mesh,
        &mut a.textures.uv,
        &mut a.textures.w,
        &mut a.textures.u,
        &mut a.textures.v,
    ] {
        for v in &mut t.data {
            *v = f64::from(*v as f32);
        }
    }
    a
}

#[test]
fn round_trip_is_identical() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("asset");
    let original = asset();
    write_asset(&path, &original, Precision::F32, "metres", Some("patch")).expect("write");
    let (read, manifest) = read_asset(&path).expect("read");
    // Textures are stored as f32, everything else exactly.
    assert_same(&read, &as_f32(original));
    assert_eq!(manifest.units, "metres");
    // Writing what was read gives the same bytes back.
    write_asset(&path, &read, Precision::F32, "metres", Some("patch")).expect("rewrite");
    let (again, _) = read_asset(&path.join(MANIFEST)).expect("read by manifest path");
    assert_same(&again, &read);
    assert!(path.join("preview.png").is_file());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).expect("list").collect();
    assert_eq!(leftovers.len(), 1, "no temporary folders left behind");
}

#[test]
fn f16_round_trip_keeps_half_precision() {
    let dir = tempfile::tempdir().expect("temp dir");
    let original = asset();
    write_asset(dir.path(), &original, Precision::F16, "m", None).expect("write");
    let (read, manifest) = read_asset(dir.path()).expect("read");
    assert_eq!(manifest.precision, Precision::F16);
    for (a, b) in original.textures.hair_mesh.data.iter().zip(&read.textures.hair_mesh.data) {
        // Stored positions are normalized to [0, 1]: f16 keeps 11 bits there.
        assert!((a - b).abs() <= 1.0 / 2048.0, "{a} vs {b}");
    }
}

fn corrupt(name: &str, edit: impl FnOnce(&Path), expected: &[&str]) {
    let dir = tempfile::tempdir().expect("temp dir");
    write_asset(dir.path(), &asset(), Precision::F32, "m", None).expect("write");
    edit(dir.path());
    let e = read_asset(dir.path()).expect_err(name).to_string();
    for part in expected {
        assert!(e.contains(part), "{name}: `{e}` should mention `{part}`");
    }
}

fn edit_json(dir: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let path = dir.join(MANIFEST);
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).expect("read")).expect("json");
    f(&mut v);
    std::fs::write(path, serde_json::to_vec(&v).expect("json")).expect("write");
}

#[test]
fn hostile_asset_folders_give_clear_errors() {
    corrupt(
        "unknown field",
        |d| edit_json(d, |v| v["colour"] = 3.into()),
        &["hair.json", "unknown field `colour`"],
    );
    corrupt(
        "version",
        |d| edit_json(d, |v| v["format_version"] = 99.into()),
        &["hair.json", "format_version", "99"],
    );
    corrupt(
        "layout",
        |d| edit_json(d, |v| v["layout"]["width"] = 1_000_000.into()),
        &["hair.json", "layout"],
    );
    corrupt(
        "version 1",
        |d| edit_json(d, |v| v["format_version"] = 1.into()),
        &["hair.json", "format_version", "re-convert"],
    );
    corrupt(
        "cell outside the slice",
        |d| edit_json(d, |v| v["layout"]["cells"][3] = serde_json::json!([4000, 0, 0])),
        &["hair.json", "layout.cells[3]", "does not fit"],
    );
    corrupt(
        "cell orientation",
        |d| edit_json(d, |v| v["layout"]["cells"][0] = serde_json::json!([0, 0, 8])),
        &["hair.json", "cell orientation 8"],
    );
    corrupt(
        "missing cells",
        |d| edit_json(d, |v| v["layout"]["cells"] = serde_json::json!([[0, 0, 0]])),
        &["hair.json", "layout.cells", "1 cells"],
    );
    corrupt(
        "bundle count",
        |d| edit_json(d, |v| v["layout"]["bundles"] = 5.into()),
        &["hair.json", "layout"],
    );
    corrupt(
        "strands",
        |d| edit_json(d, |v| v["bundles"][2]["strands"] = 0.into()),
        &["bundles[2]", "strands = 0"],
    );
    corrupt("nan", |d| edit_json(d, |v| v["normalization"]["scale"] = (-1.0).into()), &["normalization"]);
    corrupt(
        "not json",
        |d| std::fs::write(d.join(MANIFEST), b"{\"format\": ").expect("write"),
        &["hair.json", "line 1"],
    );
    corrupt("missing texture", |d| std::fs::remove_file(d.join("u.exr")).expect("rm"), &["u.exr"]);
    corrupt(
        "truncated texture",
        |d| {
            let p = d.join("hair_mesh.exr");
            let bytes = std::fs::read(&p).expect("read");
            std::fs::write(&p, &bytes[..bytes.len() / 2]).expect("write");
        },
        &["hair_mesh.exr", "textures.hair_mesh"],
    );
    corrupt(
        "swapped textures",
        |d| {
            std::fs::copy(d.join("uv.exr"), d.join("w.exr")).expect("copy");
        },
        &["w.exr", "textures.w"],
    );
    corrupt(
        "samples outside",
        |d| edit_json(d, |v| v["square_sets"][0]["points"][0] = serde_json::json!([2.0, 0.5])),
        &["square_sets[0]"],
    );
}

#[test]
fn a_failed_write_keeps_the_old_asset() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("asset");
    write_asset(&path, &asset(), Precision::F32, "m", None).expect("write");
    // A destination below a regular file cannot be written; nothing changes.
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, b"x").expect("write");
    assert!(write_asset(&blocker.join("asset"), &asset(), Precision::F32, "m", None).is_err());
    assert!(read_asset(&path).is_ok());
}
