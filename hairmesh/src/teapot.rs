//! The Utah teapot (Martin Newell, 1975) from its public Bézier patches: 32 bicubic patches.
//! The rim, body, lid and bottom are surfaces of revolution (one profile curve swept by the
//! four-arc circle approximation the original data uses, κ = 0.56); the handle and the spout
//! are two patches each, mirrored across the y = 0 plane. Z is up in the original data; the
//! meshes here are Y up, 3.15 units tall, spout toward +X.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};

use crate::scalp::ScalpMesh;

/// One bicubic Bézier patch: `control[row][column]`.
pub type Patch = [[DVec3; 4]; 4];

/// Profile curves (radius, height) of the surfaces of revolution, top to bottom.
const RIM: [[f64; 2]; 4] = [[1.4, 2.4], [1.3375, 2.53125], [1.4375, 2.53125], [1.5, 2.4]];
const BODY_UPPER: [[f64; 2]; 4] = [[1.5, 2.4], [1.75, 1.875], [2.0, 1.35], [2.0, 0.9]];
const BODY_LOWER: [[f64; 2]; 4] = [[2.0, 0.9], [2.0, 0.45], [1.5, 0.225], [1.5, 0.15]];
const LID_KNOB: [[f64; 2]; 4] = [[0.0, 3.15], [0.8, 3.15], [0.0, 2.85], [0.2, 2.7]];
const LID: [[f64; 2]; 4] = [[0.2, 2.7], [0.4, 2.55], [1.3, 2.55], [1.3, 2.4]];
const BOTTOM: [[f64; 2]; 4] = [[1.5, 0.15], [1.5, 0.075], [1.425, 0.0], [0.0, 0.0]];

/// The -Y half of the handle and the spout, as (x, y, z) rows along the tube.
const HANDLE: [[[f64; 3]; 4]; 8] = [
    [[-1.6, 0.0, 2.025], [-1.6, -0.3, 2.025], [-1.5, -0.3, 2.25], [-1.5, 0.0, 2.25]],
    [[-2.3, 0.0, 2.025], [-2.3, -0.3, 2.025], [-2.5, -0.3, 2.25], [-2.5, 0.0, 2.25]],
    [[-2.7, 0.0, 2.025], [-2.7, -0.3, 2.025], [-3.0, -0.3, 2.25], [-3.0, 0.0, 2.25]],
    [[-2.7, 0.0, 1.8], [-2.7, -0.3, 1.8], [-3.0, -0.3, 1.8], [-3.0, 0.0, 1.8]],
    [[-2.7, 0.0, 1.8], [-2.7, -0.3, 1.8], [-3.0, -0.3, 1.8], [-3.0, 0.0, 1.8]],
    [[-2.7, 0.0, 1.575], [-2.7, -0.3, 1.575], [-3.0, -0.3, 1.35], [-3.0, 0.0, 1.35]],
    [[-2.5, 0.0, 1.125], [-2.5, -0.3, 1.125], [-2.65, -0.3, 0.9375], [-2.65, 0.0, 0.9375]],
    [[-2.0, 0.0, 0.9], [-2.0, -0.3, 0.9], [-1.9, -0.3, 0.6], [-1.9, 0.0, 0.6]],
];
const SPOUT: [[[f64; 3]; 4]; 8] = [
    [[1.7, 0.0, 1.275], [1.7, -0.66, 1.275], [1.7, -0.66, 0.45], [1.7, 0.0, 0.45]],
    [[2.6, 0.0, 1.275], [2.6, -0.66, 1.275], [3.1, -0.66, 0.675], [3.1, 0.0, 0.675]],
    [[2.3, 0.0, 1.95], [2.3, -0.25, 1.95], [2.4, -0.25, 1.875], [2.4, 0.0, 1.875]],
    [[2.7, 0.0, 2.25], [2.7, -0.25, 2.25], [3.3, -0.25, 2.25], [3.3, 0.0, 2.25]],
    [[2.7, 0.0, 2.25], [2.7, -0.25, 2.25], [3.3, -0.25, 2.25], [3.3, 0.0, 2.25]],
    [[2.8, 0.0, 2.325], [2.8, -0.25, 2.325], [3.525, -0.25, 2.34375], [3.525, 0.0, 2.34375]],
    [[2.9, 0.0, 2.325], [2.9, -0.15, 2.325], [3.45, -0.15, 2.3625], [3.45, 0.0, 2.3625]],
    [[2.8, 0.0, 2.25], [2.8, -0.15, 2.25], [3.2, -0.15, 2.25], [3.2, 0.0, 2.25]],
];

/// Which parts of the teapot a mesh holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TeapotParts {
    /// Rim, body and lid: the surfaces hair grows from (outward-facing, consistently wound).
    Scalp,
    /// Every patch, for drawing the teapot as an occluder.
    Whole,
}

/// Z-up original coordinates → Y-up.
fn y_up(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, z, -y)
}

/// The four patches sweeping `profile` around the vertical axis.
fn revolution(profile: &[[f64; 2]; 4]) -> [Patch; 4] {
    const K: f64 = 0.56;
    // One quarter of the circle from +X toward −Y (original axes), then rotated.
    let arc = [[1.0, 0.0], [1.0, -K], [K, -1.0], [0.0, -1.0]];
    std::array::from_fn(|quarter| {
        let (s, c) = (-(quarter as f64) * PI / 2.0).sin_cos();
        std::array::from_fn(|row| {
            let [r, z] = profile[row];
            std::array::from_fn(|col| {
                let [ax, ay] = arc[col];
                let (x, y) = (c * ax - s * ay, s * ax + c * ay);
                y_up(r * x, r * y, z)
            })
        })
    })
}

/// A tube half (`rows` along the tube, y ≤ 0) and its mirror image, as two patches each.
fn mirrored(rows: &[[[f64; 3]; 4]; 8]) -> [Patch; 4] {
    let patch = |first: usize, mirror: bool| -> Patch {
        std::array::from_fn(|row| {
            std::array::from_fn(|col| {
                // Mirroring reverses the columns so the winding stays consistent.
                let [x, y, z] = rows[first + row][if mirror { 3 - col } else { col }];
                y_up(x, if mirror { -y } else { y }, z)
            })
        })
    };
    [patch(0, false), patch(4, false), patch(0, true), patch(4, true)]
}

/// The teapot's Bézier patches (32 for [`TeapotParts::Whole`]).
pub fn patches(parts: TeapotParts) -> Vec<Patch> {
    let mut all: Vec<Patch> =
        [RIM, BODY_UPPER, BODY_LOWER, LID_KNOB, LID].iter().flat_map(revolution).collect();
    if parts == TeapotParts::Whole {
        all.extend(revolution(&BOTTOM));
        all.extend(mirrored(&HANDLE));
        all.extend(mirrored(&SPOUT));
    }
    all
}

fn bernstein(t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t]
}

/// The point of `patch` at (u along the rows, v along the columns) in [0, 1]².
pub fn evaluate(patch: &Patch, u: f64, v: f64) -> DVec3 {
    let (bu, bv) = (bernstein(u), bernstein(v));
    let mut p = DVec3::ZERO;
    for (row, wu) in patch.iter().zip(bu) {
        for (point, wv) in row.iter().zip(bv) {
            p += *point * (wu * wv);
        }
    }
    p
}

/// The teapot tessellated into `divisions`² quads per patch, welded (patch seams and the
/// collapsed rows at the lid's top become shared vertices), with cylindrical uvs.
pub fn teapot(divisions: u32, parts: TeapotParts) -> ScalpMesh {
    let n = divisions.max(1);
    let mut mesh = ScalpMesh::default();
    let mut uvs = Vec::new();
    for patch in patches(parts) {
        let base = mesh.positions.len() as u32;
        for i in 0..=n {
            for j in 0..=n {
                let p = evaluate(&patch, f64::from(i) / f64::from(n), f64::from(j) / f64::from(n));
                mesh.positions.push(p);
                uvs.push(DVec2::new(0.5 + p.z.atan2(p.x) / (2.0 * PI), 1.0 - p.y / 3.15));
            }
        }
        let at = |i: u32, j: u32| base + i * (n + 1) + j;
        for i in 0..n {
            for j in 0..n {
                // Outward-facing for the surfaces of revolution (the profile runs top to
                // bottom, the sweep clockwise seen from above).
                mesh.faces.push(vec![at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)]);
            }
        }
    }
    mesh.uvs = Some(uvs);
    mesh.weld(crate::import::WELD_TOLERANCE);
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn teapot_has_32_patches_and_the_classic_size() {
        assert_eq!(patches(TeapotParts::Whole).len(), 32);
        let mesh = teapot(4, TeapotParts::Whole);
        let (lo, hi) = mesh.bounds().expect("bounds");
        // Spout tip at x = 3.434 (the last row's middle), handle at −3, lid knob at 3.15.
        assert!((hi.y - 3.15).abs() < 1e-9 && lo.y.abs() < 1e-9, "{lo} {hi}");
        assert!((lo.x + 3.0).abs() < 1e-9 && hi.x > 3.4 && hi.x < 3.45, "{lo} {hi}");
        assert!((hi.z - 2.0).abs() < 1e-6 && (lo.z + 2.0).abs() < 1e-6, "body radius 2: {lo} {hi}");
    }

    #[test]
    fn patches_meet_along_their_edges() {
        // The surfaces of revolution share edges with each other after welding; the scalp's
        // only boundaries are three circles: the rim's inner lip (r = 1.4), the lid's edge
        // (r = 1.3, the lid sits loose in the opening) and the body's bottom (r = 1.5).
        let mesh = teapot(3, TeapotParts::Scalp);
        let mut edges = std::collections::HashMap::<(u32, u32), u32>::new();
        for f in &mesh.faces {
            for k in 0..f.len() {
                let (a, b) = (f[k], f[(k + 1) % f.len()]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let boundary = edges.values().filter(|&&c| c == 1).count();
        // Each loop is 4 patches × 3 divisions = 12 edges; every other edge has two faces.
        assert!(edges.values().all(|&c| c <= 2), "no edge has three faces");
        assert_eq!(boundary, 36, "three boundary loops");
    }

    #[test]
    fn scalp_faces_point_outward() {
        let mesh = teapot(4, TeapotParts::Scalp);
        let outward = mesh
            .faces
            .iter()
            .filter(|f| {
                let [a, b, c] = [f[0], f[1], f[2]].map(|i| mesh.positions[i as usize]);
                let n = (b - a).cross(c - a);
                let centroid = mesh.centroid(f);
                // Away from the vertical axis (body) or up (lid top).
                let radial = DVec3::new(centroid.x, 0.0, centroid.z);
                n.dot(radial) > 0.0 || n.y > 0.0
            })
            .count();
        assert!(outward * 10 >= mesh.faces.len() * 9, "{outward} of {} faces face outward", mesh.faces.len());
    }
}
