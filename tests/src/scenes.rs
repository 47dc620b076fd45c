//! The repository's example scenes at test sizes, written to a temporary folder with their
//! asset paths made absolute (so they resolve from anywhere).

use std::path::{Path, PathBuf};

use anyhow::Context as _;

/// A path inside the repository.
pub fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

/// A file of the third-party data set (heads, grooms): see `data_set` for where it is found.
pub fn data(path: &str) -> anyhow::Result<PathBuf> {
    Ok(data_set::locate(path)?)
}

/// The artist's full Sintel groom (TressFX, 11,400 strands × 16 points, drawn as explicit
/// strands) on the Sintel bust as its occluder, both from the data set, 256×256, written to
/// `dir/NAME.json` with `effects`. The groom is in metres, the bust in centimetres 1.195 m lower
/// (found by matching the groom's roots to the bust's own guide file, sintel_hair.tfx).
pub fn sintel_scene(dir: &Path, name: &str, effects: serde_json::Value) -> anyhow::Result<PathBuf> {
    let groom = data("strands/tressfx/v4/sintel_hair_full_16points.tfx")?;
    let bust = data("heads/sintel/sintel_bust.obj")?;
    let scene = serde_json::json!({
        "output": { "width": 256, "height": 256 },
        "camera": { "eye": [0.15, 1.62, 0.5], "target": [0.0, 1.52, 0.0], "fov_y_degrees": 40 },
        "lights": [ { "directional": { "direction": [0.3, 0.9, 0.6] } } ],
        "characters": [ {
            "hair": groom, "color": [0.171, 0.0397, 0.00719], "strand_width": 0.0004,
            "occluder": { "mesh": bust, "transform": { "scale": 0.01, "translation": [0, 1.195, 0] } }
        } ],
        "effects": effects
    });
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, serde_json::to_vec_pretty(&scene)?)?;
    Ok(path)
}

/// `assets/scenes/NAME.json` at `width`×`height`, opaque.
pub fn small_scene(dir: &Path, name: &str, width: u32, height: u32) -> anyhow::Result<PathBuf> {
    scene_with(dir, name, width, height, serde_json::json!({ "transparency": "opaque" }))
}

/// `assets/scenes/NAME.json` at `width`×`height` with `effects`, drawn by the triangle raster
/// unless `effects` names a `raster` (the golden images are the triangle raster's, the
/// reference the compute rasterizer is compared with).
pub fn scene_with(
    dir: &Path,
    name: &str,
    width: u32,
    height: u32,
    effects: serde_json::Value,
) -> anyhow::Result<PathBuf> {
    let text = std::fs::read_to_string(repo(&format!("assets/scenes/{name}.json")))?;
    let mut json: serde_json::Value = serde_json::from_str(&text)?;
    json["output"] = serde_json::json!({ "width": width, "height": height });
    let mut effects = effects;
    if let Some(e) = effects.as_object_mut() {
        e.entry("raster").or_insert_with(|| serde_json::json!("triangles"));
    }
    json["effects"] = effects;
    for c in json["characters"].as_array_mut().context("characters")? {
        let hair = c["hair"].as_str().context("hair")?.to_owned();
        c["hair"] = serde_json::json!(repo("assets/scenes").join(hair));
        if let Some(mesh) = c["occluder"]["mesh"].as_str().map(str::to_owned) {
            c["occluder"]["mesh"] = serde_json::json!(repo("assets/scenes").join(mesh));
        }
    }
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, serde_json::to_vec_pretty(&json)?)?;
    Ok(path)
}

/// [`scene_with`], then `edit` applied to the scene's JSON in place (a camera, a style, an
/// occluder removed); returns the same path.
pub fn scene_with_edit(
    dir: &Path,
    name: &str,
    width: u32,
    height: u32,
    effects: serde_json::Value,
    edit: impl FnOnce(&mut serde_json::Value) -> anyhow::Result<()>,
) -> anyhow::Result<PathBuf> {
    let path = scene_with(dir, name, width, height, effects)?;
    let mut json: serde_json::Value = serde_json::from_slice(&std::fs::read(&path)?)?;
    edit(&mut json)?;
    std::fs::write(&path, serde_json::to_vec_pretty(&json)?)?;
    Ok(path)
}

/// An edit as the editor makes one: the tip-layer vertices on the +x side of the head (root
/// x > 0.05) pulled outwards and up.
pub fn pull_tips(asset: &hairmesh::asset::HairAsset) -> Vec<hairmesh::asset::VertexMove> {
    let mesh = asset.mesh();
    let tips = mesh.layers.len() - 1;
    (0..mesh.vertex_count())
        .filter(|&v| mesh.layers[0][v].x > 0.05)
        .map(|v| hairmesh::asset::VertexMove {
            layer: tips as u32,
            vertex: v as u32,
            position: mesh.layers[tips][v] + glam::DVec3::new(0.08, 0.02, 0.0),
        })
        .collect()
}
