//! Asset folders: round trips and hostile files.

use std::path::Path;

use glam::DVec3;
use hairmesh::asset::{AssetParams, HairAsset, StrandCount, VertexMove};
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
    let mut asset = HairAsset::build(&hm, &params(), style).expect("asset");
    asset.provenance = Some(hairmesh::asset::ScalpProvenance {
        file: "patch".into(),
        selector: "all".into(),
        layers: hairmesh::asset::LayerSource::Extruded(ExtrudeParams {
            layers: 3,
            length: 2.0,
            droop: 0.3,
            gravity: DVec3::NEG_Y,
        }),
    });
    asset
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
    assert_eq!(a.mesh(), b.mesh(), "hair mesh");
    assert_eq!(a.provenance, b.provenance, "provenance");
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
    corrupt(
        "mesh layers",
        |d| edit_json(d, |v| v["mesh"]["layers"].as_array_mut().expect("layers").truncate(2)),
        &["hair.json", "mesh.layers", "layout.layers = 3"],
    );
    corrupt(
        "mesh vertex not finite",
        |d| edit_json(d, |v| v["mesh"]["layers"][1][4] = serde_json::json!([1.0, "NaN", 0.0])),
        &["hair.json", "line 1", "expected f64"],
    );
    corrupt(
        "face vertex out of range",
        |d| edit_json(d, |v| v["mesh"]["faces"][1] = serde_json::json!({ "quad": [0, 1, 2, 100000] })),
        &["hair.json", "mesh.faces[1]", "vertex 100000"],
    );
    corrupt(
        "mesh moved by hand",
        |d| edit_json(d, |v| v["mesh"]["layers"][2][3][0] = serde_json::json!(40.0)),
        &["hair_mesh.exr", "mesh.layers[2][3]", "disagree"],
    );
    corrupt("missing uvs", |d| edit_json(d, |v| v["mesh"]["uvs"] = serde_json::Value::Null), &["mesh.uvs"]);
    // The fuzz tests found an EXR header that made the decoder allocate 791 TB (the process
    // aborted). Headers are now checked against the manifest before anything is decoded; here a
    // data window that disagrees with it is refused from the header alone.
    corrupt(
        "data window",
        |d| {
            let p = d.join("u.exr");
            let mut bytes = std::fs::read(&p).expect("read");
            let at = bytes.windows(10).position(|w| w == b"dataWindow").expect("dataWindow attribute");
            // name\0 "box2i"\0 size (4 bytes), then xMin, yMin, xMax, yMax as i32.
            let x_max = at + b"dataWindow\0box2i\0".len() + 4 + 8;
            bytes[x_max..x_max + 4].copy_from_slice(&4095i32.to_le_bytes());
            std::fs::write(&p, bytes).expect("write");
        },
        &["u.exr", "textures.u", "the manifest says"],
    );
}

/// A version-2 folder (no hair mesh in its manifest) is refused with what to do, and reading
/// it changes nothing on disk.
#[test]
fn an_older_asset_says_re_convert_and_stays_untouched() {
    let dir = tempfile::tempdir().expect("temp dir");
    write_asset(dir.path(), &asset(), Precision::F32, "m", Some("scalp.glb")).expect("write");
    edit_json(dir.path(), |v| {
        v["format_version"] = 2.into();
        let object = v.as_object_mut().expect("object");
        object.remove("mesh");
        object.remove("scalp");
    });
    let before: Vec<(String, Vec<u8>)> = {
        let mut files: Vec<_> = std::fs::read_dir(dir.path())
            .expect("list")
            .map(|e| {
                let e = e.expect("entry");
                (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).expect("read"))
            })
            .collect();
        files.sort();
        files
    };
    let e = read_asset(dir.path()).expect_err("version 2").to_string();
    for part in ["hair.json", "format_version", "2 is an older format", "re-convert", "scalp.glb"] {
        assert!(e.contains(part), "`{e}` should mention `{part}`");
    }
    let mut after: Vec<_> = std::fs::read_dir(dir.path())
        .expect("list")
        .map(|e| {
            let e = e.expect("entry");
            (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).expect("read"))
        })
        .collect();
    after.sort();
    assert_eq!(before, after, "reading an old asset must not change its folder");
}

/// The hair mesh of a built asset, with one vertex of layer `layer` moved by `by`.
fn moved_mesh(a: &HairAsset, layer: usize, vertex: usize, by: DVec3) -> HairMesh {
    let mut mesh = a.mesh().clone();
    mesh.layers[layer][vertex] += by;
    mesh
}

fn params() -> AssetParams {
    AssetParams { strands: StrandCount::Total(200), sample_sets: 2, seed: 9, ..Default::default() }
}

/// Convert → save → load → move a vertex → re-bake gives the textures of a fresh conversion of
/// the moved mesh (to the files' f32 precision, which the texels not rewritten keep).
#[test]
fn an_edited_asset_rebakes_to_a_fresh_conversion_of_its_moved_mesh() {
    let dir = tempfile::tempdir().expect("temp dir");
    let original = asset();
    write_asset(dir.path(), &original, Precision::F32, "m", None).expect("write");
    let (mut loaded, _) = read_asset(dir.path()).expect("read");
    // An interior vertex of layer 2 (inside the bounds: the normalization stays the same).
    let (layer, vertex, by) = (2, 5, DVec3::new(0.01, -0.02, 0.015));
    let target = loaded.mesh().layers[layer][vertex] + by;
    let change = loaded
        .move_vertices(&[VertexMove { layer: layer as u32, vertex: vertex as u32, position: target }])
        .expect("move");
    assert_eq!(loaded.revision(), 1);
    assert_eq!(change.revision, 1);
    let fresh = HairAsset::build(&moved_mesh(&original, layer, vertex, by), &params(), original.style)
        .expect("fresh conversion");
    assert_eq!(loaded.textures.normalization, fresh.textures.normalization);
    assert_eq!(loaded.textures.layout, fresh.textures.layout);
    let rewritten: std::collections::HashSet<u32> = change.texels.iter().copied().collect();
    let slice = loaded.textures.layout.slice_texels() as usize;
    for (name, a, b) in [
        ("hair_mesh", &loaded.textures.hair_mesh, &fresh.textures.hair_mesh),
        ("uv", &loaded.textures.uv, &fresh.textures.uv),
        ("w", &loaded.textures.w, &fresh.textures.w),
        ("u", &loaded.textures.u, &fresh.textures.u),
        ("v", &loaded.textures.v, &fresh.textures.v),
    ] {
        let n = a.channels as usize;
        for (i, (x, y)) in a.data.iter().zip(&b.data).enumerate() {
            let texel = (i / n) % slice;
            if rewritten.contains(&(texel as u32)) {
                // Re-baked in f64: exactly the fresh conversion.
                assert_eq!(x.to_bits(), y.to_bits(), "{name}: rewritten texel {texel} value {i}");
            } else {
                assert_eq!(*x, f64::from(*y as f32), "{name}: kept texel {texel} value {i}");
            }
        }
    }
    assert_eq!(loaded.bundles, fresh.bundles, "bundle bounds follow the move");
    assert!(change.texels.len() < slice / 2, "{} of {slice} texels rewritten", change.texels.len());
    // Saving the edit and loading it again keeps it.
    write_asset(dir.path(), &loaded, Precision::F32, "m", None).expect("write the edit");
    let (again, _) = read_asset(dir.path()).expect("read the edit");
    assert_eq!(again.mesh().layers[layer][vertex], target);
}

/// In memory (no f32 files), re-baking is bit for bit a fresh conversion when the move stays
/// inside the rest bounds, and equal in object space when it leaves them (the normalization is
/// the rest pose's, so stored values leave [0, 1]).
#[test]
fn rebaking_in_memory_matches_a_fresh_conversion_exactly() {
    let original = asset();
    // Inside the bounds: identical assets but for the revision.
    let by = DVec3::new(-0.02, 0.01, 0.03);
    let mut edited = original.clone();
    edited
        .move_vertices(&[VertexMove { layer: 1, vertex: 7, position: original.mesh().layers[1][7] + by }])
        .expect("move");
    let mut fresh =
        HairAsset::build(&moved_mesh(&original, 1, 7, by), &params(), original.style).expect("fresh");
    fresh.provenance = original.provenance.clone();
    assert_same(&edited, &fresh);

    // Past the bounds: a tip pulled far out.
    let tips = original.mesh().layers.len() - 1;
    let far = DVec3::new(0.0, 0.0, 5.0);
    let mut edited = original.clone();
    let change = edited
        .move_vertices(&[VertexMove {
            layer: tips as u32,
            vertex: 0,
            position: original.mesh().layers[tips][0] + far,
        }])
        .expect("move");
    let fresh =
        HairAsset::build(&moved_mesh(&original, tips, 0, far), &params(), original.style).expect("fresh");
    assert_eq!(edited.textures.normalization, original.textures.normalization, "rest normalization kept");
    assert_ne!(fresh.textures.normalization, original.textures.normalization);
    let (e, f) = (&edited.textures, &fresh.textures);
    let mut outside = false;
    for (a, b) in e.hair_mesh.data.chunks_exact(3).zip(f.hair_mesh.data.chunks_exact(3)) {
        let a = DVec3::from_slice(a);
        outside |= a.max_element() > 1.0;
        let (pa, pb) = (e.normalization.to_object(a), f.normalization.to_object(DVec3::from_slice(b)));
        assert!(pa.distance(pb) < 1e-12, "{pa} vs {pb}");
    }
    assert!(outside, "the pulled tip is stored outside [0, 1]");
    for (x, y) in [(&e.w, &f.w), (&e.u, &f.u), (&e.v, &f.v), (&e.uv, &f.uv)] {
        assert_eq!(x, y);
    }
    assert_eq!(edited.bundles, fresh.bundles);
    assert!(change.bundles.iter().all(|&b| edited.mesh().faces[b as usize].vertices().contains(&0)));
}

#[test]
fn bad_moves_are_refused_and_change_nothing() {
    let original = asset();
    let p = original.mesh().layers[1][0];
    for (moves, expected) in [
        (vec![VertexMove { layer: 9, vertex: 0, position: p }], "layer 9 vertex 0 does not exist"),
        (vec![VertexMove { layer: 1, vertex: 100_000, position: p }], "vertex 100000"),
        (
            vec![
                VertexMove { layer: 1, vertex: 0, position: p + DVec3::X },
                VertexMove { layer: 1, vertex: 1, position: DVec3::new(f64::NAN, 0.0, 0.0) },
            ],
            "moves[1]",
        ),
    ] {
        let mut edited = original.clone();
        let e = edited.move_vertices(&moves).expect_err(expected).to_string();
        assert!(e.contains(expected), "`{e}` should mention `{expected}`");
        assert_eq!(edited, original, "a refused edit changes nothing");
        assert_eq!(edited.revision(), 0);
    }
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

#[test]
fn a_new_style_regrows_the_bundle_bounds() {
    let mut a = asset();
    let before = a.bundles.clone();
    let wider = Style { curl: Curl { radius: 0.5, frequency: 2.0, phase: 0.1 }, ..a.style };
    let change = a.set_style(wider);
    assert_eq!(change.bundles.len(), a.bundles.len());
    assert!(change.texels.is_empty());
    assert_eq!((change.since, change.revision), (0, 1));
    for (old, new) in before.iter().zip(&a.bundles) {
        assert!(new.bounds_min.cmplt(old.bounds_min).all() && new.bounds_max.cmpgt(old.bounds_max).all());
        assert_eq!(old.strands, new.strands);
    }
    let fresh = HairAsset::build(a.mesh(), &params(), wider).expect("fresh");
    assert_eq!(a.bundles, fresh.bundles, "as if built with the style");
}

/// The head's distance field (strand-level collision) goes with the asset: read back equal,
/// and a manifest that points elsewhere or sizes it wrongly is refused by field.
#[test]
fn the_head_field_round_trips_and_bad_ones_are_refused() {
    let scalp = common::patch(3, DVec3::new(0.5, 1.0, 0.0), 1.0, &mut SplitMix64::new(11));
    let head = hairmesh::head::HeadSurface::from_mesh(&scalp);
    let mut a = asset();
    let (lo, hi) = a.bounds();
    a.head_field = hairmesh::head_field::HeadField::build(&head, (lo, hi), 0.01).map(std::sync::Arc::new);
    assert!(a.head_field.is_some(), "the patch gives a field");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("with_field");
    write_asset(&path, &a, Precision::F32, "units", None).expect("write");
    let (b, _) = read_asset(&path).expect("read");
    assert_eq!(b.head_field, a.head_field, "the field read back");
    let text = std::fs::read_to_string(path.join(MANIFEST)).expect("manifest");
    let json: serde_json::Value = serde_json::from_str(&text).expect("json");
    for (key, value, expected) in [
        ("file", serde_json::json!("../escape.exr"), "head_field.file"),
        ("size", serde_json::json!([2, 2, 5000]), "head_field.size"),
        ("cell", serde_json::json!(-1.0), "head_field"),
    ] {
        let mut broken = json.clone();
        broken["head_field"][key] = value;
        std::fs::write(path.join(MANIFEST), serde_json::to_vec(&broken).expect("json")).expect("write");
        let err = read_asset(&path).expect_err("a bad head field").to_string();
        assert!(err.contains(expected) && err.contains(MANIFEST), "{key}: {err}");
    }
}
