//! Where a head is and which way it faces, estimated from its mesh alone, so that what depends
//! on a head — the suggested hairline, presets, the drape's centre and gravity, the comb — works
//! on a scan in any unit and orientation.
//!
//! The estimate, each step robust to what scans have and lack:
//! 1. **Up**: a head or bust scan is cut open at the neck or chest; the cut is its longest
//!    border loop and up is the loop's plane normal pointing into the mesh. A closed mesh has no
//!    cut: up is the file's +Y (glTF's convention).
//! 2. **Skull**: a sphere fitted (area-weighted, algebraic) to the faces above its own centre,
//!    started from a band under the top and refitted until it settles: its centre and radius
//!    are the frame's centre and size.
//! 3. **Right**: the normal of the plane (through the centre, containing up) the head is most
//!    mirror-symmetric across, measured as the mean distance of the mirrored surface to the
//!    surface.
//! 4. **Front**: of the two directions perpendicular to both, the one the lower half of the
//!    profile reaches further along (face, nose and chin against the back of the head and neck).
//!    A mesh that is only a scalp has no face: its front is the file's (+Z; −Y when Z is up).
//!
//! Scans are nearly always aligned with the file's axes, so an up or front within
//! [`SNAP_DEGREES`] of an axis is snapped to it. The editor shows the frame and lets the artist
//! flip or turn it; the frame is then what the presets use.

use glam::{DMat4, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use crate::ScalpMesh;
use crate::head::HeadSurface;

/// An estimated up or front this close to one of the file's axes (degrees) is taken to be it.
pub const SNAP_DEGREES: f64 = 20.0;

/// Most faces the symmetry search mirrors (an even subsample of the head's faces).
const SYMMETRY_SAMPLES: usize = 600;

/// The suggested hairline, in the frame's own units (skull radii): faces whose centroid `p`
/// has `HAIRLINE_UP·h − HAIRLINE_FRONT·f > HAIRLINE_OFFSET`, with `h`, `f` the height and
/// forwardness of `p − centre` over the radius. The plane is tilted back so the hairline sits
/// on the forehead high above the eyes and at the nape low behind; fitted to the hairline of
/// the two test heads' hand-drawn hairlines (by area, 0.97 and 0.88 of the union in common).
pub const HAIRLINE_UP: f64 = 0.8192;
pub const HAIRLINE_FRONT: f64 = 0.5735;
pub const HAIRLINE_OFFSET: f64 = -0.16;

/// The face, in the frame's units: between the temples (|right| < `FACE_HALF_WIDTH`), from
/// the chin to the brows (`FACE_HEIGHTS`) and in front of the cheeks (front > `FACE_FRONT`).
/// Hair there hides the face; fitted to both test heads' faces.
pub const FACE_HALF_WIDTH: f64 = 0.55;
pub const FACE_HEIGHTS: std::ops::Range<f64> = -1.45..0.1;
pub const FACE_FRONT: f64 = 0.7;

/// How far below the skull's centre (radii) a mesh must reach to be more than a scalp.
pub const SCALP_ONLY_DEPTH: f64 = 0.5;

/// A head's centre (the skull's), up and front directions (unit, perpendicular) and size (the
/// skull's radius), in the file's units and axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeadFrame {
    pub centre: DVec3,
    pub up: DVec3,
    pub front: DVec3,
    pub radius: f64,
}

impl HeadFrame {
    /// The character's right (up × front is their left, seen from behind).
    pub fn right(&self) -> DVec3 {
        self.front.cross(self.up)
    }

    /// `p` in the frame: (right, up, front) over the radius.
    pub fn to_local(&self, p: DVec3) -> DVec3 {
        let d = (p - self.centre) / self.radius;
        DVec3::new(d.dot(self.right()), d.dot(self.up), d.dot(self.front))
    }

    /// A direction given in the frame (right, up, front) as a direction in the file.
    pub fn direction(&self, local: DVec3) -> DVec3 {
        self.right() * local.x + self.up * local.y + self.front * local.z
    }

    /// A point given in the frame (right, up, front, in radii) as a point in the file.
    pub fn point(&self, local: DVec3) -> DVec3 {
        self.centre + self.direction(local) * self.radius
    }

    /// The frame turned about its up axis by `degrees` (the face turns to its left for positive
    /// angles).
    pub fn turned(&self, degrees: f64) -> Self {
        let q = glam::DQuat::from_axis_angle(self.up, degrees.to_radians());
        Self { front: (q * self.front).normalize(), ..*self }
    }

    /// The frame with the front reversed (for a scan whose back was taken for its face).
    pub fn flipped(&self) -> Self {
        Self { front: -self.front, ..*self }
    }

    /// The frame with `up` as its up (the front kept as near as it can be).
    pub fn with_up(&self, up: DVec3) -> Option<Self> {
        let up = up.try_normalize()?;
        let front = (self.front - up * self.front.dot(up))
            .try_normalize()
            .or_else(|| up.any_orthonormal_vector().try_normalize())?;
        Some(Self { up, front, ..*self })
    }

    /// Whether a point is above the hairline at `offset` ([`HAIRLINE_OFFSET`] is the suggested
    /// one).
    pub fn above_hairline(&self, p: DVec3, offset: f64) -> bool {
        let l = self.to_local(p);
        HAIRLINE_UP * l.y - HAIRLINE_FRONT * l.z > offset
    }

    /// Whether `p` is in front of the face ([`FACE_FRONT`] and the box around it).
    pub fn over_face(&self, p: DVec3) -> bool {
        let l = self.to_local(p);
        l.x.abs() < FACE_HALF_WIDTH && FACE_HEIGHTS.contains(&l.y) && l.z > FACE_FRONT
    }

    /// The faces of `mesh` (by index) above the hairline at `offset` (in radii;
    /// [`HAIRLINE_OFFSET`] is the suggested one), as a `faces:` selector lists them. A mesh
    /// that is a scalp only (no face reaches [`SCALP_ONLY_DEPTH`] below the skull's centre: a
    /// cap has no face or neck to leave bare) is kept whole.
    pub fn hairline_faces(&self, mesh: &ScalpMesh, offset: f64) -> Vec<u32> {
        let centroids: Vec<DVec3> = mesh.faces.iter().map(|f| mesh.centroid(f)).collect();
        let scalp_only = centroids.iter().all(|c| self.to_local(*c).y > -SCALP_ONLY_DEPTH);
        (0..mesh.faces.len() as u32)
            .filter(|&f| scalp_only || self.above_hairline(centroids[f as usize], offset))
            .collect()
    }

    /// Estimates the frame of the head `mesh` (any polygons, welded or not); `None` when it has
    /// no face with area.
    pub fn estimate(mesh: &ScalpMesh) -> Option<Self> {
        let mut mesh = mesh.clone();
        mesh.weld(crate::import::WELD_TOLERANCE);
        let faces = area_weighted_centroids(&mesh);
        if faces.is_empty() {
            return None;
        }
        let mean = faces.iter().map(|(p, w)| *p * *w).sum::<DVec3>() / faces.iter().map(|f| f.1).sum::<f64>();
        let up = snap(neck_up(&mesh, mean).or_else(|| capped_neck_up(&mesh)).unwrap_or(DVec3::Y), None);
        let (centre, radius) = fit_skull(&faces, up)?;
        let surface = HeadSurface::from_mesh(&mesh);
        let right = symmetry_normal(&faces, &surface, centre, radius, up);
        // The mirror plane holds up: a neck cut tilted sideways is levelled.
        let up = (up - right * up.dot(right)).normalize_or(up);
        let frame = |front: DVec3| Self { centre, up, front: snap(front, Some(up)), radius };
        let scalp_only = faces.iter().all(|(p, _)| (*p - centre).dot(up) > -SCALP_ONLY_DEPTH * radius);
        Some(if scalp_only {
            // No face to find: the file's front (+Z, or −Y for a Z-up file, Blender's).
            let file_front = if up.z.abs() > 0.9 { DVec3::NEG_Y } else { DVec3::Z };
            frame(file_front)
        } else {
            frame(facing(&faces, centre, radius, up, right.cross(up).normalize()))
        })
    }
}

/// Face centroids with their areas (faces without area left out).
fn area_weighted_centroids(mesh: &ScalpMesh) -> Vec<(DVec3, f64)> {
    mesh.faces
        .iter()
        .filter_map(|f| {
            let p = |i: usize| mesh.positions[f[i] as usize];
            let area: f64 = (1..f.len().saturating_sub(1))
                .map(|i| 0.5 * (p(i) - p(0)).cross(p(i + 1) - p(0)).length())
                .sum();
            (area > 0.0 && area.is_finite()).then(|| (mesh.centroid(f), area))
        })
        .collect()
}

/// The normal of the longest border loop (the neck or chest cut), towards `inside`; `None`
/// for a closed mesh or one whose longest loop is too short to be a cut.
fn neck_up(mesh: &ScalpMesh, inside: DVec3) -> Option<DVec3> {
    use std::collections::HashMap;
    // Directed border edges: an edge used once, in the direction its face walks it.
    let mut uses: HashMap<(u32, u32), (u32, u32, u32)> = HashMap::new();
    for f in &mesh.faces {
        for i in 0..f.len() {
            let (a, b) = (f[i], f[(i + 1) % f.len()]);
            let e = uses.entry((a.min(b), a.max(b))).or_insert((a, b, 0));
            e.2 += 1;
        }
    }
    let mut next: HashMap<u32, u32> = uses.values().filter(|e| e.2 == 1).map(|e| (e.0, e.1)).collect();
    let mut best: Option<(f64, DVec3, DVec3)> = None;
    while let Some((&start, _)) = next.iter().next() {
        let mut loop_points = Vec::new();
        let mut v = start;
        while let Some(w) = next.remove(&v) {
            loop_points.push(mesh.positions[v as usize]);
            v = w;
            if v == start {
                break;
            }
        }
        let perimeter: f64 = (0..loop_points.len())
            .map(|i| loop_points[i].distance(loop_points[(i + 1) % loop_points.len()]))
            .sum();
        if best.is_none_or(|b| perimeter > b.0) {
            let n = newell(&loop_points);
            let c = loop_points.iter().sum::<DVec3>() / loop_points.len().max(1) as f64;
            best = Some((perimeter, n, c));
        }
    }
    let (perimeter, normal, centre) = best?;
    let (lo, hi) = mesh.bounds()?;
    // A hole for an eye or a nostril is not a cut through the neck.
    if perimeter < 0.5 * lo.distance(hi) {
        return None;
    }
    let n = normal.try_normalize()?;
    Some(if n.dot(inside - centre) >= 0.0 { n } else { -n })
}

/// Most faces tried as the plane of a capped neck.
const CAP_CANDIDATES: usize = 400;

/// A closed scan's neck is capped by a flat lid: the largest set of faces sharing one plane
/// (normals within 3°, centroids within 0.5 % of the size of it). Up is against the lid's outward
/// normal; `None` when no plane holds 1 % of the area.
fn capped_neck_up(mesh: &ScalpMesh) -> Option<DVec3> {
    let (lo, hi) = mesh.bounds()?;
    let tolerance = 5e-3 * lo.distance(hi);
    let faces: Vec<(DVec3, DVec3, f64)> = mesh
        .faces
        .iter()
        .filter_map(|f| {
            let points: Vec<DVec3> = f.iter().map(|&i| mesh.positions[i as usize]).collect();
            let n = newell(&points);
            let area = 0.5 * n.length();
            (area > 0.0).then(|| (n / (2.0 * area), mesh.centroid(f), area))
        })
        .collect();
    let total: f64 = faces.iter().map(|f| f.2).sum();
    let mut by_area: Vec<usize> = (0..faces.len()).collect();
    by_area.sort_by(|&a, &b| faces[b].2.total_cmp(&faces[a].2));
    let cos = 3f64.to_radians().cos();
    let (area, normal) = by_area
        .into_iter()
        .take(CAP_CANDIDATES)
        .map(|i| {
            let (n, c, _) = faces[i];
            let area: f64 = faces
                .iter()
                .filter(|f| f.0.dot(n) > cos && (f.1 - c).dot(n).abs() < tolerance)
                .map(|f| f.2)
                .sum();
            (area, n)
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    (area > 0.01 * total).then_some(-normal)
}

/// Newell's normal of a closed polygon (length = twice its area).
fn newell(points: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for i in 0..points.len() {
        let (a, b) = (points[i], points[(i + 1) % points.len()]);
        n += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    n
}

/// `d` snapped to the nearest of the file's axes (perpendicular to `perpendicular_to`, when
/// given) within [`SNAP_DEGREES`], else `d` made perpendicular to it.
fn snap(d: DVec3, perpendicular_to: Option<DVec3>) -> DVec3 {
    let d = match perpendicular_to {
        Some(up) => (d - up * d.dot(up)).normalize_or(d),
        None => d,
    };
    let axes = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::NEG_X, DVec3::NEG_Y, DVec3::NEG_Z];
    axes.into_iter()
        .filter(|a| perpendicular_to.is_none_or(|up| a.dot(up).abs() < 1e-9))
        .find(|a| a.dot(d) >= SNAP_DEGREES.to_radians().cos())
        .unwrap_or(d)
}

/// Least-squares sphere through weighted points: (centre, radius).
fn fit_sphere(points: &[(DVec3, f64)]) -> Option<(DVec3, f64)> {
    // |p|² = 2 p·c + k with k = r² − |c|²: linear in (c, k).
    let mut a = DMat4::ZERO;
    let mut b = DVec4::ZERO;
    for (p, w) in points {
        let row = DVec4::new(2.0 * p.x, 2.0 * p.y, 2.0 * p.z, 1.0);
        for i in 0..4 {
            *a.col_mut(i) += row * row[i] * *w;
        }
        b += row * p.length_squared() * *w;
    }
    if a.determinant().abs() < 1e-300 {
        return None;
    }
    let x = a.inverse() * b;
    let centre = x.truncate();
    let r2 = x.w + centre.length_squared();
    (r2 > 0.0 && centre.is_finite()).then(|| (centre, r2.sqrt()))
}

/// The skull: a sphere fitted to the faces above its centre, from a band under the top.
fn fit_skull(faces: &[(DVec3, f64)], up: DVec3) -> Option<(DVec3, f64)> {
    let heights = faces.iter().map(|(p, _)| p.dot(up));
    let (low, top) = heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, t), h| (l.min(h), t.max(h)));
    let band = 0.15 * (top - low);
    let mut cap: Vec<(DVec3, f64)> = faces.iter().copied().filter(|(p, _)| p.dot(up) >= top - band).collect();
    let mut sphere = fit_sphere(&cap)?;
    for _ in 0..12 {
        let (c, r) = sphere;
        cap = faces
            .iter()
            .copied()
            .filter(|(p, _)| (p - c).dot(up) >= 0.0 && p.distance(c) < 1.5 * r)
            .collect();
        let Some(next) = fit_sphere(&cap) else { break };
        let settled = next.0.distance(c) < 1e-4 * r && (next.1 - r).abs() < 1e-4 * r;
        sphere = next;
        if settled {
            break;
        }
    }
    Some(sphere)
}

/// The unit normal (perpendicular to `up`) of the plane through `centre` the head is most
/// mirror-symmetric across.
fn symmetry_normal(
    faces: &[(DVec3, f64)],
    surface: &HeadSurface,
    centre: DVec3,
    radius: f64,
    up: DVec3,
) -> DVec3 {
    let head: Vec<(DVec3, f64)> = faces
        .iter()
        .copied()
        .filter(|(p, _)| {
            let d = *p - centre;
            d.dot(up) > -1.3 * radius && (d - up * d.dot(up)).length() < 1.8 * radius
        })
        .collect();
    let stride = head.len().div_ceil(SYMMETRY_SAMPLES).max(1);
    let samples: Vec<(DVec3, f64)> = head.into_iter().step_by(stride).collect();
    let e1 = up.any_orthonormal_vector();
    let e2 = up.cross(e1);
    let normal = |degrees: f64| {
        let a = degrees.to_radians();
        e1 * a.cos() + e2 * a.sin()
    };
    let cap = 0.3 * radius;
    let asymmetry = |degrees: f64| -> f64 {
        let n = normal(degrees);
        samples
            .iter()
            .map(|(p, w)| {
                let mirrored = *p - n * (2.0 * (*p - centre).dot(n));
                surface.signed_distance(mirrored).abs().min(cap) * w
            })
            .sum()
    };
    let best_of = |angles: &mut dyn Iterator<Item = f64>| {
        angles.map(|a| (asymmetry(a), a)).min_by(|x, y| x.0.total_cmp(&y.0)).map_or(0.0, |b| b.1)
    };
    let coarse = best_of(&mut (0..36).map(|i| f64::from(i) * 5.0));
    let fine = best_of(&mut (-10..=10).map(|i| coarse + f64::from(i) * 0.5));
    normal(fine)
}

/// Which of `±forward` the face is on: the lower half of the head's profile reaches further
/// that way (nose, lips and chin against the back of the skull and the neck).
fn facing(faces: &[(DVec3, f64)], centre: DVec3, radius: f64, up: DVec3, forward: DVec3) -> DVec3 {
    const BANDS: usize = 8;
    let right = forward.cross(up);
    let mut reach = [[f64::NEG_INFINITY; BANDS]; 2];
    for (p, _) in faces {
        let d = *p - centre;
        let h = -d.dot(up) / radius;
        if !(0.0..1.0).contains(&h) || d.dot(right).abs() > 0.3 * radius {
            continue;
        }
        let band = ((h * BANDS as f64) as usize).min(BANDS - 1);
        let f = d.dot(forward);
        reach[0][band] = reach[0][band].max(f);
        reach[1][band] = reach[1][band].max(-f);
    }
    let total = |r: &[f64; BANDS]| r.iter().map(|x| x.max(0.0)).sum::<f64>();
    if total(&reach[0]) >= total(&reach[1]) { forward } else { -forward }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit sphere of `rings` × `segments` quads (triangles at the poles), closed.
    pub(crate) fn uv_sphere(rings: u32, segments: u32) -> ScalpMesh {
        let mut positions = vec![DVec3::Y, DVec3::NEG_Y];
        for i in 1..rings {
            let t = std::f64::consts::PI * f64::from(i) / f64::from(rings);
            for j in 0..segments {
                let a = std::f64::consts::TAU * f64::from(j) / f64::from(segments);
                positions.push(DVec3::new(t.sin() * a.cos(), t.cos(), -t.sin() * a.sin()));
            }
        }
        let at = |i: u32, j: u32| 2 + (i - 1) * segments + j % segments;
        let mut faces = Vec::new();
        for j in 0..segments {
            faces.push(vec![0, at(1, j), at(1, j + 1)]);
            faces.push(vec![1, at(rings - 1, j + 1), at(rings - 1, j)]);
            for i in 1..rings - 1 {
                faces.push(vec![at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        ScalpMesh { positions, faces, ..ScalpMesh::default() }
    }

    /// A closed ball: no cut, so up is the file's +Y.
    #[test]
    fn a_closed_mesh_keeps_the_files_up() {
        let ball = uv_sphere(16, 32);
        let frame = HeadFrame::estimate(&ball).expect("a frame");
        assert_eq!(frame.up, DVec3::Y);
        assert!((frame.radius - 1.0).abs() < 0.05, "{frame:?}");
        assert!(frame.centre.length() < 0.05, "{frame:?}");
        assert!(frame.front.dot(frame.up).abs() < 1e-9);
    }

    #[test]
    fn a_scalp_cap_is_kept_whole() {
        let cap = crate::procedural::head_cap(8, 32);
        let frame = HeadFrame::estimate(&cap).expect("a frame");
        assert_eq!(frame.up, DVec3::Y, "{frame:?}");
        assert_eq!(frame.front, DVec3::Z, "{frame:?}");
        assert_eq!(frame.hairline_faces(&cap, HAIRLINE_OFFSET).len(), cap.faces.len());
    }

    #[test]
    fn turning_and_flipping_keep_the_frame_orthonormal() {
        let f = HeadFrame { centre: DVec3::ONE, up: DVec3::Y, front: DVec3::Z, radius: 2.0 };
        let t = f.turned(90.0);
        assert!(t.front.distance(DVec3::X) < 1e-12, "{t:?}");
        assert_eq!(f.flipped().front, DVec3::NEG_Z);
        assert!(f.right().distance(DVec3::NEG_X) < 1e-12);
        let p = DVec3::new(0.3, -0.2, 0.7);
        assert!(f.to_local(f.point(p)).distance(p) < 1e-12);
        let z_up = f.with_up(DVec3::Z).expect("a frame");
        assert!(z_up.front.dot(DVec3::Z).abs() < 1e-12 && (z_up.front.length() - 1.0).abs() < 1e-12);
    }
}
