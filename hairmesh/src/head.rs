//! The head as a surface to keep hair out of: the signed distance of a point to a triangle
//! mesh (negative inside), found through a uniform grid of its triangles, with the sign from the
//! angle-weighted pseudo-normal of the nearest feature (face, edge or vertex; Bærentzen & Aanæs
//! 2005), which is exact for closed meshes. Scans are open (a bust cut at the chest, a head at
//! the neck): a point whose nearest feature is on the cut is beyond it, not inside, so it counts
//! as outside.

use std::collections::HashMap;

use glam::DVec3;

use crate::ScalpMesh;

/// Most grid cells along an axis.
const MAX_CELLS_PER_AXIS: usize = 64;

/// The nearest point of the surface to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nearest {
    pub point: DVec3,
    /// The outward pseudo-normal at that point (unit).
    pub normal: DVec3,
    /// Distance to the surface, negative inside.
    pub signed_distance: f64,
}

/// Which part of a triangle a nearest point lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Feature {
    Face,
    Edge(u32, u32),
    Vertex(u32),
}

/// A triangle mesh ready for distance queries.
#[derive(Clone, Debug)]
pub struct HeadSurface {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    face_normals: Vec<DVec3>,
    vertex_normals: Vec<DVec3>,
    edge_normals: HashMap<(u32, u32), DVec3>,
    /// Edges of one triangle only (the cut of an open scan), and their vertices.
    border_edges: std::collections::HashSet<(u32, u32)>,
    border_vertices: Vec<bool>,
    lo: DVec3,
    cell: f64,
    dims: [usize; 3],
    /// Per cell: the triangles whose bounds overlap it.
    cells: Vec<Vec<u32>>,
}

fn edge_key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl HeadSurface {
    /// The surface of `mesh` (polygons fanned into triangles).
    pub fn from_mesh(mesh: &ScalpMesh) -> Self {
        let triangles = mesh
            .faces
            .iter()
            .flat_map(|f| (1..f.len().saturating_sub(1)).map(move |i| [f[0], f[i], f[i + 1]]))
            .collect::<Vec<_>>();
        Self::new(mesh.positions.clone(), triangles)
    }

    /// The surface of `triangles` over `positions` (indices must be in range).
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Self {
        let corner = |t: &[u32; 3], i: usize| positions[t[i] as usize];
        let face_normals: Vec<DVec3> = triangles
            .iter()
            .map(|t| (corner(t, 1) - corner(t, 0)).cross(corner(t, 2) - corner(t, 0)).normalize_or_zero())
            .collect();
        let mut vertex_normals = vec![DVec3::ZERO; positions.len()];
        let mut edge_normals: HashMap<(u32, u32), DVec3> = HashMap::new();
        let mut edge_uses: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &triangles {
            for i in 0..3 {
                *edge_uses.entry(edge_key(t[i], t[(i + 1) % 3])).or_default() += 1;
            }
        }
        let border_edges: std::collections::HashSet<(u32, u32)> =
            edge_uses.into_iter().filter(|(_, n)| *n == 1).map(|(e, _)| e).collect();
        let mut border_vertices = vec![false; positions.len()];
        for &(a, b) in &border_edges {
            border_vertices[a as usize] = true;
            border_vertices[b as usize] = true;
        }
        for (t, n) in triangles.iter().zip(&face_normals) {
            for i in 0..3 {
                let (a, b, c) = (corner(t, i), corner(t, (i + 1) % 3), corner(t, (i + 2) % 3));
                let angle = (b - a).angle_between(c - a);
                if angle.is_finite() {
                    vertex_normals[t[i] as usize] += angle * *n;
                }
                *edge_normals.entry(edge_key(t[i], t[(i + 1) % 3])).or_default() += *n;
            }
        }
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for p in &positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if triangles.is_empty() || lo.x > hi.x {
            (lo, hi) = (DVec3::ZERO, DVec3::ZERO);
        }
        // About two triangles per occupied cell, at most MAX_CELLS_PER_AXIS along an axis.
        let size = (hi - lo).max(DVec3::splat(1e-12));
        let volume_per_triangle = size.x * size.y * size.z / triangles.len().max(1) as f64;
        let cell = volume_per_triangle.cbrt().max(size.max_element() / MAX_CELLS_PER_AXIS as f64) * 2.0;
        let dims = (size / cell).ceil().as_uvec3().max(glam::UVec3::ONE).to_array().map(|d| d as usize);
        let mut cells = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        let cell_of = |p: DVec3| -> [usize; 3] {
            let c = ((p - lo) / cell).floor();
            [0, 1, 2].map(|i| (c[i].max(0.0) as usize).min(dims[i] - 1))
        };
        for (i, t) in triangles.iter().enumerate() {
            let tri = [corner(t, 0), corner(t, 1), corner(t, 2)];
            let (a, b) = (cell_of(tri[0].min(tri[1]).min(tri[2])), cell_of(tri[0].max(tri[1]).max(tri[2])));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        cells[(z * dims[1] + y) * dims[0] + x].push(i as u32);
                    }
                }
            }
        }
        Self {
            positions,
            triangles,
            face_normals,
            vertex_normals,
            edge_normals,
            border_edges,
            border_vertices,
            lo,
            cell,
            dims,
            cells,
        }
    }

    /// The bounds of the surface.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let size = DVec3::new(self.dims[0] as f64, self.dims[1] as f64, self.dims[2] as f64) * self.cell;
        (self.lo, self.lo + size)
    }

    /// The size the margins and tolerances scale with: the diagonal of [`HeadSurface::bounds`].
    pub fn size(&self) -> f64 {
        let (lo, hi) = self.bounds();
        lo.distance(hi)
    }

    /// The nearest point of the surface to `p`; `None` for a surface without triangles or a
    /// non-finite `p`.
    pub fn nearest(&self, p: DVec3) -> Option<Nearest> {
        if self.triangles.is_empty() || !p.is_finite() {
            return None;
        }
        let c = ((p - self.lo) / self.cell).floor();
        let centre = [0, 1, 2].map(|i| (c[i].max(0.0) as usize).min(self.dims[i] - 1));
        let mut best: Option<(f64, DVec3, u32, Feature)> = None;
        let max_ring = self.dims.iter().copied().max().unwrap_or(1);
        for ring in 0..=max_ring {
            self.visit_ring(centre, ring, &mut |t| {
                let (q, feature) = closest_on_triangle(p, &self.triangles[t as usize], &self.positions);
                let d = p.distance_squared(q);
                if best.is_none_or(|(bd, ..)| d < bd) {
                    best = Some((d, q, t, feature));
                }
            });
            // Every cell beyond this ring is at least `ring` cells away.
            if best.is_some_and(|(d, ..)| d.sqrt() <= ring as f64 * self.cell) {
                break;
            }
        }
        let (d2, point, t, feature) = best?;
        let pseudo = match feature {
            Feature::Face => self.face_normals[t as usize],
            Feature::Edge(a, b) => self.edge_normals.get(&edge_key(a, b)).copied().unwrap_or_default(),
            Feature::Vertex(v) => self.vertex_normals[v as usize],
        };
        let normal = pseudo.try_normalize().unwrap_or(self.face_normals[t as usize]);
        let on_cut = match feature {
            Feature::Face => false,
            Feature::Edge(a, b) => self.border_edges.contains(&edge_key(a, b)),
            Feature::Vertex(v) => self.border_vertices[v as usize],
        };
        let outside = on_cut || (p - point).dot(normal) >= 0.0;
        let distance = d2.sqrt();
        let away = (p - point).try_normalize();
        // The direction out of the surface: from the nearest point to p when outside, the other
        // way inside; on the surface itself, the pseudo-normal.
        let normal = match away {
            Some(dir) if outside => dir,
            Some(dir) => -dir,
            None => normal,
        };
        Some(Nearest { point, normal, signed_distance: if outside { distance } else { -distance } })
    }

    /// Signed distance of `p` to the surface (negative inside; infinite without a surface).
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        self.nearest(p).map_or(f64::INFINITY, |n| n.signed_distance)
    }

    /// `p` moved out to `margin` above the surface when it is inside or closer than that;
    /// `None` when it is already clear. In a hollow a step out can come near another part of
    /// the surface, so it steps again (a few times at most).
    pub fn push_out(&self, p: DVec3, margin: f64) -> Option<DVec3> {
        let mut q = p;
        for _ in 0..8 {
            let n = self.nearest(q)?;
            if n.signed_distance >= margin * (1.0 - 1e-9) {
                break;
            }
            q = n.point + n.normal * margin;
        }
        (q != p).then_some(q)
    }

    fn visit_ring(&self, c: [usize; 3], ring: usize, visit: &mut dyn FnMut(u32)) {
        let range = |i: usize| {
            let lo = c[i].saturating_sub(ring);
            let hi = (c[i] + ring).min(self.dims[i] - 1);
            lo..=hi
        };
        let r = ring as isize;
        for z in range(2) {
            for y in range(1) {
                for x in range(0) {
                    let off =
                        [x as isize - c[0] as isize, y as isize - c[1] as isize, z as isize - c[2] as isize];
                    if off.iter().map(|o| o.abs()).max() != Some(r) {
                        continue;
                    }
                    for &t in &self.cells[(z * self.dims[1] + y) * self.dims[0] + x] {
                        visit(t);
                    }
                }
            }
        }
    }
}

/// The point of triangle `tri` nearest to `p` and the feature it lies on (Ericson, *Real-Time
/// Collision Detection*, 5.1.5).
fn closest_on_triangle(p: DVec3, tri: &[u32; 3], positions: &[DVec3]) -> (DVec3, Feature) {
    let [ia, ib, ic] = *tri;
    let (a, b, c) = (positions[ia as usize], positions[ib as usize], positions[ic as usize]);
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Vertex(ia));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Vertex(ib));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + v * ab, Feature::Edge(ia, ib));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Vertex(ic));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + w * ac, Feature::Edge(ia, ic));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + w * (c - b), Feature::Edge(ib, ic));
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        // A degenerate triangle: its nearest vertex.
        let nearest = [(a, ia), (b, ib), (c, ic)]
            .into_iter()
            .min_by(|x, y| x.0.distance_squared(p).total_cmp(&y.0.distance_squared(p)))
            .unwrap_or((a, ia));
        return (nearest.0, Feature::Vertex(nearest.1));
    }
    let (v, w) = (vb / denom, vc / denom);
    (a + ab * v + ac * w, Feature::Face)
}

/// Points sampled along each strand by [`check_strands`] (the root, on the scalp, not counted).
pub const CHECK_POINTS_PER_STRAND: u32 = 16;

/// How far a strand may dip into the head before it counts as entering it, as a fraction of the
/// head's size: roots sit on the scalp, and the surface is only as exact as its triangles.
pub const CHECK_TOLERANCE: f64 = 1e-3;

/// What [`check_strands`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StrandCheck {
    pub strands: u64,
    /// Strands with a point inside the head (deeper than the tolerance).
    pub entering: u64,
    /// The deepest point inside the head (0 when none is).
    pub deepest: f64,
    /// Hair-mesh vertices above the roots inside the head.
    pub vertices_inside: u64,
    /// Strands with a point in front of the face ([`crate::head_frame::HeadFrame::over_face`];
    /// 0 without a frame).
    pub over_face: u64,
}

/// Samples every strand of `asset` ([`CHECK_POINTS_PER_STRAND`] points, the CPU reference's
/// styled positions) and counts those that enter `head`, and those that hang in front of the
/// face of `frame`.
pub fn check_strands(
    asset: &crate::asset::HairAsset,
    head: &HeadSurface,
    frame: Option<&crate::head_frame::HeadFrame>,
) -> StrandCheck {
    use rayon::prelude::*;
    let tolerance = CHECK_TOLERANCE * head.size();
    let per_bundle: Vec<StrandCheck> = (0..asset.bundles.len() as u32)
        .into_par_iter()
        .map(|b| {
            let mut c = StrandCheck::default();
            for j in 0..asset.bundles[b as usize].strands {
                let root = asset.root_parameter(b, j);
                let mut over_face = false;
                let depth = (1..=CHECK_POINTS_PER_STRAND)
                    .map(|k| {
                        let p =
                            asset.strand_point(b, j, root, f64::from(k) / f64::from(CHECK_POINTS_PER_STRAND));
                        over_face |= frame.is_some_and(|f| f.over_face(p));
                        -head.signed_distance(p)
                    })
                    .fold(f64::NEG_INFINITY, f64::max);
                c.strands += 1;
                c.over_face += u64::from(over_face);
                if depth > tolerance {
                    c.entering += 1;
                    c.deepest = c.deepest.max(depth);
                }
            }
            c
        })
        .collect();
    let mut total = per_bundle.iter().fold(StrandCheck::default(), |a, c| StrandCheck {
        strands: a.strands + c.strands,
        entering: a.entering + c.entering,
        deepest: a.deepest.max(c.deepest),
        vertices_inside: 0,
        over_face: a.over_face + c.over_face,
    });
    total.vertices_inside = asset
        .mesh()
        .layers
        .iter()
        .skip(1)
        .flatten()
        .filter(|p| head.signed_distance(**p) < -tolerance)
        .count() as u64;
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed cube of 12 triangles, outward-facing, side 2 around the origin.
    fn cube() -> HeadSurface {
        let positions: Vec<DVec3> = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                )
            })
            .collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let faces = quads.iter().map(|q| q.to_vec()).collect();
        HeadSurface::from_mesh(&ScalpMesh { positions, faces, ..Default::default() })
    }

    #[test]
    fn signed_distances_of_a_cube_are_exact_inside_outside_and_at_corners() {
        let cube = cube();
        for (p, expected) in [
            (DVec3::ZERO, -1.0),
            (DVec3::new(0.5, 0.0, 0.0), -0.5),
            (DVec3::new(3.0, 0.0, 0.0), 2.0),
            (DVec3::new(0.0, -1.25, 0.0), 0.25),
            (DVec3::new(2.0, 2.0, 2.0), 3f64.sqrt()),
            (DVec3::new(2.0, 2.0, 0.0), 2f64.sqrt()),
            (DVec3::new(0.9, 0.9, 0.9), -0.1),
        ] {
            let d = cube.signed_distance(p);
            assert!((d - expected).abs() < 1e-12, "{p}: {d}, expected {expected}");
        }
    }

    #[test]
    fn points_are_pushed_out_to_the_margin_along_the_surface_normal() {
        let cube = cube();
        let out = cube.push_out(DVec3::new(0.8, 0.1, 0.0), 0.05).expect("inside");
        assert!(out.distance(DVec3::new(1.05, 0.1, 0.0)) < 1e-12, "{out}");
        assert!(cube.push_out(DVec3::new(1.2, 0.0, 0.0), 0.05).is_none());
        let near = cube.push_out(DVec3::new(1.01, 0.0, 0.0), 0.05).expect("too close");
        assert!((cube.signed_distance(near) - 0.05).abs() < 1e-12);
    }

    #[test]
    fn beyond_the_cut_of_an_open_mesh_is_outside() {
        // The cube without its bottom (y = −1) face: a box open below.
        let positions: Vec<DVec3> = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                )
            })
            .collect();
        let quads = [[4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let faces = quads.iter().map(|q| q.to_vec()).collect::<Vec<Vec<u32>>>();
        let open = HeadSurface::from_mesh(&ScalpMesh {
            positions,
            faces: vec![vec![2, 6, 7, 3]].into_iter().chain(faces).collect(),
            ..Default::default()
        });
        assert!(open.signed_distance(DVec3::new(0.0, 0.5, 0.0)) < 0.0, "inside, near the top");
        assert!(open.signed_distance(DVec3::new(0.0, -1.5, 0.0)) > 0.0, "below the open bottom");
        assert!(open.signed_distance(DVec3::new(0.5, -1.2, 0.0)) > 0.0);
    }

    #[test]
    fn the_grid_finds_what_brute_force_finds_on_a_head() {
        let head = crate::procedural::head_cap(12, 48);
        let surface = HeadSurface::from_mesh(&head);
        let (lo, hi) = surface.bounds();
        let mut rng = crate::rng::SplitMix64::new(7);
        for _ in 0..500 {
            let t = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.6 - 0.3;
            let p = lo + (hi - lo) * t;
            let fast = surface.nearest(p).expect("nearest").point.distance(p);
            let brute = surface
                .triangles
                .iter()
                .map(|tri| closest_on_triangle(p, tri, &surface.positions).0.distance(p))
                .fold(f64::INFINITY, f64::min);
            assert!((fast - brute).abs() < 1e-12, "{p}: grid {fast}, brute force {brute}");
        }
        assert!(HeadSurface::new(Vec::new(), Vec::new()).nearest(DVec3::ZERO).is_none());
        assert!(surface.nearest(DVec3::NAN).is_none());
    }
}
