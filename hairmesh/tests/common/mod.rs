//! Meshes shared by the integration tests.

use std::path::PathBuf;

use glam::{DVec2, DVec3};
use hairmesh::ScalpMesh;
use hairmesh::rng::SplitMix64;

/// A bumpy n×n grid patch (quads) plus a fan of triangles on one side.
#[allow(dead_code, reason = "each test binary uses a different part of this module")]
pub fn patch(n: u32, origin: DVec3, scale: f64, rng: &mut SplitMix64) -> ScalpMesh {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let bump = 0.15 * (rng.next_f64() - 0.5);
            positions.push(origin + DVec3::new(f64::from(i), bump, -f64::from(j)) * scale);
            uvs.push(DVec2::new(f64::from(i), f64::from(j)) / f64::from(n));
        }
    }
    let id = |i: u32, j: u32| j * (n + 1) + i;
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            faces.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let apex = positions.len() as u32;
    positions.push(origin + DVec3::new(-1.0, 0.0, -0.5 * f64::from(n)) * scale);
    uvs.push(DVec2::new(-0.2, 0.5));
    for j in 0..n {
        faces.push(vec![apex, id(0, j), id(0, j + 1)]);
    }
    ScalpMesh { positions, uvs: Some(uvs), faces, ..Default::default() }
}

/// A file or folder of the third-party data set (heads, grooms, glTF samples), wherever the
/// resolver finds it; a missing one fails the test with the message that says how to get it.
#[allow(dead_code, reason = "each test binary uses a different part of this module")]
pub fn testdata(relative: &str) -> PathBuf {
    data_set::require(relative)
}
