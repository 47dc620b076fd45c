//! Inner hair-mesh vertices placed from the outer ones, as in the hair-mesh papers: the user
//! shapes the hair mesh's surface — the tip layer and the columns on the border of the scalp
//! region — and the vertices inside the volume follow.
//!
//! The rule, in two parts, both on displacements from a rest mesh (the mesh when the edit
//! began):
//! 1. **Along each column**: an inner vertex moves by its column's root and tip moves,
//!    interpolated by its arc length `w` along the rest column (layer `k` of a straight column
//!    by `k / L` of the tip's move), so a dragged tip bends its column evenly.
//! 2. **Across the volume**: what the border columns do beyond that rule (a side of the hair
//!    pulled out) spreads inward harmonically: over the hair mesh's graph (each layer's face
//!    edges and each column's edges, weighted by the inverse of their rest length, so the result
//!    does not depend on units) the residual `r` solves `Σ_j w_ij (r_i − r_j) = 0` with the
//!    border's residuals given and zero at the roots and tips.
//!
//! So a constant move of the whole surface moves the inside by the same constant; the residual
//! is a weighted average of its neighbours' (the maximum principle), so nothing inside moves
//! further than the border pulled it, and degenerate input stays finite.
//!
//! The harmonic part is solved by conjugate gradients preconditioned with its diagonal,
//! warm-started from the last solution: while a drag goes on, each solve starts next to its
//! answer.

use glam::DVec3;

use crate::asset::VertexMove;
use crate::hair_mesh::HairMesh;

/// Relative residual at which the solve stops.
const TOLERANCE: f64 = 1e-10;

/// Which vertices of a hair mesh are outer (shaped by the user) and the factor-free system
/// that places the inner ones.
#[derive(Clone, Debug)]
pub struct InnerVertices {
    layers: usize,
    per_layer: usize,
    /// The rest positions displacements are measured from.
    rest: Vec<Vec<DVec3>>,
    /// Per layer per vertex: the fraction of its rest column's arc length below it.
    along: Vec<Vec<f64>>,
    /// Per graph vertex (layer-major): its unknown's index, or `None` for fixed vertices.
    unknown: Vec<Option<usize>>,
    /// Per unknown: the graph vertex.
    vertex_of: Vec<usize>,
    /// Per unknown: its neighbours (graph vertex, weight), and the sum of weights.
    neighbours: Vec<Vec<(usize, f64)>>,
    diagonal: Vec<f64>,
    /// The last solution (displacements of the unknowns), the next solve's start.
    last: Vec<DVec3>,
}

impl InnerVertices {
    /// The system of `rest`: its outer vertices are the tip layer, the roots, and every column
    /// on the border of the scalp region (a vertex of an edge that only one face uses).
    pub fn new(rest: &HairMesh) -> Self {
        let layers = rest.layers.len();
        let per_layer = rest.vertex_count();
        let outer = outer_vertices(rest);
        let id = |k: usize, v: usize| k * per_layer + v;
        let inner = |k: usize, v: usize| !outer[k][v];
        let mut unknown = vec![None; layers * per_layer];
        let mut vertex_of = Vec::new();
        for k in 0..layers {
            for v in 0..per_layer {
                if inner(k, v) {
                    unknown[id(k, v)] = Some(vertex_of.len());
                    vertex_of.push(id(k, v));
                }
            }
        }
        // Edges: face edges in every layer, column edges between layers.
        let mut edges: Vec<(usize, usize)> = Vec::new();
        for face in &rest.faces {
            let vs = face.vertices();
            for i in 0..vs.len() {
                let (a, b) = (vs[i] as usize, vs[(i + 1) % vs.len()] as usize);
                edges.extend((0..layers).map(|k| (id(k, a.min(b)), id(k, a.max(b)))));
            }
        }
        edges.sort_unstable();
        edges.dedup();
        edges.extend(
            (0..layers.saturating_sub(1)).flat_map(|k| (0..per_layer).map(move |v| (id(k, v), id(k + 1, v)))),
        );
        let position = |g: usize| rest.layers[g / per_layer][g % per_layer];
        let scale = extent(rest).max(f64::MIN_POSITIVE);
        let mut neighbours = vec![Vec::new(); vertex_of.len()];
        for &(a, b) in &edges {
            // Inverse rest length, with coincident vertices held to a tiny length of the mesh's size.
            let w = 1.0 / position(a).distance(position(b)).max(1e-9 * scale);
            if let Some(i) = unknown[a] {
                neighbours[i].push((b, w));
            }
            if let Some(j) = unknown[b] {
                neighbours[j].push((a, w));
            }
        }
        let diagonal =
            neighbours.iter().map(|n| n.iter().map(|(_, w)| w).sum::<f64>().max(f64::MIN_POSITIVE)).collect();
        let unknowns = vertex_of.len();
        let w = rest.w();
        let along = w
            .iter()
            .enumerate()
            .map(|(k, layer)| {
                layer
                    .iter()
                    .enumerate()
                    .map(|(v, &wk)| {
                        let total = w[layers - 1][v];
                        // A column of no length moves by layer index instead.
                        if total > 1e-12 * scale { wk / total } else { k as f64 / (layers - 1).max(1) as f64 }
                    })
                    .collect()
            })
            .collect();
        Self {
            layers,
            per_layer,
            rest: rest.layers.clone(),
            along,
            unknown,
            vertex_of,
            neighbours,
            diagonal,
            last: vec![DVec3::ZERO; unknowns],
        }
    }

    /// Is vertex `vertex` of layer `layer` outer (placed by the user)?
    pub fn is_outer(&self, layer: u32, vertex: u32) -> bool {
        let g = layer as usize * self.per_layer + vertex as usize;
        self.unknown.get(g).is_none_or(Option::is_none)
    }

    /// The fraction of vertex `vertex`'s rest column's arc length below layer `layer`: how much
    /// of its tip's move that layer follows under the column rule.
    pub fn along(&self, layer: u32, vertex: u32) -> f64 {
        self.along[layer as usize][vertex as usize]
    }

    /// How many vertices are inner (placed by [`InnerVertices::place`]).
    pub fn inner_count(&self) -> usize {
        self.vertex_of.len()
    }

    /// Where the inner vertices go for the outer vertices of `current` (a mesh of the same
    /// topology as the rest mesh): one move per inner vertex.
    pub fn place(&mut self, current: &HairMesh) -> Vec<VertexMove> {
        assert_eq!(current.layers.len(), self.layers, "the mesh's layers changed");
        let (per_layer, tip) = (self.per_layer, self.layers - 1);
        let displacement = |k: usize, v: usize| current.layers[k][v] - self.rest[k][v];
        // Part 1: the column rule; part 2 works on what is left of the fixed vertices' moves.
        let column_rule = |k: usize, v: usize| {
            let (root, top) = (displacement(0, v), displacement(tip, v));
            root + self.along[k][v] * (top - root)
        };
        let residual = |g: usize| {
            let (k, v) = (g / per_layer, g % per_layer);
            displacement(k, v) - column_rule(k, v)
        };
        let n = self.vertex_of.len();
        // b_i = Σ over fixed neighbours of w_ij r_j; A x = b with A_ii = Σ w, A_ij = −w.
        let b: Vec<DVec3> = self
            .neighbours
            .iter()
            .map(|ns| {
                ns.iter().filter(|(g, _)| self.unknown[*g].is_none()).map(|&(g, w)| w * residual(g)).sum()
            })
            .collect();
        let apply = |x: &[DVec3], out: &mut [DVec3]| {
            for i in 0..n {
                let mut sum = self.diagonal[i] * x[i];
                for &(g, w) in &self.neighbours[i] {
                    if let Some(j) = self.unknown[g] {
                        sum -= w * x[j];
                    }
                }
                out[i] = sum;
            }
        };
        let mut x = std::mem::take(&mut self.last);
        conjugate_gradients(&apply, &self.diagonal, &b, &mut x);
        let moves = (0..n)
            .map(|i| {
                let g = self.vertex_of[i];
                let (k, v) = (g / per_layer, g % per_layer);
                let position = self.rest[k][v] + column_rule(k, v) + x[i];
                VertexMove { layer: k as u32, vertex: v as u32, position }
            })
            .collect();
        self.last = x;
        moves
    }
}

/// Per layer per vertex: whether the vertex is outer — a root, on the tip layer, or in a column
/// on the border of the scalp region (a vertex of an edge that only one face uses) — shaped by
/// the user; the others are inner, placed by [`InnerVertices::place`].
pub fn outer_vertices(mesh: &HairMesh) -> Vec<Vec<bool>> {
    let layers = mesh.layers.len();
    let border = border_vertices(mesh);
    (0..layers).map(|k| border.iter().map(|&b| k == 0 || k + 1 == layers || b).collect()).collect()
}

/// Vertices on the border of the mesh's faces: those of an edge only one face uses.
fn border_vertices(mesh: &HairMesh) -> Vec<bool> {
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for face in &mesh.faces {
        let vs = face.vertices();
        for i in 0..vs.len() {
            let (a, b) = (vs[i], vs[(i + 1) % vs.len()]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    let mut border = vec![false; mesh.vertex_count()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i == 1 {
            border[edges[i].0 as usize] = true;
            border[edges[i].1 as usize] = true;
        }
        i = j;
    }
    // A vertex no face uses has nothing to follow: it keeps its place.
    let mut used = vec![false; mesh.vertex_count()];
    for face in &mesh.faces {
        for &v in face.vertices() {
            used[v as usize] = true;
        }
    }
    border.iter().zip(&used).map(|(&b, &u)| b || !u).collect()
}

fn extent(mesh: &HairMesh) -> f64 {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for p in mesh.layers.iter().flatten().filter(|p| p.is_finite()) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    if lo.x <= hi.x { (hi - lo).max_element() } else { 0.0 }
}

/// Solves `A x = b` (A symmetric positive definite, given by `apply`) for the three
/// coordinates at once, preconditioned with A's diagonal; `x` holds the start and the answer.
fn conjugate_gradients(
    apply: &dyn Fn(&[DVec3], &mut [DVec3]),
    diagonal: &[f64],
    b: &[DVec3],
    x: &mut [DVec3],
) {
    let n = b.len();
    if n == 0 {
        return;
    }
    let dot = |a: &[DVec3], c: &[DVec3]| -> DVec3 { a.iter().zip(c).map(|(p, q)| *p * *q).sum() };
    let mut r = vec![DVec3::ZERO; n];
    apply(x, &mut r);
    for i in 0..n {
        r[i] = b[i] - r[i];
    }
    let norm_b = dot(b, b).max(DVec3::splat(f64::MIN_POSITIVE));
    let mut z: Vec<DVec3> = r.iter().zip(diagonal).map(|(r, d)| *r / *d).collect();
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut ap = vec![DVec3::ZERO; n];
    // CG converges in at most n steps in exact arithmetic; the cap guards rounding.
    for _ in 0..(4 * n).max(64) {
        if (dot(&r, &r) / norm_b).max_element() < TOLERANCE * TOLERANCE {
            break;
        }
        apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        // Per coordinate; a coordinate already solved has p·Ap = 0 and stays.
        let alpha = DVec3::select(pap.cmpgt(DVec3::ZERO), rz / pap, DVec3::ZERO);
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
        }
        for i in 0..n {
            z[i] = r[i] / diagonal[i];
        }
        let rz_next = dot(&r, &z);
        let beta = DVec3::select(rz.cmpgt(DVec3::ZERO), rz_next / rz, DVec3::ZERO);
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
        rz = rz_next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hair_mesh::ExtrudeParams;

    /// A 6×6 grid of quads extruded into 4 layers: 16 interior columns × 3 inner layers.
    fn grid_mesh() -> HairMesh {
        let n = 6u32;
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                positions.push(DVec3::new(f64::from(i), 0.0, f64::from(j)) * 0.1);
            }
        }
        let id = |i: u32, j: u32| j * (n + 1) + i;
        let mut faces = Vec::new();
        for j in 0..n {
            for i in 0..n {
                faces.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let scalp = crate::ScalpMesh { positions, faces, ..Default::default() };
        HairMesh::extrude(
            &scalp,
            &ExtrudeParams { layers: 4, length: 0.5, droop: 0.0, gravity: DVec3::NEG_Y },
        )
        .expect("extrudes")
    }

    fn apply(mesh: &mut HairMesh, moves: &[VertexMove]) {
        for m in moves {
            mesh.layers[m.layer as usize][m.vertex as usize] = m.position;
        }
    }

    #[test]
    fn the_outer_vertices_are_the_tips_roots_and_border_columns() {
        let mesh = grid_mesh();
        let inner = InnerVertices::new(&mesh);
        // 5×5 interior vertices of a 7×7 grid, layers 1..=3 of 0..=4.
        assert_eq!(inner.inner_count(), 25 * 3);
        let centre = 3 * 7 + 3;
        assert!(inner.is_outer(4, centre) && inner.is_outer(0, centre) && !inner.is_outer(2, centre));
        assert!(inner.is_outer(2, 0), "a corner column is on the border");
    }

    #[test]
    fn a_constant_move_of_the_surface_moves_the_inside_by_the_same_offset() {
        let rest = grid_mesh();
        let mut inner = InnerVertices::new(&rest);
        let offset = DVec3::new(0.3, -0.2, 0.05);
        let mut moved = rest.clone();
        for (k, layer) in moved.layers.iter_mut().enumerate() {
            for (v, p) in layer.iter_mut().enumerate() {
                if inner.is_outer(k as u32, v as u32) {
                    *p += offset;
                }
            }
        }
        for m in inner.place(&moved) {
            let expected = rest.layers[m.layer as usize][m.vertex as usize] + offset;
            assert!(m.position.distance(expected) < 1e-9, "{m:?} vs {expected}");
        }
    }

    #[test]
    fn a_dragged_tip_bends_its_column_evenly() {
        let rest = grid_mesh();
        let mut inner = InnerVertices::new(&rest);
        let mut moved = rest.clone();
        let centre = 3 * 7 + 3;
        moved.layers[4][centre] += DVec3::new(0.4, 0.0, 0.0);
        let moves = inner.place(&moved);
        apply(&mut moved, &moves);
        // A straight column: layer k moves by k / L of the tip's move (second differences 0).
        let dx: Vec<f64> = (0..5).map(|k| moved.layers[k][centre].x - rest.layers[k][centre].x).collect();
        for (k, d) in dx.iter().enumerate() {
            assert!((d - 0.1 * k as f64).abs() < 1e-9, "{dx:?}");
        }
        // Other columns are shaped by their own tips.
        assert!(
            moves
                .iter()
                .filter(|m| m.vertex != centre as u32)
                .all(|m| { m.position.distance(rest.layers[m.layer as usize][m.vertex as usize]) < 1e-9 })
        );
    }

    #[test]
    fn a_pulled_border_column_moves_its_inner_neighbours_smoothly() {
        let rest = grid_mesh();
        let mut inner = InnerVertices::new(&rest);
        let mut moved = rest.clone();
        // Pull the middle of one side (x = 0, z = 0.3) outward in its inner layers only.
        let side = 3 * 7;
        for k in 1..4 {
            moved.layers[k][side].x -= 0.3;
        }
        let moves = inner.place(&moved);
        apply(&mut moved, &moves);
        let dx = |k: usize, v: usize| rest.layers[k][v].x - moved.layers[k][v].x;
        // Along the row into the volume the pull fades: monotonically, smoothly, never beyond it.
        let row: Vec<f64> = (0..7).map(|i| dx(2, side + i)).collect();
        assert!(
            (row[0] - 0.3).abs() < 1e-12 && row.windows(2).all(|w| w[1] < w[0] && w[1] >= -1e-12),
            "{row:?}"
        );
        let second = row.windows(3).map(|w| (w[0] - 2.0 * w[1] + w[2]).abs()).fold(0.0, f64::max);
        assert!(second < 0.2, "second differences {second} along {row:?}");
        // Roots and tips stay where they were; nothing moves beyond the pull.
        assert!(moves.iter().all(|m| m.layer > 0 && m.layer < 4));
        assert!(moves.iter().all(|m| {
            m.position.distance(rest.layers[m.layer as usize][m.vertex as usize]) <= 0.3 + 1e-12
        }));
    }

    #[test]
    fn degenerate_meshes_stay_finite() {
        let mut rest = grid_mesh();
        // Collapse a column and a whole layer onto single points.
        for k in 0..rest.layers.len() {
            rest.layers[k][10] = rest.layers[0][10];
        }
        let p = rest.layers[2][0];
        rest.layers[2].iter_mut().for_each(|q| *q = p);
        let mut inner = InnerVertices::new(&rest);
        let mut moved = rest.clone();
        moved.layers[4][24] += DVec3::splat(1e6);
        assert!(inner.place(&moved).iter().all(|m| m.position.is_finite()));
        // One layer: everything is outer, nothing to place.
        let flat = HairMesh { layers: rest.layers[..2].to_vec(), ..rest.clone() };
        assert!(InnerVertices::new(&flat).place(&flat).is_empty());
    }
}
