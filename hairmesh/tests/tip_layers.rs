//! Bundles of different lengths: a face's strands end at its tip layer (the paper's "the tip
//! layer can be different for each face") in the reference generator, the bundle table and
//! the asset files.

use glam::{DVec2, DVec3};
use hairmesh::ScalpMesh;
use hairmesh::asset::{AssetParams, HairAsset, StrandCount};
use hairmesh::asset_io::{MANIFEST, Precision, read_asset, write_asset};
use hairmesh::hair_mesh::{ExtrudeParams, HairMesh};
use hairmesh::reference::{LodParams, Projection, ViewParams};
use hairmesh::style::Style;

/// A flat n×n grid of unit quads in the y = 0 plane, extruded straight along its normal into
/// `layers` layers of total length `length`: every column is the same straight line, so a
/// strand's point at layer k is its root moved by that line's k-th point.
fn straight_hair(n: u32, layers: u32, length: f64) -> HairMesh {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push(DVec3::new(f64::from(i), 0.0, -f64::from(j)));
            uvs.push(DVec2::new(f64::from(i), f64::from(j)) / f64::from(n));
        }
    }
    let id = |i: u32, j: u32| j * (n + 1) + i;
    let faces = (0..n)
        .flat_map(|j| (0..n).map(move |i| vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]))
        .collect();
    let scalp = ScalpMesh { positions, uvs: Some(uvs), faces, ..Default::default() };
    HairMesh::extrude(&scalp, &ExtrudeParams { layers, length, droop: 0.0, gravity: DVec3::NEG_Y })
        .expect("extrudes")
}

fn build(hm: &HairMesh, strands: u64) -> HairAsset {
    let params =
        AssetParams { strands: StrandCount::Total(strands), sample_sets: 2, seed: 3, ..Default::default() };
    HairAsset::build(hm, &params, Style::default()).expect("asset")
}

fn full_detail() -> (ViewParams, LodParams) {
    let view = ViewParams {
        eye: DVec3::new(0.0, 2.0, 5.0),
        vertical_resolution: 256.0,
        projection: Projection::Perspective { fov_y: 0.8 },
    };
    (view, LodParams { enabled: false, ..LodParams::default() })
}

#[test]
fn a_short_bundle_ends_at_its_tip_layer() {
    let (layers, length) = (4, 2.0);
    let mut hm = straight_hair(4, layers, length);
    // Faces 0..16 end at layers 1, 2, 3, 4, 1, 2, ...
    let tips: Vec<u32> = (0..hm.faces.len() as u32).map(|f| 1 + f % layers).collect();
    hm.tip_layers = Some(tips.clone());
    let asset = build(&hm, 400);
    let offset = |k: usize| hm.layers[k][0] - hm.layers[0][0];
    for k in 0..=layers as usize {
        assert!(
            (0..hm.vertex_count()).all(|v| (hm.layers[k][v] - hm.layers[0][v]).distance(offset(k)) < 1e-12),
            "the test mesh's columns are not one straight line"
        );
    }
    let (view, lod) = full_detail();
    let strands = asset.generate_reference(&view, &lod);
    assert!(strands.len() >= 300, "{} strands", strands.len());
    for s in &strands {
        let tip = tips[s.bundle as usize] as usize;
        let (root, end) = (s.positions[0], s.positions[s.positions.len() - 1]);
        let expected = root + offset(tip);
        assert!(
            end.distance(expected) < 1e-9 * length,
            "bundle {} (tip layer {tip}) strand {} ends at {end}, expected {expected}",
            s.bundle,
            s.index
        );
        // Every vertex on the way stays on the short column: none beyond the tip.
        let reach = f64::from(tip as u32) / f64::from(layers) * length;
        assert!(s.positions.iter().all(|p| (*p - root).length() <= reach * (1.0 + 1e-9)));
    }
    // The bundle table measures each bundle up to its tip: the length the vertex LOD uses and
    // the bounds culling uses.
    for (b, info) in asset.bundles.iter().enumerate() {
        let reach = f64::from(tips[b]) / f64::from(layers) * length;
        assert!((info.length - reach).abs() < 1e-9, "bundle {b}: length {} for reach {reach}", info.length);
        assert!(info.bounds_max.y <= reach + 1e-9, "bundle {b}: bounds {} above {reach}", info.bounds_max.y);
        assert_eq!(asset.reach(b as u32), f64::from(tips[b]) / f64::from(layers));
    }
}

#[test]
fn shortening_a_bundle_is_an_edit_of_its_table_entry() {
    let hm = straight_hair(3, 4, 1.0);
    let mut asset = build(&hm, 100);
    let before = asset.clone();
    let change = asset.set_tip_layer(&[4, 2, 4], 2).expect("edit");
    assert_eq!(change.bundles, vec![2, 4], "the bundles whose entry changed");
    assert!(change.texels.is_empty(), "the textures stay");
    assert_eq!(change.since + 1, change.revision);
    for b in 0..asset.bundles.len() as u32 {
        let expected = if b == 2 || b == 4 { 2 } else { 4 };
        assert_eq!(asset.tip_layer(b), expected, "bundle {b}");
    }
    assert!((asset.bundles[2].length - 0.5).abs() < 1e-12 && asset.bundles[3] == before.bundles[3]);
    // Out of range clamps to the mesh's layers; an unknown bundle is refused and nothing changes.
    asset.set_tip_layer(&[2], 0).expect("clamped");
    assert_eq!(asset.tip_layer(2), 1);
    let unchanged = asset.clone();
    let err = asset.set_tip_layer(&[1, 99], 3).expect_err("bundle 99");
    assert!(err.to_string().contains("bundle 99"), "{err}");
    assert_eq!(asset, unchanged);
    // Back to full length everywhere: the mesh drops its list (the older, shorter form).
    let all: Vec<u32> = (0..asset.bundles.len() as u32).collect();
    asset.set_tip_layer(&all, 4).expect("edit");
    assert_eq!(asset.mesh().tip_layers, None);
    assert_eq!(asset.bundles, before.bundles);
}

#[test]
fn tip_layers_round_trip_through_the_asset_files() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut hm = straight_hair(3, 3, 1.5);
    let uniform = build(&hm, 90);
    write_asset(&dir.path().join("uniform"), &uniform, Precision::F32, "units", None).expect("write");
    let manifest = std::fs::read_to_string(dir.path().join("uniform").join(MANIFEST)).expect("manifest");
    assert!(!manifest.contains("tip_layers"), "an asset of one length writes what older versions wrote");

    hm.tip_layers = Some(vec![1, 2, 3, 3, 2, 1, 1, 1, 3]);
    let mixed = build(&hm, 90);
    let path = dir.path().join("mixed");
    write_asset(&path, &mixed, Precision::F32, "units", None).expect("write");
    let (read, _) = read_asset(&path).expect("read");
    assert_eq!(read.mesh().tip_layers, hm.tip_layers);
    assert_eq!(read.bundles, mixed.bundles);
    let (view, lod) = full_detail();
    // (The files hold f32 textures: the read asset's strands agree to f32 rounding.)
    let (a, b) = (read.generate_reference(&view, &lod), mixed.generate_reference(&view, &lod));
    assert_eq!(a.len(), b.len());
    for (s, t) in a.iter().zip(&b) {
        let far = s.positions.iter().zip(&t.positions).map(|(p, q)| p.distance(*q)).fold(0.0, f64::max);
        assert!(far < 1e-6, "bundle {} strand {}: {far} apart", s.bundle, s.index);
    }

    // A tip layer the mesh does not have is refused, naming the file and the field.
    let text = std::fs::read_to_string(path.join(MANIFEST)).expect("manifest");
    let json: serde_json::Value = serde_json::from_str(&text).expect("json");
    for (tips, expected) in [
        (serde_json::json!([1, 2, 4, 3, 2, 1, 1, 1, 3]), "face 2 ends at layer 4 (expected 1..=3)"),
        (serde_json::json!([0, 2, 3, 3, 2, 1, 1, 1, 3]), "face 0 ends at layer 0"),
        (serde_json::json!([1, 2, 3, 3, 2, 1, 1, 1]), "8 tip layers for 9 faces"),
    ] {
        let mut broken = json.clone();
        broken["mesh"]["tip_layers"] = tips;
        std::fs::write(path.join(MANIFEST), serde_json::to_vec(&broken).expect("json")).expect("write");
        let err = read_asset(&path).expect_err("bad tip layers").to_string();
        assert!(err.contains("mesh.tip_layers") && err.contains(MANIFEST) && err.contains(expected), "{err}");
    }
}

#[test]
fn a_hair_mesh_with_bad_tip_layers_builds_no_asset() {
    let mut hm = straight_hair(2, 3, 1.0);
    for (tips, expected) in
        [(vec![1, 2, 3], "3 tip layers for 4 faces"), (vec![1, 4, 3, 3], "face 1 ends at layer 4")]
    {
        hm.tip_layers = Some(tips);
        let params = AssetParams { strands: StrandCount::Total(40), ..Default::default() };
        let err = HairAsset::build(&hm, &params, Style::default()).expect_err("bad tips").to_string();
        assert!(err.contains(expected), "{err}");
    }
}

#[test]
fn layers_inserted_removed_and_extruded_keep_the_hair() {
    let (layers, length) = (3, 1.5);
    let asset = build(&straight_hair(3, layers, length), 200);
    let (view, lod) = full_detail();
    let before = asset.generate_reference(&view, &lod);
    let ends = |strands: &[hairmesh::reference::Strand]| -> Vec<(DVec3, DVec3)> {
        strands.iter().map(|s| (s.positions[0], s.positions[s.positions.len() - 1])).collect()
    };
    // A layer inserted halfway up the second segment: the same straight strands, more layers.
    let mut mesh = asset.mesh().clone();
    mesh.insert_layer(2).expect("insert");
    let inserted = asset.with_layers(mesh).expect("rebuilt");
    assert_eq!((inserted.textures.layout.layers, inserted.mesh().layer_count()), (4, 4));
    let after = inserted.generate_reference(&view, &lod);
    assert_eq!(after.len(), before.len());
    for ((a, b), (c, d)) in ends(&before).iter().zip(&ends(&after)) {
        assert!(a.distance(*c) < 1e-9 && b.distance(*d) < 1e-9, "{a}→{b} became {c}→{d}");
    }
    // Removing it gives the first asset's strands back.
    let mut mesh = inserted.mesh().clone();
    mesh.remove_layer(2).expect("remove");
    let removed = inserted.with_layers(mesh).expect("rebuilt");
    for (s, t) in before.iter().zip(&removed.generate_reference(&view, &lod)) {
        let far = s.positions.iter().zip(&t.positions).map(|(p, q)| p.distance(*q)).fold(0.0, f64::max);
        assert!(far < 1e-9, "bundle {} strand {}: {far}", s.bundle, s.index);
    }
    // Extruding two faces: they grow by a layer's length, the others stay.
    let mut mesh = asset.mesh().clone();
    assert!(mesh.extrude_faces(&[0, 4]).expect("extrude"));
    let extruded = asset.with_layers(mesh).expect("rebuilt");
    for (b, info) in extruded.bundles.iter().enumerate() {
        let expected = if b == 0 || b == 4 { length * 4.0 / 3.0 } else { length };
        assert!((info.length - expected).abs() < 1e-9, "bundle {b}: {}", info.length);
    }
    // Another hair mesh's faces are refused.
    let other = straight_hair(2, layers, length);
    let err = asset.with_layers(other).expect_err("other faces").to_string();
    assert!(err.contains("faces or vertices differ"), "{err}");
}
