//! Meshes the project makes itself, so the demo needs no downloaded files.

use std::f64::consts::PI;
use std::path::Path;

use glam::{DVec2, DVec3};

use crate::ScalpMesh;

/// A head cap: the part of an ellipsoid (semi-axes `radii`, metres, +Y up, face toward +Z)
/// above a hairline that sits lower at the back than at the front, as quads on a
/// latitude/longitude grid (`rings` × `segments`), with a polar triangle fan at the crown.
/// uv: u = longitude / 2π, v = colatitude / the cap's extent.
pub fn head_cap(rings: u32, segments: u32) -> ScalpMesh {
    let rings = rings.max(1);
    let segments = segments.max(3);
    let radii = DVec3::new(0.078, 0.095, 0.1);
    let centre = DVec3::new(0.0, 1.6, 0.0);
    // Colatitude of the hairline: 62° at the forehead (+Z), 100° at the nape (−Z).
    let hairline = |phi: f64| (62.0 + 38.0 * (0.5 - 0.5 * phi.cos())).to_radians();
    let mut positions = vec![centre + DVec3::new(0.0, radii.y, 0.0)];
    let mut uvs = vec![DVec2::new(0.5, 0.0)];
    for r in 1..=rings {
        for s in 0..segments {
            let phi = 2.0 * PI * f64::from(s) / f64::from(segments);
            let theta = hairline(phi) * f64::from(r) / f64::from(rings);
            let dir = DVec3::new(theta.sin() * phi.sin(), theta.cos(), theta.sin() * phi.cos());
            positions.push(centre + dir * radii);
            uvs.push(DVec2::new(f64::from(s) / f64::from(segments), f64::from(r) / f64::from(rings)));
        }
    }
    let id = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut faces = Vec::new();
    for s in 0..segments {
        faces.push(vec![0, id(1, s), id(1, s + 1)]);
    }
    for r in 1..rings {
        for s in 0..segments {
            // Counter-clockwise seen from outside.
            faces.push(vec![id(r, s), id(r + 1, s), id(r + 1, s + 1), id(r, s + 1)]);
        }
    }
    ScalpMesh { positions, uvs: Some(uvs), faces, ..Default::default() }
}

/// Writes a mesh as glTF 2.0 with one embedded (base64) buffer: f32 positions, f32 uvs and u32
/// triangle indices (polygons fanned). Atomic.
pub fn write_gltf(path: &Path, mesh: &ScalpMesh, name: &str) -> std::io::Result<()> {
    use base64::Engine as _;
    let triangles: Vec<u32> =
        mesh.faces.iter().flat_map(|f| (1..f.len() - 1).flat_map(move |k| [f[0], f[k], f[k + 1]])).collect();
    let mut buffer = Vec::new();
    for p in &mesh.positions {
        for c in p.to_array() {
            buffer.extend((c as f32).to_le_bytes());
        }
    }
    let pos_len = buffer.len();
    let uvs = mesh.uvs.clone().unwrap_or_else(|| vec![DVec2::ZERO; mesh.positions.len()]);
    for t in &uvs {
        for c in t.to_array() {
            buffer.extend((c as f32).to_le_bytes());
        }
    }
    let uv_len = buffer.len() - pos_len;
    for i in &triangles {
        buffer.extend(i.to_le_bytes());
    }
    let idx_len = buffer.len() - pos_len - uv_len;
    // Morph targets (hair layers as shape keys): displacements from the base positions.
    let mut target_views = Vec::new();
    for layer in &mesh.morph_layers {
        let start = buffer.len();
        for (p, base) in layer.iter().zip(&mesh.positions) {
            for c in (*p - *base).to_array() {
                buffer.extend((c as f32).to_le_bytes());
            }
        }
        target_views.push((start, buffer.len() - start));
    }
    let (lo, hi) = mesh.bounds().unwrap_or((DVec3::ZERO, DVec3::ZERO));
    let f32s = |v: DVec3| v.to_array().map(|c| serde_json::json!(c as f32));
    let mut doc = serde_json::json!({
        "asset": {"version": "2.0", "generator": "hairkit hairmesh::procedural"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": name}],
        "meshes": [{"name": name, "primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "mode": 4}]}],
        "buffers": [{"byteLength": buffer.len(), "uri": format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&buffer))}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_len, "target": 34962},
            {"buffer": 0, "byteOffset": pos_len, "byteLength": uv_len, "target": 34962},
            {"buffer": 0, "byteOffset": pos_len + uv_len, "byteLength": idx_len, "target": 34963}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": mesh.positions.len(), "type": "VEC3", "min": f32s(lo), "max": f32s(hi)},
            {"bufferView": 1, "componentType": 5126, "count": uvs.len(), "type": "VEC2"},
            {"bufferView": 2, "componentType": 5125, "count": triangles.len(), "type": "SCALAR"}
        ]
    });
    if !target_views.is_empty() {
        let mut targets = Vec::new();
        for (k, (offset, len)) in target_views.iter().enumerate() {
            let view = 3 + k;
            if let Some(views) = doc["bufferViews"].as_array_mut() {
                views.push(serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": len}));
            }
            if let Some(accessors) = doc["accessors"].as_array_mut() {
                accessors.push(serde_json::json!({"bufferView": view, "componentType": 5126, "count": mesh.positions.len(), "type": "VEC3"}));
            }
            targets.push(serde_json::json!({"POSITION": view}));
        }
        doc["meshes"][0]["primitives"][0]["targets"] = serde_json::Value::Array(targets);
    }
    let text = serde_json::to_string_pretty(&doc).map_err(std::io::Error::other)?;
    crate::atomic::write_file_atomic(path, |w| w.write_all(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::load_scalp;
    use crate::{BundleFace, ExtrudeParams, HairMesh, ScalpSelector};

    #[test]
    fn head_cap_round_trips_through_gltf_and_keeps_its_quads() {
        let cap = head_cap(6, 24);
        assert_eq!(cap.faces.len(), 24 + 5 * 24);
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("cap.gltf");
        write_gltf(&path, &cap, "head cap").expect("write");
        let loaded = load_scalp(&path, &ScalpSelector::All).expect("load");
        assert_eq!(loaded.positions.len(), cap.positions.len());
        assert!((loaded.area() - cap.area()).abs() < 1e-6 * cap.area());
        let hm = HairMesh::extrude(&loaded, &ExtrudeParams::default()).expect("extrude");
        let quads = hm.faces.iter().filter(|f| matches!(f, BundleFace::Quad(_))).count();
        // Every triangulated grid quad is recovered; neighbouring crown-fan triangles may pair
        // up too (they are near-planar convex quads).
        assert!(quads >= 5 * 24, "{quads}");
        // Normals point outward: the first layer is farther from the centre than the root.
        // (Checked below through morph targets too.)
        let centre = DVec3::new(0.0, 1.6, 0.0);
        assert!(hm.layers[1].iter().zip(&hm.layers[0]).all(|(a, b)| a.distance(centre) > b.distance(centre)));
    }
}

#[cfg(test)]
mod morph_tests {
    use super::*;
    use crate::import::load_scalp;
    use crate::{ExtrudeParams, HairMesh, ScalpSelector};

    /// A hair mesh modelled as shape keys (one glTF morph target per layer) imports as layers.
    #[test]
    fn morph_target_layers_import_as_hair_mesh_layers() {
        let mut cap = head_cap(3, 12);
        let extruded = HairMesh::extrude(
            &cap,
            &ExtrudeParams { layers: 3, length: 0.1, droop: 0.5, ..ExtrudeParams::default() },
        )
        .expect("extrude");
        cap.morph_layers = extruded.layers[1..].to_vec();
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("shape_keys.gltf");
        write_gltf(&path, &cap, "shape keys").expect("write");
        let loaded = load_scalp(&path, &ScalpSelector::All).expect("load");
        assert_eq!(loaded.morph_layers.len(), 3);
        let hm = HairMesh::from_morph_targets(&loaded).expect("layers from targets");
        assert_eq!(hm.layer_count(), 3);
        // Same layers as the extrusion they were written from (f32 in the file).
        for (k, layer) in hm.layers.iter().enumerate() {
            for p in layer {
                let nearest = extruded.layers[k].iter().map(|q| q.distance(*p)).fold(f64::INFINITY, f64::min);
                assert!(nearest < 1e-6, "layer {k}: {p} is {nearest} from the extruded layer");
            }
        }
    }
}
