//! Painting the scalp: a brush on the screen selects the head's faces under it (those facing
//! the camera and not hidden by the head itself), or removes them; the selection becomes a
//! `faces:` scalp selector ([`hairmesh::ScalpSelector::Faces`]), which the conversion and the
//! asset's provenance keep, so re-converting gives the same scalp. UI-free, so it is tested
//! without a window.

use glam::{DVec3, Vec2, Vec3};
use hairmesh::head_frame::{HAIRLINE_OFFSET, HeadFrame};
use hairmesh::{ScalpMesh, ScalpSelector};

use crate::camera::{DepthGrid, Projection};

/// How far behind the head's own depth a face centroid may lie and still count as seen (a
/// fraction of its depth: the depth grid is coarse).
const DEPTH_TOLERANCE: f32 = 0.01;

/// The head's faces and which of them are scalp.
#[derive(Clone, Debug)]
pub struct ScalpPaint {
    /// The file's faces as imported ([`hairmesh::import::load_faces`]).
    pub mesh: ScalpMesh,
    centroids: Vec<DVec3>,
    normals: Vec<DVec3>,
    pub selected: Vec<bool>,
}

impl ScalpPaint {
    /// The faces of `mesh` with `selector`'s selection to start from (`auto`: the hairline
    /// `frame` suggests, the frame estimated from `mesh` when not given).
    pub fn new(mesh: ScalpMesh, selector: &ScalpSelector, frame: Option<&HeadFrame>) -> Self {
        let centroids: Vec<DVec3> = mesh.faces.iter().map(|f| mesh.centroid(f)).collect();
        let normals = mesh
            .faces
            .iter()
            .map(|f| {
                // Newell's normal: any polygon, any winding quality.
                let mut n = DVec3::ZERO;
                for i in 0..f.len() {
                    let (a, b) =
                        (mesh.positions[f[i] as usize], mesh.positions[f[(i + 1) % f.len()] as usize]);
                    n += DVec3::new(
                        (a.y - b.y) * (a.z + b.z),
                        (a.z - b.z) * (a.x + b.x),
                        (a.x - b.x) * (a.y + b.y),
                    );
                }
                n.normalize_or_zero()
            })
            .collect();
        let selected = match selector {
            ScalpSelector::Faces(list) => {
                let mut s = vec![false; mesh.faces.len()];
                for &f in list {
                    if let Some(x) = s.get_mut(f as usize) {
                        *x = true;
                    }
                }
                s
            }
            ScalpSelector::Named(_) => vec![true; mesh.faces.len()],
            ScalpSelector::Auto => {
                let frame = frame.copied().or_else(|| HeadFrame::estimate(&mesh));
                hairline(&mesh, frame.as_ref(), HAIRLINE_OFFSET)
            }
            other => centroids.iter().map(|c| other.keeps_centroid(*c)).collect(),
        };
        Self { mesh, centroids, normals, selected }
    }

    /// Selects the faces above the hairline of `frame` at `offset` (skull radii;
    /// [`HAIRLINE_OFFSET`] is the suggested one) and nothing else.
    pub fn suggest_hairline(&mut self, frame: &HeadFrame, offset: f64) {
        self.selected = hairline(&self.mesh, Some(frame), offset);
    }

    /// Faces selected.
    pub fn count(&self) -> usize {
        self.selected.iter().filter(|s| **s).count()
    }

    /// One dab of the brush at `centre` (viewport pixels) with `radius`: every face whose
    /// centroid projects inside it, faces the camera at `eye` and is not hidden (by `depth`,
    /// the head's depth image) is added (`add`) or removed. Returns how many changed.
    pub fn dab(
        &mut self,
        projection: &Projection,
        depth: Option<&DepthGrid>,
        eye: Vec3,
        centre: Vec2,
        radius: f32,
        add: bool,
    ) -> usize {
        let mut changed = 0;
        for (i, c) in self.centroids.iter().enumerate() {
            if self.selected[i] == add || self.normals[i].dot(eye.as_dvec3() - *c) <= 0.0 {
                continue;
            }
            let Some((pixel, w)) = projection.project(c.as_vec3()) else { continue };
            if pixel.distance(centre) > radius || depth.is_some_and(|g| g.hides(pixel, w, DEPTH_TOLERANCE)) {
                continue;
            }
            self.selected[i] = add;
            changed += 1;
        }
        changed
    }

    /// The selection as a scalp selector.
    pub fn selector(&self) -> ScalpSelector {
        ScalpSelector::Faces(
            self.selected.iter().enumerate().filter(|(_, s)| **s).map(|(i, _)| i as u32).collect(),
        )
    }

    /// The selected faces as triangles (fans), for drawing.
    pub fn selected_triangles(&self) -> Vec<[DVec3; 3]> {
        let positions = &self.mesh.positions;
        let mut out = Vec::new();
        for (f, _) in self.mesh.faces.iter().zip(&self.selected).filter(|(_, s)| **s) {
            for i in 1..f.len().saturating_sub(1) {
                out.push([f[0], f[i], f[i + 1]].map(|v| positions[v as usize]));
            }
        }
        out
    }
}

/// Per face of `mesh`: above the hairline of `frame` (none without a frame).
fn hairline(mesh: &ScalpMesh, frame: Option<&HeadFrame>, offset: f64) -> Vec<bool> {
    let mut selected = vec![false; mesh.faces.len()];
    if let Some(frame) = frame {
        for f in frame.hairline_faces(mesh, offset) {
            selected[f as usize] = true;
        }
    }
    selected
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::OrbitCamera;

    #[test]
    fn a_dab_selects_the_faces_under_it_on_the_near_side_only() {
        let cap = hairmesh::procedural::head_cap(8, 32);
        let mut paint = ScalpPaint::new(cap, &ScalpSelector::Faces(vec![0]), None);
        assert_eq!(paint.count(), 1);
        let mut camera = OrbitCamera::default();
        let (lo, hi) = paint.mesh.bounds().expect("bounds");
        camera.frame(lo.as_vec3(), hi.as_vec3());
        let size = Vec2::new(400.0, 300.0);
        let projection = Projection::new(&camera, size);
        let eye = camera.eye();
        // A big dab at the middle of the view selects the near side and nothing behind it.
        let added = paint.dab(&projection, None, eye, size / 2.0, 60.0, true);
        assert!(added > 10, "{added}");
        let selected = paint.selector();
        let ScalpSelector::Faces(faces) = &selected else { panic!("faces") };
        for &f in faces.iter().skip(1) {
            let toward_eye = paint.normals[f as usize].dot(eye.as_dvec3() - paint.centroids[f as usize]);
            assert!(toward_eye > 0.0 || f == 0, "face {f} faces away");
        }
        // Removing with the same dab leaves face 0 (outside the dab or not) as it was.
        let removed = paint.dab(&projection, None, eye, size / 2.0, 60.0, false);
        assert!(removed >= added - 1);
        assert_eq!(ScalpSelector::parse(&selected.to_string()).expect("round trip"), selected);
    }
}
