//! Scalp meshes: what import produces and hair meshes are built from.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::{HairMeshError, Result};

/// A polygon mesh after import and welding: positions, optional uvs (one per position), and
/// faces as polygons (triangles, quads and n-gons kept as the file had them).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScalpMesh {
    pub positions: Vec<DVec3>,
    pub uvs: Option<Vec<DVec2>>,
    pub faces: Vec<Vec<u32>>,
    /// Per glTF morph target: the displaced positions of every vertex (a hair mesh modelled as
    /// shape keys, one target per layer).
    pub morph_layers: Vec<Vec<DVec3>>,
    /// Things skipped on import (point or line primitives, ...), for the user.
    pub warnings: Vec<String>,
}

/// Which faces of the file form the scalp. Spatial predicates test each face's centroid, in the
/// file's own units and axes (after node transforms).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ScalpSelector {
    /// Every face.
    #[default]
    All,
    /// Faces of glTF meshes, or materials, or OBJ objects/groups with this exact name.
    Named(String),
    /// Faces whose centroid `c` satisfies `dot(normal, c) > offset`.
    AbovePlane { normal: DVec3, offset: f64 },
    /// Faces whose centroid lies inside the sphere.
    InSphere { center: DVec3, radius: f64 },
    /// These faces of the file, by their index in import order (what the editor's scalp brush
    /// paints; sorted, without repeats).
    Faces(Vec<u32>),
    /// The suggested hairline of the head frame estimated from the whole file
    /// ([`crate::head_frame`]): the crown, the back and the sides above the ears, not the face.
    Auto,
}

/// Most faces a `faces:` selector may list.
pub const MAX_SELECTED_FACES: usize = 1 << 24;

/// The CLI form ([`ScalpSelector::parse`] reads it back).
impl std::fmt::Display for ScalpSelector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::All => write!(f, "all"),
            Self::Auto => write!(f, "auto"),
            Self::Named(name) => write!(f, "name:{name}"),
            Self::AbovePlane { normal: n, offset } => write!(f, "above:{},{},{},{offset}", n.x, n.y, n.z),
            Self::InSphere { center: c, radius } => write!(f, "sphere:{},{},{},{radius}", c.x, c.y, c.z),
            Self::Faces(faces) => write!(f, "faces:{}", face_ranges(faces)),
        }
    }
}

impl ScalpSelector {
    /// Parses the CLI form: `all`, `auto`, `name:NAME`, `above:NX,NY,NZ,OFFSET`,
    /// `sphere:CX,CY,CZ,R` or `faces:LIST`.
    pub fn parse(text: &str) -> Result<Self> {
        let bad = |message: String| HairMeshError::InvalidParameter { what: "scalp selector", message };
        let numbers = |list: &str, n: usize| -> Result<Vec<f64>> {
            let v: Vec<f64> = list
                .split(',')
                .map(|s| s.trim().parse::<f64>().map_err(|e| bad(format!("`{s}` in `{text}`: {e}"))))
                .collect::<Result<_>>()?;
            if v.len() != n || v.iter().any(|x| !x.is_finite()) {
                return Err(bad(format!("`{text}` needs {n} finite numbers")));
            }
            Ok(v)
        };
        if text == "all" {
            return Ok(Self::All);
        }
        if text == "auto" {
            return Ok(Self::Auto);
        }
        if let Some(list) = text.strip_prefix("faces:") {
            let mut faces = Vec::new();
            for part in list.split(',').map(str::trim).filter(|p| !p.is_empty()) {
                let index =
                    |s: &str| s.trim().parse::<u32>().map_err(|e| bad(format!("`{s}` in `faces:`: {e}")));
                let (a, b) = match part.split_once('-') {
                    Some((a, b)) => (index(a)?, index(b)?),
                    None => (index(part)?, index(part)?),
                };
                if a > b || faces.len() + (b - a) as usize >= MAX_SELECTED_FACES {
                    return Err(bad(format!(
                        "`{part}` in `faces:`: a range START-END with START ≤ END, and at most {MAX_SELECTED_FACES} faces"
                    )));
                }
                faces.extend(a..=b);
            }
            faces.sort_unstable();
            faces.dedup();
            if faces.is_empty() {
                return Err(bad("`faces:` lists no face".into()));
            }
            return Ok(Self::Faces(faces));
        }
        if let Some(name) = text.strip_prefix("name:") {
            return Ok(Self::Named(name.to_owned()));
        }
        if let Some(list) = text.strip_prefix("above:") {
            let v = numbers(list, 4)?;
            let normal = DVec3::new(v[0], v[1], v[2]);
            if normal.length() < 1e-12 {
                return Err(bad(format!("`{text}`: the plane normal is zero")));
            }
            return Ok(Self::AbovePlane { normal: normal.normalize(), offset: v[3] });
        }
        if let Some(list) = text.strip_prefix("sphere:") {
            let v = numbers(list, 4)?;
            if v[3] <= 0.0 {
                return Err(bad(format!("`{text}`: the radius must be positive")));
            }
            return Ok(Self::InSphere { center: DVec3::new(v[0], v[1], v[2]), radius: v[3] });
        }
        Err(bad(format!(
            "`{text}` (expected all, auto, name:NAME, above:NX,NY,NZ,OFFSET, sphere:CX,CY,CZ,R or faces:LIST)"
        )))
    }

    /// Whether a face with this centroid is kept by a spatial predicate (`Named` and `All`
    /// keep everything here; names are applied while importing).
    pub fn keeps_centroid(&self, c: DVec3) -> bool {
        match self {
            Self::All | Self::Auto | Self::Named(_) | Self::Faces(_) => true,
            Self::AbovePlane { normal, offset } => normal.dot(c) > *offset,
            Self::InSphere { center, radius } => c.distance_squared(*center) < radius * radius,
        }
    }
}

impl ScalpMesh {
    /// Axis-aligned bounds `(min, max)`; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }

    pub fn centroid(&self, face: &[u32]) -> DVec3 {
        face.iter().map(|&i| self.positions[i as usize]).sum::<DVec3>() / face.len().max(1) as f64
    }

    /// Keeps the faces a spatial selector accepts, then drops unused vertices.
    pub fn select(&mut self, selector: &ScalpSelector) {
        let keep: Vec<bool> = match selector {
            ScalpSelector::Faces(list) => {
                let mut keep = vec![false; self.faces.len()];
                for &f in list {
                    if let Some(k) = keep.get_mut(f as usize) {
                        *k = true;
                    }
                }
                keep
            }
            ScalpSelector::Auto => {
                let mut keep = vec![false; self.faces.len()];
                if let Some(frame) = crate::head_frame::HeadFrame::estimate(self) {
                    for f in frame.hairline_faces(self, crate::head_frame::HAIRLINE_OFFSET) {
                        keep[f as usize] = true;
                    }
                }
                keep
            }
            _ => self.faces.iter().map(|f| selector.keeps_centroid(self.centroid(f))).collect(),
        };
        let mut i = 0;
        self.faces.retain(|_| {
            i += 1;
            keep[i - 1]
        });
        self.compact();
    }

    /// Merges vertices closer than `tolerance × bounds diagonal` (UV seams and split normals
    /// leave duplicates that would cut the hair mesh apart), removes repeated vertices inside a
    /// face and faces left with fewer than 3, then drops unused vertices.
    pub fn weld(&mut self, relative_tolerance: f64) {
        let Some((lo, hi)) = self.bounds() else { return };
        let tol = (relative_tolerance * lo.distance(hi)).max(f64::MIN_POSITIVE);
        let cell = |p: DVec3| ((p - lo) / tol).floor().as_i64vec3();
        let mut grid: std::collections::HashMap<glam::I64Vec3, Vec<u32>> = std::collections::HashMap::new();
        let mut remap = vec![0u32; self.positions.len()];
        let mut kept: Vec<usize> = Vec::new();
        for (i, p) in self.positions.iter().enumerate() {
            let c = cell(*p);
            let mut found = None;
            'search: for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        if let Some(list) = grid.get(&(c + glam::I64Vec3::new(dx, dy, dz)))
                            && let Some(&r) =
                                list.iter().find(|&&r| self.positions[kept[r as usize]].distance(*p) <= tol)
                        {
                            found = Some(r);
                            break 'search;
                        }
                    }
                }
            }
            remap[i] = found.unwrap_or_else(|| {
                let r = kept.len() as u32;
                kept.push(i);
                grid.entry(c).or_default().push(r);
                r
            });
        }
        self.positions = kept.iter().map(|&i| self.positions[i]).collect();
        if let Some(uvs) = &mut self.uvs {
            *uvs = kept.iter().map(|&i| uvs[i]).collect();
        }
        for layer in &mut self.morph_layers {
            *layer = kept.iter().map(|&i| layer[i]).collect();
        }
        for face in &mut self.faces {
            for v in face.iter_mut() {
                *v = remap[*v as usize];
            }
            // Remove consecutive repeats (cyclically): a collapsed edge.
            face.dedup();
            while face.len() > 1 && face.first() == face.last() {
                face.pop();
            }
        }
        self.faces.retain(|f| {
            let mut distinct = f.clone();
            distinct.sort_unstable();
            distinct.dedup();
            distinct.len() == f.len() && f.len() >= 3
        });
        self.compact();
    }

    /// Drops vertices no face uses, renumbering faces.
    pub fn compact(&mut self) {
        let mut remap = vec![u32::MAX; self.positions.len()];
        let mut order = Vec::new();
        for face in &self.faces {
            for &v in face {
                if remap[v as usize] == u32::MAX {
                    remap[v as usize] = order.len() as u32;
                    order.push(v as usize);
                }
            }
        }
        for face in &mut self.faces {
            for v in face.iter_mut() {
                *v = remap[*v as usize];
            }
        }
        self.positions = order.iter().map(|&i| self.positions[i]).collect();
        if let Some(uvs) = &mut self.uvs {
            *uvs = order.iter().map(|&i| uvs[i]).collect();
        }
        for layer in &mut self.morph_layers {
            *layer = order.iter().map(|&i| layer[i]).collect();
        }
    }

    /// Total area of all faces (polygons fanned from their first vertex).
    pub fn area(&self) -> f64 {
        self.faces
            .iter()
            .map(|f| {
                let p0 = self.positions[f[0] as usize];
                (1..f.len() - 1)
                    .map(|k| {
                        let a = self.positions[f[k] as usize] - p0;
                        let b = self.positions[f[k + 1] as usize] - p0;
                        0.5 * a.cross(b).length()
                    })
                    .sum::<f64>()
            })
            .sum()
    }
}

/// `0-12,15,20-22`: sorted face indices as ranges.
fn face_ranges(faces: &[u32]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < faces.len() {
        let mut j = i;
        while j + 1 < faces.len() && faces[j + 1] == faces[j] + 1 {
            j += 1;
        }
        parts.push(if i == j { faces[i].to_string() } else { format!("{}-{}", faces[i], faces[j]) });
        i = j + 1;
    }
    parts.join(",")
}

#[cfg(test)]
mod tests {

    #[test]
    fn painted_faces_round_trip_as_ranges_and_select_by_index() {
        let selector = ScalpSelector::parse("faces:5,0-3,4,9, 11-12,3").expect("parses");
        assert_eq!(selector, ScalpSelector::Faces(vec![0, 1, 2, 3, 4, 5, 9, 11, 12]));
        assert_eq!(selector.to_string(), "faces:0-5,9,11-12");
        assert_eq!(ScalpSelector::parse(&selector.to_string()).expect("again"), selector);
        for bad in ["faces:", "faces:3-1", "faces:x", "faces:0-4294967295"] {
            assert!(ScalpSelector::parse(bad).is_err(), "{bad}");
        }
        let mut mesh = crate::procedural::head_cap(4, 8);
        let all = mesh.faces.clone();
        mesh.select(&ScalpSelector::Faces(vec![1, 3, 1000]));
        assert_eq!(mesh.faces.len(), 2);
        let corners = |f: &Vec<u32>| f.len();
        assert_eq!(mesh.faces.iter().map(corners).collect::<Vec<_>>(), [all[1].len(), all[3].len()]);
    }

    use super::*;

    #[test]
    fn weld_merges_seams_and_drops_collapsed_faces() {
        // Two triangles sharing an edge, but with the shared vertices duplicated (a UV seam),
        // plus a triangle that collapses to a line once welded.
        let mut m = ScalpMesh {
            positions: vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::X + DVec3::splat(1e-9),
                DVec3::Y,
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::ZERO,
            ],
            uvs: None,
            faces: vec![vec![0, 1, 2], vec![3, 5, 4], vec![0, 6, 1]],
            ..Default::default()
        };
        m.weld(1e-6);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.faces.len(), 2);
        assert!(m.faces.iter().flatten().all(|&v| (v as usize) < m.positions.len()));
        assert!((m.area() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn selectors_parse_and_reject_bad_text() {
        assert_eq!(ScalpSelector::parse("all").ok(), Some(ScalpSelector::All));
        assert_eq!(ScalpSelector::parse("name:Scalp").ok(), Some(ScalpSelector::Named("Scalp".into())));
        let s = ScalpSelector::parse("above:0,2,0,1.5").expect("valid");
        assert!(s.keeps_centroid(DVec3::new(0.0, 2.0, 0.0)));
        assert!(!s.keeps_centroid(DVec3::new(0.0, 1.0, 0.0)));
        assert!(ScalpSelector::parse("sphere:0,0,0,1").expect("valid").keeps_centroid(DVec3::splat(0.5)));
        for bad in
            ["above:0,0,0,1", "sphere:0,0,0,-1", "above:1,2", "sphere:a,b,c,d", "above:nan,0,1,0", "top"]
        {
            let e = ScalpSelector::parse(bad).expect_err(bad).to_string();
            assert!(e.contains("scalp selector"), "{e}");
        }
    }
}
