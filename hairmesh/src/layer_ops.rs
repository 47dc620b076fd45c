//! Polygon-modelling operations on a hair mesh's layers (the paper's hair mesh is edited like
//! a polygon mesh): insert a layer between two (a loop cut through every column), remove one,
//! and extrude the selected faces' bundles by a layer past their tips. The faces and vertices
//! stay; the layers change, and with them each face's tip layer.
//!
//! The asset then needs its textures again on the same slice layout
//! ([`crate::asset::HairAsset::with_layers`]).

use glam::DVec3;

use crate::hair_mesh::{HairMesh, MAX_LAYERS};
use crate::{HairMeshError, Result};

fn refused(message: String) -> HairMeshError {
    HairMeshError::InvalidParameter { what: "layer edit", message }
}

impl HairMesh {
    /// Inserts a layer between layers `at − 1` and `at` (1 ≤ `at` ≤ L), each vertex on its
    /// column's curve halfway through that segment, so the strands keep their shape. A face
    /// that ended at layer `at` or later ends one layer later (at the same vertex).
    pub fn insert_layer(&mut self, at: usize) -> Result<()> {
        let last = self.layer_count();
        if !(1..=last).contains(&at) {
            return Err(refused(format!(
                "a layer goes between two of layers 0..={last}, not before layer {at}"
            )));
        }
        if last as u32 >= MAX_LAYERS {
            return Err(refused(format!("the hair mesh has {last} layers, the most there may be")));
        }
        let middle: Vec<DVec3> = (0..self.vertex_count() as u32)
            .map(|v| {
                let segments = crate::curve::column_segments(&self.column(v));
                segments[at - 1].eval(0.5)
            })
            .collect();
        let tips = self.tips();
        self.layers.insert(at, middle);
        let shifted = tips.iter().map(|&t| if t as usize >= at { t + 1 } else { t }).collect();
        self.set_tips(shifted);
        Ok(())
    }

    /// Removes layer `layer` (1 ≤ `layer` ≤ L; one layer above the roots must stay). A face
    /// that ended at or after it ends one layer earlier (at least at layer 1).
    pub fn remove_layer(&mut self, layer: usize) -> Result<()> {
        let last = self.layer_count();
        if last < 2 {
            return Err(refused("the hair mesh has one layer above its roots: it cannot lose it".into()));
        }
        if !(1..=last).contains(&layer) {
            return Err(refused(format!("layer {layer} is not one of layers 1..={last}")));
        }
        let tips = self.tips();
        self.layers.remove(layer);
        let shifted = tips.iter().map(|&t| if t as usize >= layer { (t - 1).max(1) } else { t }).collect();
        self.set_tips(shifted);
        Ok(())
    }

    /// Extrudes the bundles of `faces` one layer past their tips. A face that ends at the outer
    /// layer needs a new one: every column gets a vertex continuing its last segment (its
    /// direction and length), and only the extruded faces reach it; a face that ends earlier
    /// ends one layer later. Returns whether a layer was added.
    pub fn extrude_faces(&mut self, faces: &[u32]) -> Result<bool> {
        if let Some(&f) = faces.iter().find(|&&f| f as usize >= self.faces.len()) {
            return Err(refused(format!("face {f} does not exist ({} faces)", self.faces.len())));
        }
        let last = self.layer_count();
        let mut tips = self.tips();
        let grow = faces.iter().any(|&f| tips[f as usize] as usize == last);
        if grow {
            if last as u32 >= MAX_LAYERS {
                return Err(refused(format!("the hair mesh has {last} layers, the most there may be")));
            }
            let outer = &self.layers[last];
            let below = &self.layers[last - 1];
            let next: Vec<DVec3> = outer.iter().zip(below).map(|(p, q)| 2.0 * *p - *q).collect();
            self.layers.push(next);
        }
        for &f in faces {
            tips[f as usize] += 1;
        }
        self.set_tips(tips);
        Ok(grow)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hair_mesh::ExtrudeParams;

    fn cap(layers: u32) -> HairMesh {
        let scalp = crate::procedural::head_cap(3, 12);
        HairMesh::extrude(&scalp, &ExtrudeParams { layers, length: 0.2, droop: 0.8, ..Default::default() })
            .expect("extrudes")
    }

    #[test]
    fn an_inserted_layer_lies_on_the_curves_and_keeps_the_tips() {
        let mut hm = cap(3);
        hm.tip_layers = Some((0..hm.faces.len() as u32).map(|f| 1 + f % 3).collect());
        let before = hm.clone();
        hm.insert_layer(2).expect("insert");
        assert_eq!(hm.layer_count(), 4);
        for v in 0..hm.vertex_count() as u32 {
            let old = crate::curve::column_segments(&before.column(v));
            assert!(hm.layers[2][v as usize].distance(old[1].eval(0.5)) < 1e-12);
            assert_eq!(hm.layers[3][v as usize], before.layers[2][v as usize]);
        }
        for f in 0..hm.faces.len() {
            let t = before.tip_layer(f);
            // The same vertex ends each bundle.
            assert_eq!(hm.tip_layer(f), if t >= 2 { t + 1 } else { t }, "face {f}");
        }
        assert!(hm.check_tip_layers().is_ok());
        // Removing it again gives the mesh back.
        hm.remove_layer(2).expect("remove");
        assert_eq!(hm, before);
    }

    #[test]
    fn extruding_faces_adds_a_layer_only_they_reach() {
        let mut hm = cap(3);
        let faces = [0u32, 5];
        assert!(hm.extrude_faces(&faces).expect("extrude"));
        assert_eq!(hm.layer_count(), 4);
        for f in 0..hm.faces.len() {
            let expected = if faces.contains(&(f as u32)) { 4 } else { 3 };
            assert_eq!(hm.tip_layer(f), expected, "face {f}");
        }
        // The new layer continues each column's last segment.
        for v in 0..hm.vertex_count() {
            let (a, b, c) = (hm.layers[2][v], hm.layers[3][v], hm.layers[4][v]);
            assert!((c - b).distance(b - a) < 1e-12);
        }
        // Extruding the others too reaches the new layer without another.
        let others: Vec<u32> = (0..hm.faces.len() as u32).filter(|f| !faces.contains(f)).collect();
        assert!(!hm.extrude_faces(&others).expect("extrude"));
        assert_eq!((hm.layer_count(), hm.tip_layers.clone()), (4, None));
    }

    #[test]
    fn impossible_layer_edits_are_refused() {
        let mut hm = cap(1);
        assert!(hm.remove_layer(1).is_err(), "the last layer above the roots");
        assert!(hm.insert_layer(0).is_err() && hm.insert_layer(2).is_err());
        assert!(hm.extrude_faces(&[999]).is_err());
        let before = hm.clone();
        assert!(hm.remove_layer(5).is_err());
        assert_eq!(hm, before, "a refused edit changes nothing");
    }
}
