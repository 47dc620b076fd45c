//! Moving hair-mesh tips: the selected columns, their mirrors and a soft selection around them
//! move their tips by a transform (a drag's translation, or a grab, rotation or scale,
//! [`crate::transform`]); every outer column bends evenly under its tip, and the inner vertices
//! follow the surface ([`hairmesh::inner`]). With the head known, every moved vertex is kept a margin
//! outside it ([`hairmesh::head`]). Kept apart from the UI so it is tested without one.

use std::sync::Arc;

use glam::{DAffine3, DVec3};
use hairmesh::HairMesh;
use hairmesh::asset::VertexMove;
use hairmesh::head::HeadSurface;
use hairmesh::inner::InnerVertices;
use serde::{Deserialize, Serialize};

/// How far outside the head moved vertices are kept, as a fraction of the head's size.
pub const HEAD_MARGIN: f64 = 0.005;

/// One column taking part in a drag.
#[derive(Clone, Debug)]
struct Column {
    vertex: u32,
    /// How much of the drag it follows (1 for the dragged one, the falloff for the rest).
    weight: f64,
    /// Mirrored across x = 0 (it follows the drag with x negated).
    mirrored: bool,
}

/// How an edit of the tips was made, enough to make it again on the same mesh
/// ([`Sculpt::moves`]): what a session records for a drag or a G/R/S.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sculpt {
    /// The columns moved by `transform` (their tips), each `true` when it does the mirror
    /// image (a twin across x = 0).
    pub seeds: Vec<(u32, bool)>,
    /// Tips this close to a seed follow by [`falloff`] (file units).
    pub soft_radius: f64,
    /// What the seeds' tips undergo.
    pub transform: DAffine3,
    /// Kept out of the head (when the document has one).
    pub outside_head: bool,
    /// What mirrored seeds are mirrored across.
    #[serde(default)]
    pub mirror: MirrorPlane,
    /// The layer the transform takes hold of (`None`: the tips; [`TipDrag::at_layer`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layer: Option<u32>,
}

impl Sculpt {
    /// The edit made again on `mesh` (the mesh it was made on), kept out of `head` when it
    /// was.
    pub fn moves(&self, mesh: &HairMesh, head: Option<Arc<HeadSurface>>) -> Vec<VertexMove> {
        let mut drag =
            TipDrag::with_seeds(mesh, &self.seeds, self.soft_radius, self.layer).across(self.mirror);
        if let (true, Some(head)) = (self.outside_head, head) {
            drag = drag.outside(head);
        }
        drag.moves_with(&self.transform)
    }
}

/// A drag of one tip (with its mirror and soft selection), from the mesh at its start. With a
/// layer handle ([`TipDrag::at_layer`]) it takes hold of that layer instead: the layer and
/// those above it undergo the transform, the ones below bend under it by the column rule.
#[derive(Clone, Debug)]
pub struct TipDrag {
    seeds: Vec<(u32, bool)>,
    soft_radius: f64,
    /// The layer held (`None`: the tips).
    layer: Option<u32>,
    mirror: MirrorPlane,
    rest: HairMesh,
    columns: Vec<Column>,
    inner: InnerVertices,
    /// The head to keep out of, and the margin.
    head: Option<(Arc<HeadSurface>, f64)>,
}

/// Smooth falloff from 1 at the centre to 0 at `radius` (Blender's "smooth" soft selection).
pub fn falloff(distance: f64, radius: f64) -> f64 {
    if radius <= 0.0 {
        return if distance <= 0.0 { 1.0 } else { 0.0 };
    }
    let t = (1.0 - distance / radius).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The axis-aligned bounds of `points` (inverted, infinite ones for none).
pub fn point_bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
}

/// A mirror: the plane through `point` with unit `normal` — the head's plane of symmetry
/// ([`MirrorPlane::of_head`]), or x = 0 without a head.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MirrorPlane {
    pub point: DVec3,
    pub normal: DVec3,
}

impl Default for MirrorPlane {
    fn default() -> Self {
        Self { point: DVec3::ZERO, normal: DVec3::X }
    }
}

impl MirrorPlane {
    /// The plane a head is symmetric across: through its centre, normal to its right.
    pub fn of_head(frame: &hairmesh::head_frame::HeadFrame) -> Self {
        Self { point: frame.centre, normal: frame.right() }
    }

    /// `p` seen in the mirror.
    pub fn reflect(&self, p: DVec3) -> DVec3 {
        p - self.normal * (2.0 * (p - self.point).dot(self.normal))
    }

    /// The reflection as an affine map.
    pub fn affine(&self) -> DAffine3 {
        let n = self.normal;
        let householder = glam::DMat3::IDENTITY - 2.0 * glam::DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        DAffine3::from_translation(self.point)
            * DAffine3::from_mat3(householder)
            * DAffine3::from_translation(-self.point)
    }
}

/// The outer-layer vertex whose root mirrors `v`'s across `plane` (within 1 % of the scalp's
/// size), if it is another vertex.
pub fn mirror_vertex(mesh: &HairMesh, v: u32, plane: &MirrorPlane) -> Option<u32> {
    let roots = &mesh.layers[0];
    let p = roots.get(v as usize)?;
    let target = plane.reflect(*p);
    let (lo, hi) = point_bounds(roots);
    let tolerance = 0.01 * lo.distance(hi);
    let (best, d) = roots
        .iter()
        .enumerate()
        .map(|(i, q)| (i as u32, q.distance(target)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    (d <= tolerance && best != v).then_some(best)
}

/// `a` seen in the mirror `plane` (what a mirrored column does when its twin does `a`).
fn mirrored(a: &DAffine3, plane: &MirrorPlane) -> DAffine3 {
    let m = plane.affine();
    m * *a * m
}

/// The layer `layer` asks a drag to hold (`None`: the tips, also for the outer layer) and the
/// columns that take part: the seeds and, within `soft_radius` of a seed at that layer, the
/// columns around them by [`falloff`].
fn held_columns(
    mesh: &HairMesh,
    seeds: &[(u32, bool)],
    soft_radius: f64,
    layer: Option<u32>,
) -> (Option<u32>, Vec<Column>) {
    let last = mesh.layers.len() - 1;
    let held = layer.map_or(last, |l| (l as usize).clamp(1, last.max(1)));
    let at = &mesh.layers[held];
    let mut weights: Vec<(f64, bool)> = vec![(0.0, false); mesh.vertex_count()];
    for &(centre, mirrored) in seeds {
        let Some(&c) = at.get(centre as usize) else { continue };
        for (v, p) in at.iter().enumerate() {
            let w = falloff(p.distance(c), soft_radius);
            if w > weights[v].0 {
                weights[v] = (w, mirrored);
            }
        }
    }
    let columns = weights
        .iter()
        .enumerate()
        .filter(|(_, (w, _))| *w > 0.0)
        .map(|(v, &(weight, mirrored))| Column { vertex: v as u32, weight, mirrored })
        .collect();
    ((held != last).then_some(held as u32), columns)
}

impl TipDrag {
    /// Starts dragging the tip of `vertex` (and of `mirror`, mirrored) of `mesh`; tips within
    /// `soft_radius` of a dragged tip follow with [`falloff`].
    pub fn new(mesh: &HairMesh, vertex: u32, mirror: Option<u32>, soft_radius: f64) -> Self {
        let seeds: Vec<(u32, bool)> =
            std::iter::once((vertex, false)).chain(mirror.map(|m| (m, true))).collect();
        Self::with_seeds(mesh, &seeds, soft_radius, None)
    }

    /// Starts moving the tips of the `selected` columns of `mesh` (with `mirror_of`'s twins,
    /// mirrored, where a twin is not selected itself); tips within `soft_radius` of a selected
    /// tip follow with [`falloff`].
    pub fn selection(
        mesh: &HairMesh,
        selected: &[u32],
        mirror_of: impl Fn(u32) -> Option<u32>,
        soft_radius: f64,
    ) -> Self {
        let mut seeds: Vec<(u32, bool)> = selected.iter().map(|&v| (v, false)).collect();
        for &v in selected {
            if let Some(m) = mirror_of(v).filter(|m| !selected.contains(m)) {
                seeds.push((m, true));
            }
        }
        Self::with_seeds(mesh, &seeds, soft_radius, None)
    }

    /// The same drag holding layer `layer` (1..=L; the tips at L) of the columns instead of
    /// their tips: soft selection measured there too.
    #[must_use]
    pub fn at_layer(mut self, layer: u32) -> Self {
        let (held, columns) = held_columns(&self.rest, &self.seeds, self.soft_radius, Some(layer));
        self.layer = held;
        self.columns = columns;
        self
    }

    /// The layer the drag holds (the outer one for the tips).
    fn held_layer(&self) -> usize {
        self.layer.map_or(self.rest.layers.len() - 1, |l| l as usize)
    }

    fn with_seeds(mesh: &HairMesh, seeds: &[(u32, bool)], soft_radius: f64, layer: Option<u32>) -> Self {
        let (layer, columns) = held_columns(mesh, seeds, soft_radius, layer);
        Self {
            seeds: seeds.to_vec(),
            soft_radius,
            layer,
            mirror: MirrorPlane::default(),
            rest: mesh.clone(),
            columns,
            inner: InnerVertices::new(mesh),
            head: None,
        }
    }

    /// Mirrored seeds do the mirror image across `plane` (x = 0 unless set).
    #[must_use]
    pub fn across(mut self, plane: MirrorPlane) -> Self {
        self.mirror = plane;
        self
    }

    /// Keeps every moved vertex [`HEAD_MARGIN`] × the head's size outside `head`.
    #[must_use]
    pub fn outside(mut self, head: Arc<HeadSurface>) -> Self {
        let margin = HEAD_MARGIN * head.size();
        self.head = Some((head, margin));
        self
    }

    /// How `transform` applied by this drag was made ([`Sculpt::moves`] makes it again).
    pub fn recipe(&self, transform: DAffine3) -> Sculpt {
        Sculpt {
            seeds: self.seeds.clone(),
            soft_radius: self.soft_radius,
            transform,
            outside_head: self.head.is_some(),
            mirror: self.mirror,
            layer: self.layer,
        }
    }

    /// Vertices the drag moves (for highlighting).
    pub fn columns(&self) -> impl Iterator<Item = u32> + '_ {
        self.columns.iter().map(|c| c.vertex)
    }

    /// The moves for the dragged tip displaced by `delta` from where it started: every
    /// column's vertices above the root (outer ones by the column rule, inner ones placed by
    /// the surface).
    pub fn moves(&mut self, delta: DVec3) -> Vec<VertexMove> {
        self.moves_with(&DAffine3::from_translation(delta))
    }

    /// The moves for the tips of the selection carried by `transform` from where they started
    /// (a soft-selected tip by its weight's share of that displacement, a mirrored one by the
    /// mirrored transform).
    pub fn moves_with(&mut self, transform: &DAffine3) -> Vec<VertexMove> {
        let mirror = mirrored(transform, &self.mirror);
        self.moves_for(|c, from| {
            let to =
                if c.mirrored { mirror.transform_point3(from) } else { transform.transform_point3(from) };
            (to - from) * c.weight
        })
    }

    /// The moves for each column's tip displaced by its own amount (a brush dab; columns not
    /// listed stay).
    pub fn moves_by(&mut self, displacements: &[(u32, DVec3)]) -> Vec<VertexMove> {
        let by: std::collections::HashMap<u32, DVec3> = displacements.iter().copied().collect();
        self.moves_for(|c, _| by.get(&c.vertex).copied().unwrap_or(DVec3::ZERO))
    }

    /// Starts moving the tips of `weighted` columns of `mesh`, each by its weight's share of a
    /// transform (a grab brush's hold) or by its own displacement ([`TipDrag::moves_by`]).
    pub fn weighted(mesh: &HairMesh, weighted: &[(u32, f64)]) -> Self {
        let columns = weighted
            .iter()
            .filter(|(v, w)| (*v as usize) < mesh.vertex_count() && *w > 0.0)
            .map(|&(vertex, weight)| Column { vertex, weight, mirrored: false })
            .collect();
        Self {
            seeds: Vec::new(),
            soft_radius: 0.0,
            layer: None,
            mirror: MirrorPlane::default(),
            rest: mesh.clone(),
            columns,
            inner: InnerVertices::new(mesh),
            head: None,
        }
    }

    /// Every column's vertices above the root for the tip displacement `tip_move` gives it
    /// (outer ones by the column rule, inner ones placed by the surface), pushed out of the
    /// head.
    fn moves_for(&mut self, tip_move: impl Fn(&Column, DVec3) -> DVec3) -> Vec<VertexMove> {
        let tip = self.rest.layers.len() - 1;
        let held = self.held_layer();
        let mut mesh = self.rest.clone();
        let mut moves = Vec::new();
        for c in &self.columns {
            let v = c.vertex as usize;
            let d = tip_move(c, self.rest.layers[held][v]);
            let reach = self.inner.along(held as u32, c.vertex);
            for k in 1..=tip {
                // At and above the held layer each vertex undergoes the transform itself; below
                // it, the column bends by its share of the held vertex's move.
                let step = if k >= held {
                    tip_move(c, self.rest.layers[k][v])
                } else if reach > 0.0 {
                    d * (self.inner.along(k as u32, c.vertex) / reach)
                } else {
                    DVec3::ZERO
                };
                let position = self.rest.layers[k][v] + step;
                mesh.layers[k][c.vertex as usize] = position;
                if self.inner.is_outer(k as u32, c.vertex) {
                    moves.push(VertexMove { layer: k as u32, vertex: c.vertex, position });
                }
            }
        }
        moves.extend(self.inner.place(&mesh));
        if let Some((head, margin)) = &self.head {
            for m in &mut moves {
                if let Some(out) = head.push_out(m.position, *margin) {
                    m.position = out;
                }
            }
        }
        moves
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Short hair extruded from the project's head cap, for the sculpting tests.
    pub(crate) fn cap() -> HairMesh {
        let scalp = hairmesh::procedural::head_cap(6, 24);
        HairMesh::extrude(&scalp, &hairmesh::ExtrudeParams { layers: 4, length: 0.2, ..Default::default() })
            .expect("extrudes")
    }

    /// Holding a layer: it and the layers above undergo the transform, the ones below bend by
    /// their share of the held vertex's move, the roots stay; the recipe makes it again.
    #[test]
    fn a_held_layer_takes_the_transform_and_the_column_bends_below_it() {
        // A strip of quads: every column is on the hair mesh's surface (outer).
        let positions: Vec<DVec3> =
            (0..2).flat_map(|j| (0..4).map(move |i| DVec3::new(f64::from(i), 0.0, -f64::from(j)))).collect();
        let faces = (0..3u32).map(|i| vec![i, i + 1, i + 5, i + 4]).collect();
        let scalp = hairmesh::ScalpMesh { positions, faces, ..Default::default() };
        let mesh = HairMesh::extrude(
            &scalp,
            &hairmesh::ExtrudeParams { layers: 4, length: 2.0, ..Default::default() },
        )
        .expect("extrudes");
        let selected = [1u32, 2, 5, 6];
        let mut drag = TipDrag::selection(&mesh, &selected, |_| None, 0.0).at_layer(2);
        let pivot = selected.iter().map(|&v| mesh.layers[2][v as usize]).sum::<DVec3>() / 4.0;
        let scale = DAffine3::from_translation(pivot)
            * DAffine3::from_scale(DVec3::splat(0.5))
            * DAffine3::from_translation(-pivot);
        let moves = drag.moves_with(&scale);
        let inner = InnerVertices::new(&mesh);
        let at =
            |layer: u32, v: u32| moves.iter().find(|m| m.layer == layer && m.vertex == v).map(|m| m.position);
        for &v in &selected {
            for k in 2..=4u32 {
                let expected = scale.transform_point3(mesh.layers[k as usize][v as usize]);
                let got = at(k, v).expect("a moved vertex");
                assert!(got.distance(expected) < 1e-12, "layer {k} of column {v}: {got} vs {expected}");
            }
            let d2 = at(2, v).expect("held") - mesh.layers[2][v as usize];
            let share = inner.along(1, v) / inner.along(2, v);
            let got = at(1, v).expect("below");
            assert!(got.distance(mesh.layers[1][v as usize] + d2 * share) < 1e-12, "layer 1 of column {v}");
            assert!(moves.iter().all(|m| m.layer > 0), "a root moved");
        }
        let recipe = drag.recipe(scale);
        assert_eq!(recipe.layer, Some(2));
        assert_eq!(recipe.moves(&mesh, None), moves, "the session's recipe makes the same moves");
        // Holding the outer layer is holding the tips.
        assert_eq!(TipDrag::selection(&mesh, &selected, |_| None, 0.0).at_layer(4).recipe(scale).layer, None);
    }

    #[test]
    fn a_grab_into_the_head_leaves_every_vertex_outside_it() {
        let scalp = hairmesh::procedural::head_cap(6, 24);
        let mesh = HairMesh::extrude(
            &scalp,
            &hairmesh::ExtrudeParams { layers: 4, length: 0.05, ..Default::default() },
        )
        .expect("extrudes");
        let head = Arc::new(HeadSurface::from_mesh(&scalp));
        let margin = HEAD_MARGIN * head.size();
        let tip = mesh.layers.len() - 1;
        // The topmost tip, dragged down through the crown with a wide soft selection.
        let v = (0..mesh.vertex_count())
            .max_by(|&a, &b| mesh.layers[tip][a].y.total_cmp(&mesh.layers[tip][b].y))
            .expect("tips") as u32;
        let mut free = TipDrag::new(&mesh, v, None, 0.06);
        let mut kept = TipDrag::new(&mesh, v, None, 0.06).outside(head.clone());
        let grab = DVec3::new(0.0, -0.15, 0.0);
        let inside = free.moves(grab).iter().filter(|m| head.signed_distance(m.position) < 0.0).count();
        assert!(inside > 10, "the grab should drive the mesh into the head ({inside} vertices)");
        let moves = kept.moves(grab);
        let worst = moves.iter().map(|m| head.signed_distance(m.position)).fold(f64::INFINITY, f64::min);
        assert!(worst >= margin - 1e-9, "a vertex {worst} from the head, margin {margin}");
    }

    #[test]
    fn a_selection_scaled_about_its_centre_gathers_its_tips_and_mirrors_them() {
        let mesh = cap();
        let tip = mesh.layers.len() - 1;
        let selected: Vec<u32> = (30..38).collect();
        let tips: Vec<DVec3> = selected.iter().map(|&v| mesh.layers[tip][v as usize]).collect();
        let centre = tips.iter().sum::<DVec3>() / tips.len() as f64;
        let gather = DAffine3::from_translation(centre)
            * DAffine3::from_scale(DVec3::splat(0.25))
            * DAffine3::from_translation(-centre);
        let mirror_of = |v: u32| mirror_vertex(&mesh, v, &MirrorPlane::default());
        let mut edit = TipDrag::selection(&mesh, &selected, mirror_of, 0.0);
        let moves = edit.moves_with(&gather);
        for (&v, p) in selected.iter().zip(&tips) {
            let moved = moves.iter().find(|m| m.vertex == v && m.layer as usize == tip).expect("moved");
            let expected = centre + (*p - centre) * 0.25;
            assert!(moved.position.distance(expected) < 1e-12, "{v}: {} vs {expected}", moved.position);
        }
        // A twin outside the selection does the mirror image.
        let (v, twin) = selected
            .iter()
            .find_map(|&v| mirror_of(v).filter(|m| !selected.contains(m)).map(|m| (v, m)))
            .expect("a twin outside the selection");
        let at = |vertex: u32| {
            moves.iter().find(|m| m.vertex == vertex && m.layer as usize == tip).map(|m| m.position)
        };
        let (a, b) = (at(v).expect("moved"), at(twin).expect("twin moved"));
        assert!(DVec3::new(-a.x, a.y, a.z).distance(b) < 1e-9, "{a} vs {b}");
    }

    #[test]
    fn a_mirror_plane_reflects_points_and_transforms() {
        let plane =
            MirrorPlane { point: DVec3::new(1.0, 0.0, 0.0), normal: DVec3::new(1.0, 1.0, 0.0).normalize() };
        let p = DVec3::new(2.0, 3.0, -1.0);
        assert!(plane.reflect(plane.reflect(p)).distance(p) < 1e-12);
        assert!(plane.affine().transform_point3(p).distance(plane.reflect(p)) < 1e-12);
        // A translation's mirror image moves the reflected point by the reflected offset.
        let shift = DAffine3::from_translation(DVec3::new(0.1, 0.0, 0.0));
        let q = mirrored(&shift, &plane).transform_point3(plane.reflect(p));
        assert!(q.distance(plane.reflect(p + DVec3::new(0.1, 0.0, 0.0))) < 1e-12);
    }

    #[test]
    fn falloff_is_one_at_the_centre_and_zero_at_the_radius() {
        assert_eq!(falloff(0.0, 1.0), 1.0);
        assert_eq!(falloff(1.0, 1.0), 0.0);
        assert!((falloff(0.5, 1.0) - 0.5).abs() < 1e-12);
        assert_eq!((falloff(0.0, 0.0), falloff(0.1, 0.0)), (1.0, 0.0));
    }

    #[test]
    fn a_drag_without_soft_selection_moves_one_column_evenly() {
        let mesh = cap();
        let v = 40;
        let mut drag = TipDrag::new(&mesh, v, None, 0.0);
        let d = DVec3::new(0.05, 0.0, 0.0);
        let moves = drag.moves(d);
        let tip = mesh.layers.len() - 1;
        let moved_tip =
            moves.iter().find(|m| m.vertex == v && m.layer as usize == tip).expect("the tip moves");
        assert!(moved_tip.position.distance(mesh.layers[tip][v as usize] + d) < 1e-12);
        for m in &moves {
            let moved = m.position.distance(mesh.layers[m.layer as usize][m.vertex as usize]);
            if m.vertex == v {
                assert!(moved <= d.length() + 1e-12);
            } else {
                assert!(moved < 1e-9, "{m:?} moved {moved}");
            }
        }
    }

    #[test]
    fn soft_selection_moves_neighbours_less_and_a_mirror_mirrored() {
        let mesh = cap();
        let tip = mesh.layers.len() - 1;
        let v = 40;
        let radius = 0.05;
        let mut drag = TipDrag::new(&mesh, v, Some(41), radius);
        assert!(drag.columns().count() > 2, "the soft selection holds neighbours");
        let d = DVec3::new(0.0, 0.03, 0.0);
        let moves = drag.moves(d);
        let tips: Vec<&VertexMove> = moves.iter().filter(|m| m.layer as usize == tip).collect();
        for m in &tips {
            let moved = m.position.distance(mesh.layers[tip][m.vertex as usize]);
            assert!(moved <= d.length() + 1e-12);
        }
        assert!(tips.iter().any(|m| {
            let moved = m.position.distance(mesh.layers[tip][m.vertex as usize]);
            moved > 1e-6 && moved < d.length() - 1e-6
        }));
        assert!(moves.iter().all(|m| m.position.is_finite() && m.layer > 0));
    }
}
