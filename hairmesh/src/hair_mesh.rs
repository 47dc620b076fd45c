//! The hair mesh: the scalp's faces (bundles) extruded through layers with one topology.
//!
//! Root layer = scalp faces. Triangles are paired back into quads where two neighbours form a
//! near-planar convex quad (a triangulated export of a quad-modelled scalp gets its quads
//! back); quads that are not convex and planar are split along their shorter diagonal; n-gons
//! are fanned into triangles first. Layers come either from extrusion along smoothed vertex
//! normals with optional gravity droop, or from the file's morph targets (one per layer).

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{HairMeshError, Result, ScalpMesh};

/// One bundle's root face: indices into every layer's vertex list.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BundleFace {
    Triangle([u32; 3]),
    Quad([u32; 4]),
}

impl BundleFace {
    pub fn vertices(&self) -> &[u32] {
        match self {
            BundleFace::Triangle(v) => v,
            BundleFace::Quad(v) => v,
        }
    }
}

/// How layers are made.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExtrudeParams {
    /// Number of layers above the root layer (L ≥ 1).
    pub layers: u32,
    /// Hair length along the normal, in the file's units.
    pub length: f64,
    /// Downward pull at the tip as a fraction of `length` (0 = straight out), growing with the
    /// square of the distance from the root.
    pub droop: f64,
    /// The direction gravity pulls (the file's "down").
    pub gravity: DVec3,
}

impl Default for ExtrudeParams {
    fn default() -> Self {
        Self { layers: 4, length: 1.0, droop: 0.0, gravity: DVec3::NEG_Y }
    }
}

/// How [`HairMesh::drape`] lays hair over a head.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DrapeParams {
    /// Number of layers above the root layer (L ≥ 1).
    pub layers: u32,
    /// Hair length (arc length from the root to the tip), in the file's units.
    pub length: f64,
    /// The centre of the head the hair flows around (the skull's centre, roughly).
    pub centre: DVec3,
    /// How far the hair moves away from the head per unit of length while it flows over it
    /// (0 = it keeps its root's distance from `centre`).
    pub lift: f64,
    /// The direction gravity pulls (the file's "down").
    pub gravity: DVec3,
    /// Added to the gravity direction while the hair flows over the head: the way it is
    /// combed (e.g. backwards, away from the face; sideways for a side part). The hair never
    /// flows from the direction opposite to this sum, so put that direction off the scalp
    /// (into the face for hair combed back).
    pub comb: DVec3,
}

/// Most layers a hair mesh may have (the texture holds 1 + 3L slices).
pub const MAX_LAYERS: u32 = 64;

/// Layers × vertices with one face list. Stored in an asset's manifest (`mesh`), so an asset
/// can be reopened, edited and re-baked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HairMesh {
    /// `layers[0]` is the scalp; `layers.len() = L + 1`, each with one entry per vertex.
    pub layers: Vec<Vec<DVec3>>,
    pub faces: Vec<BundleFace>,
    /// Root uv per vertex, when the scalp had texture coordinates.
    pub uvs: Option<Vec<DVec2>>,
    /// The layer each face's strands end at (the paper's *tip layer*, 1..=L), one per face:
    /// bundles of different lengths — a short fringe, a long back — in one hair mesh. Absent
    /// when every bundle reaches the last layer (so older assets read and write unchanged).
    /// Vertex columns still run through every layer: a column shared by a short and a long
    /// face goes on for the long one, and the short face's curve ends where its tip layer is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_layers: Option<Vec<u32>>,
}

impl HairMesh {
    pub fn layer_count(&self) -> usize {
        self.layers.len().saturating_sub(1)
    }

    pub fn vertex_count(&self) -> usize {
        self.layers.first().map_or(0, Vec::len)
    }

    /// The layer face `face`'s strands end at (1..=L).
    pub fn tip_layer(&self, face: usize) -> u32 {
        let last = self.layer_count() as u32;
        self.tip_layers.as_ref().and_then(|t| t.get(face)).map_or(last, |&t| t.clamp(1, last.max(1)))
    }

    /// Every face's tip layer ([`Self::tip_layer`]).
    pub fn tips(&self) -> Vec<u32> {
        (0..self.faces.len()).map(|f| self.tip_layer(f)).collect()
    }

    /// Sets every face's tip layer; a mesh whose faces all reach the last layer drops the list
    /// (the older form).
    pub(crate) fn set_tips(&mut self, tips: Vec<u32>) {
        let last = self.layer_count() as u32;
        self.tip_layers = if tips.iter().all(|&t| t == last) { None } else { Some(tips) };
    }

    /// Whether the tip layers fit the mesh: one per face, each in 1..=L.
    pub fn check_tip_layers(&self) -> std::result::Result<(), String> {
        let Some(tips) = &self.tip_layers else { return Ok(()) };
        if tips.len() != self.faces.len() {
            return Err(format!("{} tip layers for {} faces", tips.len(), self.faces.len()));
        }
        let last = self.layer_count() as u32;
        match tips.iter().position(|&t| t == 0 || t > last) {
            Some(f) => Err(format!("face {f} ends at layer {} (expected 1..={last})", tips[f])),
            None => Ok(()),
        }
    }

    /// The vertex column of vertex `v` through all layers.
    pub fn column(&self, v: u32) -> Vec<DVec3> {
        self.layers.iter().map(|l| l[v as usize]).collect()
    }

    /// w per layer per vertex: path length along the vertex column (0 at the root).
    pub fn w(&self) -> Vec<Vec<f64>> {
        let mut w = vec![vec![0.0; self.vertex_count()]];
        for pair in self.layers.windows(2) {
            let below = &w[w.len() - 1];
            let next = below
                .iter()
                .zip(pair[0].iter().zip(&pair[1]))
                .map(|(w, (a, b))| w + a.distance(*b))
                .collect();
            w.push(next);
        }
        w
    }

    /// Builds the hair mesh by extruding `scalp` along smoothed normals.
    pub fn extrude(scalp: &ScalpMesh, params: &ExtrudeParams) -> Result<Self> {
        let bad = |message: String| HairMeshError::InvalidParameter { what: "extrusion", message };
        if params.layers == 0 || params.layers > MAX_LAYERS {
            return Err(bad(format!("{} layers (expected 1..={MAX_LAYERS})", params.layers)));
        }
        if !(params.length.is_finite() && params.length > 0.0) {
            return Err(bad(format!("length {} (expected a positive number)", params.length)));
        }
        if !params.droop.is_finite() || !params.gravity.is_finite() {
            return Err(bad("droop and gravity must be finite".into()));
        }
        let gravity = params.gravity.try_normalize().unwrap_or(DVec3::ZERO);
        let faces = bundle_faces(scalp);
        let normals = vertex_normals(scalp);
        let l = f64::from(params.layers);
        let layers = (0..=params.layers)
            .map(|k| {
                let t = f64::from(k) / l;
                scalp
                    .positions
                    .iter()
                    .zip(&normals)
                    .map(|(p, n)| {
                        *p + *n * (params.length * t) + gravity * (params.droop * params.length * t * t)
                    })
                    .collect()
            })
            .collect();
        Ok(Self { layers, faces, uvs: scalp.uvs.clone(), tip_layers: None })
    }

    /// Builds the hair mesh by laying hair over a head: each vertex column flows over a sphere
    /// around `centre` (its radius the root's distance, growing by `lift` per unit length),
    /// turning from the root's direction towards `gravity + comb` at one radian per radius of
    /// length, until the head's surface turns vertical (the direction from the centre is
    /// perpendicular to gravity); from there it hangs straight down. Hair that starts below
    /// that line hangs from its root. Roots keep their positions; neighbouring roots get
    /// neighbouring paths, so bundles stay well shaped.
    pub fn drape(scalp: &ScalpMesh, params: &DrapeParams) -> Result<Self> {
        Self::drape_over(scalp, params, None)
    }

    /// [`HairMesh::drape`] over a head: every step of the march that would enter `head` (or come
    /// closer than `clearance`) is moved out onto it, so hair slides over ears and shoulders
    /// instead of through them.
    pub fn drape_over(
        scalp: &ScalpMesh,
        params: &DrapeParams,
        head: Option<(&crate::head::HeadSurface, f64)>,
    ) -> Result<Self> {
        let bad = |message: String| HairMeshError::InvalidParameter { what: "drape", message };
        if params.layers == 0 || params.layers > MAX_LAYERS {
            return Err(bad(format!("{} layers (expected 1..={MAX_LAYERS})", params.layers)));
        }
        if !(params.length.is_finite() && params.length > 0.0) {
            return Err(bad(format!("length {} (expected a positive number)", params.length)));
        }
        if !(params.centre.is_finite() && params.lift.is_finite() && params.lift >= 0.0) {
            return Err(bad("the centre must be finite and the lift finite and ≥ 0".into()));
        }
        let gravity = params
            .gravity
            .try_normalize()
            .ok_or_else(|| bad(format!("gravity {} has no direction", params.gravity)))?;
        let flow = (gravity + params.comb)
            .try_normalize()
            .ok_or_else(|| bad(format!("gravity + comb = {} has no direction", gravity + params.comb)))?;
        let l = params.layers as usize;
        // Sub-steps per layer of the march along each column (the path is smooth; 16 keep the
        // arc-length error far below a layer's spacing).
        const STEPS: usize = 16;
        let ds = params.length / (l * STEPS) as f64;
        let mut layers = vec![Vec::with_capacity(scalp.positions.len()); l + 1];
        for &root in &scalp.positions {
            let r0 = root - params.centre;
            let radius0 = r0.length();
            let mut dir = r0.try_normalize().unwrap_or(-gravity);
            let mut p = root;
            let mut hanging = dir.dot(gravity) >= 0.0;
            let mut s = 0.0;
            layers[0].push(root);
            for layer in layers.iter_mut().skip(1) {
                for _ in 0..STEPS {
                    s += ds;
                    if hanging {
                        p += gravity * ds;
                        if let Some(q) = head.and_then(|(h, clearance)| h.push_out(p, clearance)) {
                            p = q;
                        }
                        continue;
                    }
                    let radius = (radius0 + params.lift * s).max(1e-12);
                    // Turn towards the flow direction by ds / radius, about the axis between them
                    // (any perpendicular when they are opposite).
                    let axis =
                        dir.cross(flow).try_normalize().unwrap_or_else(|| dir.any_orthonormal_vector());
                    let angle = (ds / radius).min(dir.angle_between(flow));
                    dir = glam::DQuat::from_axis_angle(axis, angle).mul_vec3(dir).normalize();
                    p = params.centre + dir * radius;
                    if let Some(q) = head.and_then(|(h, clearance)| h.push_out(p, clearance)) {
                        p = q;
                    }
                    hanging = dir.dot(gravity) >= 0.0;
                }
                layer.push(p);
            }
        }
        Ok(Self { layers, faces: bundle_faces(scalp), uvs: scalp.uvs.clone(), tip_layers: None })
    }

    /// Builds the hair mesh from the scalp's morph targets: layer k is target k.
    pub fn from_morph_targets(scalp: &ScalpMesh) -> Result<Self> {
        if scalp.morph_layers.is_empty() {
            return Err(HairMeshError::InvalidParameter {
                what: "morph-target layers",
                message: "the scalp has no morph targets (one glTF morph target per layer)".into(),
            });
        }
        let mut layers = vec![scalp.positions.clone()];
        layers.extend(scalp.morph_layers.iter().cloned());
        Ok(Self { layers, faces: bundle_faces(scalp), uvs: scalp.uvs.clone(), tip_layers: None })
    }
}

fn polygon_normal(points: &[DVec3]) -> DVec3 {
    // Newell's method: robust for non-planar polygons.
    let mut n = DVec3::ZERO;
    for i in 0..points.len() {
        let (a, b) = (points[i], points[(i + 1) % points.len()]);
        n += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    n
}

/// Area-weighted vertex normals (the un-normalized Newell normal is twice the area times the
/// unit normal). A vertex whose faces cancel or have no area falls back to the direction from
/// the mesh centroid, then to +Y, so the result is always a unit vector.
pub fn vertex_normals(scalp: &ScalpMesh) -> Vec<DVec3> {
    let mut sums = vec![DVec3::ZERO; scalp.positions.len()];
    for face in &scalp.faces {
        let pts: Vec<DVec3> = face.iter().map(|&v| scalp.positions[v as usize]).collect();
        let n = polygon_normal(&pts);
        for &v in face {
            sums[v as usize] += n;
        }
    }
    let centroid = scalp.positions.iter().sum::<DVec3>() / scalp.positions.len().max(1) as f64;
    sums.iter()
        .zip(&scalp.positions)
        .map(|(s, p)| s.try_normalize().or_else(|| (*p - centroid).try_normalize()).unwrap_or(DVec3::Y))
        .collect()
}

/// Quads kept or recovered, triangles otherwise.
pub fn bundle_faces(scalp: &ScalpMesh) -> Vec<BundleFace> {
    let p = |v: u32| scalp.positions[v as usize];
    let mut quads = Vec::new();
    let mut triangles = Vec::new();
    for face in &scalp.faces {
        match face.len() {
            3 => triangles.push([face[0], face[1], face[2]]),
            4 => {
                let q = [face[0], face[1], face[2], face[3]];
                if quad_quality(q.map(p)).is_some() {
                    quads.push(q);
                } else if p(q[0]).distance(p(q[2])) <= p(q[1]).distance(p(q[3])) {
                    triangles.extend([[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
                } else {
                    triangles.extend([[q[0], q[1], q[3]], [q[1], q[2], q[3]]]);
                }
            }
            _ => triangles.extend((1..face.len() - 1).map(|k| [face[0], face[k], face[k + 1]])),
        }
    }
    // Candidate pairs across shared edges with consistent orientation, best quads first.
    let mut edge_owner = std::collections::HashMap::new();
    for (t, tri) in triangles.iter().enumerate() {
        for e in 0..3 {
            edge_owner.insert((tri[e], tri[(e + 1) % 3]), (t, e));
        }
    }
    let mut candidates = Vec::new();
    for (t, tri) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (x, y) = (tri[e], tri[(e + 1) % 3]);
            let Some(&(u, ue)) = edge_owner.get(&(y, x)) else { continue };
            if u <= t {
                continue;
            }
            let z_t = tri[(e + 2) % 3];
            let z_u = triangles[u][(ue + 2) % 3];
            let quad = [x, z_u, y, z_t];
            if let Some(quality) = quad_quality(quad.map(p)) {
                candidates.push((quality, t, u, quad));
            }
        }
    }
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut used = vec![false; triangles.len()];
    for (_, t, u, quad) in candidates {
        if !used[t] && !used[u] {
            used[t] = true;
            used[u] = true;
            quads.push(quad);
        }
    }
    let mut faces: Vec<BundleFace> = quads.into_iter().map(BundleFace::Quad).collect();
    faces.extend(triangles.iter().zip(&used).filter(|(_, u)| !**u).map(|(t, _)| BundleFace::Triangle(*t)));
    faces
}

/// `Some(quality)` for a near-planar (corner normals within ~20°) strictly convex quad, with
/// quality the smallest corner sine (1 for a rectangle); `None` otherwise.
fn quad_quality(q: [DVec3; 4]) -> Option<f64> {
    let n = polygon_normal(&q).try_normalize()?;
    let mut min_sine = f64::INFINITY;
    for i in 0..4 {
        let a = (q[(i + 3) % 4] - q[i]).try_normalize()?;
        let b = (q[(i + 1) % 4] - q[i]).try_normalize()?;
        let corner = b.cross(a);
        let sine = corner.dot(n);
        if sine <= 0.05 || corner.try_normalize()?.dot(n) < 0.94 {
            return None;
        }
        min_sine = min_sine.min(sine);
    }
    Some(min_sine)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An n×n grid in the XZ plane facing +Y, each cell as two triangles.
    fn triangulated_grid(n: u32, origin: DVec3, scale: f64) -> ScalpMesh {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                positions.push(origin + DVec3::new(f64::from(i), 0.0, -f64::from(j)) * scale);
            }
        }
        let mut faces = Vec::new();
        let id = |i: u32, j: u32| j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                faces.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                faces.push(vec![id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        ScalpMesh { positions, faces, ..Default::default() }
    }

    #[test]
    fn triangle_pairs_become_quads_again() {
        let grid = triangulated_grid(4, DVec3::ZERO, 1.0);
        let faces = bundle_faces(&grid);
        assert_eq!(faces.len(), 16);
        assert!(faces.iter().all(|f| matches!(f, BundleFace::Quad(_))));
    }

    #[test]
    fn extrusion_follows_normals_and_w_grows() {
        let grid = triangulated_grid(3, DVec3::ZERO, 1.0);
        for layers in [1, 4, 32] {
            let hm = HairMesh::extrude(
                &grid,
                &ExtrudeParams { layers, length: 2.0, droop: 0.0, gravity: DVec3::NEG_Y },
            )
            .expect("valid");
            assert_eq!(hm.layer_count(), layers as usize);
            let tip = hm.layers[layers as usize][0];
            assert!((tip - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-12, "{tip}");
            let w = hm.w();
            assert!((w[layers as usize][5] - 2.0).abs() < 1e-12);
            assert!(w.windows(2).all(|p| p[0].iter().zip(&p[1]).all(|(a, b)| b > a)));
        }
    }

    #[test]
    fn far_and_tiny_meshes_stay_finite() {
        for (origin, scale) in [(DVec3::splat(1e4), 1.0), (DVec3::ZERO, 1e-4), (DVec3::splat(-1e4), 1e-4)] {
            let grid = triangulated_grid(2, origin, scale);
            let normals = vertex_normals(&grid);
            assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-12 && n.y > 0.999), "{normals:?}");
            let hm = HairMesh::extrude(
                &grid,
                &ExtrudeParams { layers: 3, length: scale, droop: 0.5, gravity: DVec3::NEG_Y },
            )
            .expect("valid");
            assert!(hm.layers.iter().flatten().all(|p| p.is_finite()));
        }
    }

    #[test]
    fn degenerate_faces_get_fallback_normals() {
        // A zero-area triangle and a needle: unit normals anyway.
        let scalp = ScalpMesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0, DVec3::new(1.0, 1e-12, 0.0)],
            faces: vec![vec![0, 1, 2], vec![0, 1, 3]],
            ..Default::default()
        };
        assert!(vertex_normals(&scalp).iter().all(|n| (n.length() - 1.0).abs() < 1e-12));
        assert_eq!(bundle_faces(&scalp).len(), 2, "no quad made from degenerate triangles");
    }

    #[test]
    fn draped_hair_flows_over_the_head_and_hangs() {
        // A cap of a unit sphere around the origin: top and back hemisphere roots.
        let mut positions = Vec::new();
        for i in 0..=8 {
            for j in 0..=8 {
                let (theta, phi) =
                    (0.1 + 1.2 * f64::from(i) / 8.0, std::f64::consts::PI * f64::from(j) / 8.0);
                positions.push(DVec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin()));
            }
        }
        let faces = (0..8u32)
            .flat_map(|i| {
                (0..8u32).map(move |j| vec![i * 9 + j, i * 9 + j + 1, (i + 1) * 9 + j + 1, (i + 1) * 9 + j])
            })
            .collect();
        let scalp = ScalpMesh { positions, faces, ..Default::default() };
        let params = DrapeParams {
            layers: 8,
            length: 3.0,
            centre: DVec3::ZERO,
            lift: 0.05,
            gravity: DVec3::NEG_Y,
            comb: DVec3::new(0.0, 0.0, -2.0),
        };
        let hm = HairMesh::drape(&scalp, &params).expect("drape");
        for v in 0..hm.vertex_count() {
            let column = hm.column(v as u32);
            assert_eq!(column[0], scalp.positions[v]);
            // Never into the head, arc length = the hair length, the tip below the root.
            assert!(column.iter().all(|p| p.length() >= 1.0 - 1e-9), "{column:?}");
            let arc: f64 = column.windows(2).map(|p| p[0].distance(p[1])).sum();
            assert!(arc <= 3.0 * 1.01 && arc > 2.5, "arc {arc}");
            assert!(column[8].y < column[0].y - 1.0, "tip {} root {}", column[8], column[0]);
        }
        for bad in [
            DrapeParams { layers: 0, ..params },
            DrapeParams { length: f64::NAN, ..params },
            DrapeParams { lift: -1.0, ..params },
            DrapeParams { gravity: DVec3::ZERO, ..params },
            DrapeParams { comb: DVec3::Y, ..params },
        ] {
            assert!(HairMesh::drape(&scalp, &bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn bad_parameters_are_refused() {
        let grid = triangulated_grid(1, DVec3::ZERO, 1.0);
        for params in [
            ExtrudeParams { layers: 0, ..Default::default() },
            ExtrudeParams { layers: MAX_LAYERS + 1, ..Default::default() },
            ExtrudeParams { length: f64::NAN, ..Default::default() },
            ExtrudeParams { length: -1.0, ..Default::default() },
            ExtrudeParams { droop: f64::INFINITY, ..Default::default() },
        ] {
            assert!(HairMesh::extrude(&grid, &params).is_err(), "{params:?}");
        }
        assert!(HairMesh::from_morph_targets(&grid).is_err());
    }
}
