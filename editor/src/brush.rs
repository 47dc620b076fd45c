//! Hair brushes acting on the hair mesh, as in Blender's hair sculpting: a circle on the screen
//! picks the tips under it (weighted by a smooth falloff from its centre), and each dab moves
//! them; the columns bend under their tips with the roots fixed (the displacement falls off
//! along the length), the inner vertices follow and the head pushes out ([`crate::sculpt`]).
//!
//! - **Comb** drags the tips along the stroke.
//! - **Grab** holds the tips under the brush when the stroke starts and moves them with it.
//! - **Smooth** pulls each tip toward the mean of its neighbours' (along the hair mesh's faces).
//! - **Length** grows the columns (Shift: shrinks them) along their root-to-tip direction.
//! - **Puff** lifts the tips off the scalp along the direction the hair leaves it (Shift:
//!   flattens them toward it).
//!
//! UI-free: the viewport gives it the projection, the pointer and the stroke; tested without a
//! window.

use glam::{DVec3, Vec2, Vec3};
use hairmesh::HairMesh;

use crate::camera::Projection;
use crate::sculpt::falloff;

/// What a brush does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BrushKind {
    Comb,
    Grab,
    Smooth,
    Length,
    Puff,
}

impl BrushKind {
    pub const ALL: [Self; 5] = [Self::Comb, Self::Grab, Self::Smooth, Self::Length, Self::Puff];

    pub fn name(self) -> &'static str {
        match self {
            Self::Comb => "Comb",
            Self::Grab => "Grab",
            Self::Smooth => "Smooth",
            Self::Length => "Length",
            Self::Puff => "Puff",
        }
    }

    /// What it does, for a tooltip.
    pub fn hint(self) -> &'static str {
        match self {
            Self::Comb => "Drag the tips under the brush along the stroke; the roots stay",
            Self::Grab => "Hold the tips under the brush and move them with the pointer",
            Self::Smooth => "Even out the tips under the brush with their neighbours",
            Self::Length => "Grow the hair under the brush (Shift: shrink it)",
            Self::Puff => "Lift the hair under the brush off the scalp (Shift: flatten it)",
        }
    }
}

/// Share of the hair's length a full-strength Length or Puff dab moves a tip.
pub const STEP: f64 = 0.04;

/// The tips (column indices) under a brush of `radius` pixels at `centre` (viewport pixels),
/// with their weights; `tips` not finite are left out (hidden or facing away).
pub fn under_brush(projection: &Projection, tips: &[Vec3], centre: Vec2, radius: f32) -> Vec<(u32, f64)> {
    tips.iter()
        .enumerate()
        .filter_map(|(v, p)| {
            let (pixel, _) = projection.project(*p)?;
            let w = falloff(f64::from(pixel.distance(centre)), f64::from(radius));
            (w > 0.0).then_some((v as u32, w))
        })
        .collect()
}

/// Each face-neighbour of every vertex (vertices sharing a bundle face with it).
pub fn neighbours(mesh: &HairMesh) -> Vec<Vec<u32>> {
    let mut n: Vec<Vec<u32>> = vec![Vec::new(); mesh.vertex_count()];
    for face in &mesh.faces {
        let vs = face.vertices();
        for (i, &a) in vs.iter().enumerate() {
            for &b in [vs[(i + 1) % vs.len()], vs[(i + vs.len() - 1) % vs.len()]].iter() {
                if !n[a as usize].contains(&b) {
                    n[a as usize].push(b);
                }
            }
        }
    }
    n
}

/// One dab of an incremental brush (not Grab, which moves what it held at the start): the
/// tip displacement of each weighted column of `mesh`. `stroke` is the pointer's motion since
/// the last dab in the world (at the tips' depth), `strength` 0..=1, `invert` the Shift
/// variant, `hair_length` the scale of Length and Puff steps.
pub fn dab(
    kind: BrushKind,
    mesh: &HairMesh,
    weighted: &[(u32, f64)],
    stroke: DVec3,
    strength: f64,
    invert: bool,
    hair_length: f64,
) -> Vec<(u32, DVec3)> {
    let tip = mesh.layers.len() - 1;
    let sign = if invert { -1.0 } else { 1.0 };
    let neighbours = matches!(kind, BrushKind::Smooth).then(|| neighbours(mesh));
    weighted
        .iter()
        .map(|&(v, w)| {
            let at = mesh.layers[tip][v as usize];
            let root = mesh.layers[0][v as usize];
            let d = match kind {
                BrushKind::Comb | BrushKind::Grab => stroke * w * strength,
                BrushKind::Smooth => {
                    let around = neighbours.as_ref().map_or(&[][..], |n| &n[v as usize][..]);
                    if around.is_empty() {
                        DVec3::ZERO
                    } else {
                        let mean = around.iter().map(|&u| mesh.layers[tip][u as usize]).sum::<DVec3>()
                            / around.len() as f64;
                        (mean - at) * (w * strength).min(1.0)
                    }
                }
                BrushKind::Length => {
                    (at - root).normalize_or_zero() * (sign * STEP * hair_length * w * strength)
                }
                BrushKind::Puff => {
                    // The direction the hair leaves the scalp: root to the first layer.
                    let out = (mesh.layers[1.min(tip)][v as usize] - root).normalize_or_zero();
                    out * (sign * STEP * hair_length * w * strength)
                }
            };
            (v, d)
        })
        .filter(|(_, d)| d.length_squared() > 0.0)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sculpt::tests::cap;

    #[test]
    fn comb_moves_along_the_stroke_by_the_falloff() {
        let mesh = cap();
        let stroke = DVec3::new(0.01, 0.0, 0.0);
        let moved = dab(BrushKind::Comb, &mesh, &[(3, 1.0), (4, 0.5)], stroke, 1.0, false, 0.2);
        assert_eq!(moved, vec![(3, stroke), (4, stroke * 0.5)]);
    }

    #[test]
    fn smooth_pulls_an_outlier_back_toward_its_neighbours() {
        let mut mesh = cap();
        let tip = mesh.layers.len() - 1;
        let v = 40;
        let rest = mesh.layers[tip][v];
        mesh.layers[tip][v] += DVec3::new(0.05, 0.0, 0.0);
        let moved = dab(BrushKind::Smooth, &mesh, &[(v as u32, 1.0)], DVec3::ZERO, 0.5, false, 0.2);
        let (_, d) = moved[0];
        let after = mesh.layers[tip][v] + d;
        assert!(after.distance(rest) < mesh.layers[tip][v].distance(rest), "{after} vs {rest}");
    }

    #[test]
    fn length_grows_and_shrinks_along_the_column_and_puff_lifts_off_the_scalp() {
        let mesh = cap();
        let tip = mesh.layers.len() - 1;
        let v = 40u32;
        let along = (mesh.layers[tip][v as usize] - mesh.layers[0][v as usize]).normalize();
        let grow = dab(BrushKind::Length, &mesh, &[(v, 1.0)], DVec3::ZERO, 1.0, false, 0.2)[0].1;
        let shrink = dab(BrushKind::Length, &mesh, &[(v, 1.0)], DVec3::ZERO, 1.0, true, 0.2)[0].1;
        assert!((grow.dot(along) - STEP * 0.2).abs() < 1e-12 && (shrink + grow).length() < 1e-12);
        let out = (mesh.layers[1][v as usize] - mesh.layers[0][v as usize]).normalize();
        let puff = dab(BrushKind::Puff, &mesh, &[(v, 0.5)], DVec3::ZERO, 1.0, false, 0.2)[0].1;
        assert!((puff.dot(out) - 0.5 * STEP * 0.2).abs() < 1e-12);
    }

    #[test]
    fn only_tips_inside_the_circle_are_under_the_brush() {
        let mesh = cap();
        let tip = mesh.layers.len() - 1;
        let mut camera = crate::camera::OrbitCamera::default();
        let (lo, hi) = crate::sculpt::point_bounds(&mesh.layers[tip]);
        camera.frame(lo.as_vec3(), hi.as_vec3());
        let size = Vec2::new(400.0, 300.0);
        let projection = Projection::new(&camera, size);
        let tips: Vec<Vec3> = mesh.layers[tip].iter().map(|p| p.as_vec3()).collect();
        let under = under_brush(&projection, &tips, size / 2.0, 40.0);
        assert!(!under.is_empty() && under.len() < tips.len());
        for (v, w) in under {
            let (pixel, _) = projection.project(tips[v as usize]).expect("in view");
            assert!(pixel.distance(size / 2.0) < 40.0 && w > 0.0 && w <= 1.0);
        }
    }
}
