//! Inner vertices by hand (the *Inner vertices* toggle): every hair-mesh vertex above the roots
//! is drawn, and one can be dragged in the view plane on its own. The paper places the inner
//! vertices from the outer ones (`hairmesh::inner`); this is the hand override it allows. A
//! later move of outer vertices places the inner ones again.

use egui::{Color32, Pos2, Rect, Stroke, Vec2};
use glam::DVec3;
use hairmesh::asset::VertexMove;

use super::EditorApp;
use crate::camera::Projection;
use crate::document::Gesture;

/// A hand drag of one hair-mesh vertex.
#[derive(Clone, Copy, Debug)]
pub(super) struct InnerDrag {
    layer: u32,
    vertex: u32,
    start: DVec3,
    pointer_start: Pos2,
}

impl EditorApp {
    /// Draws every vertex above the roots (inner ones hollow), picks the one under the pointer
    /// and drags it. Returns whether it took the pointer this frame.
    pub(super) fn inner_vertex_input(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        rect: Rect,
        projection: &Projection,
        painter: &egui::Painter,
    ) -> bool {
        let Some(doc) = self.doc.as_ref() else { return false };
        let mesh = doc.asset().mesh();
        let outer = hairmesh::inner::outer_vertices(mesh);
        let to_screen =
            |p: DVec3| projection.project(p.as_vec3()).map(|(px, _)| rect.min + Vec2::new(px.x, px.y));
        let dot = Color32::from_rgba_unmultiplied(160, 220, 255, 170);
        let mut nearest: Option<((u32, u32), f32)> = None;
        let pointer = response.hover_pos();
        for (k, layer) in mesh.layers.iter().enumerate().skip(1) {
            for (v, p) in layer.iter().enumerate() {
                let Some(s) = to_screen(*p) else { continue };
                if outer[k][v] {
                    painter.circle_filled(s, 1.5, dot);
                } else {
                    painter.circle_stroke(s, 2.5, Stroke::new(1.0, dot));
                }
                if let Some(at) = pointer {
                    let d = at.distance(s);
                    if d <= super::PICK_RADIUS && nearest.is_none_or(|(_, best)| d < best) {
                        nearest = Some(((k as u32, v as u32), d));
                    }
                }
            }
        }
        if self.inner_drag.is_none() {
            self.hovered_inner = nearest.map(|(lv, _)| lv);
        }
        if let Some((layer, vertex)) = self.hovered_inner
            && let Some(s) = to_screen(mesh.layers[layer as usize][vertex as usize])
        {
            painter.circle_stroke(s, 5.0, Stroke::new(2.0, Color32::from_rgb(255, 200, 80)));
        }
        // The vertex is the one under the pointer when the button went down (the drag starts
        // a few pixels later, over another vertex perhaps).
        if response.hovered() && ui.input(|i| i.pointer.primary_pressed()) {
            self.press_inner = self.hovered_inner;
        }
        if response.drag_started_by(egui::PointerButton::Primary)
            && let Some((layer, vertex)) = self.press_inner.take()
        {
            self.inner_drag = Some(InnerDrag {
                layer,
                vertex,
                start: mesh.layers[layer as usize][vertex as usize],
                pointer_start: ui.input(|i| i.pointer.press_origin()).unwrap_or(rect.center()),
            });
        }
        let Some(drag) = self.inner_drag else { return false };
        if let Some(pos) = response.interact_pointer_pos() {
            let delta = pos - drag.pointer_start;
            let moved = self.camera.drag_point(
                drag.start.as_vec3(),
                glam::Vec2::new(delta.x, delta.y),
                rect.height(),
            );
            let edit = [VertexMove { layer: drag.layer, vertex: drag.vertex, position: moved.as_dvec3() }];
            if let Some(doc) = self.doc.as_mut()
                && let Err(e) = doc.move_vertices(&edit, Some(Gesture::Drag))
            {
                self.error = Some(e.to_string());
            }
        }
        self.interacting = true;
        if response.drag_stopped() || !ui.input(|i| i.pointer.primary_down()) {
            self.inner_drag = None;
            if let Some(doc) = self.doc.as_mut() {
                doc.end_gesture();
            }
        }
        true
    }
}
