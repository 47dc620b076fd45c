//! Hair brushes in the viewport ([`crate::brush`]): with a brush chosen in the *Sculpt* panel,
//! a left drag strokes it (Alt-drag still orbits); one stroke is one undo step.

use egui::{Color32, Pos2, Rect, Stroke};
use glam::{DAffine3, DVec3, Vec2, Vec3};

use super::EditorApp;
use crate::brush::{BrushKind, dab, under_brush};
use crate::camera::Projection;
use crate::document::Gesture;
use crate::sculpt::TipDrag;
use crate::transform::median_point;

/// A stroke in progress.
#[derive(Debug)]
pub(super) struct BrushStroke {
    /// The pointer at the last dab.
    last: Pos2,
    /// Grab: the columns held and where the stroke started.
    hold: Option<(TipDrag, Pos2, DVec3)>,
}

impl EditorApp {
    /// Brush input for this frame; `tips` as for selection (NaN: not reachable). Returns
    /// whether it took the pointer.
    pub(super) fn brush_input(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        rect: Rect,
        tips: &[Vec3],
        painter: &egui::Painter,
    ) -> bool {
        let Some(kind) = self.hair_brush else {
            self.stroke = None;
            return false;
        };
        if self.scalp_paint.is_some() || !self.show_overlay || self.modal.is_some() {
            self.stroke = None;
            return false;
        }
        let (alt, shift) = ui.input(|i| (i.modifiers.alt, i.modifiers.shift));
        if let Some(pos) = response.hover_pos() {
            let colour =
                if shift { Color32::from_rgb(255, 110, 90) } else { Color32::from_rgb(120, 220, 160) };
            painter.circle_stroke(pos, self.hair_brush_radius, Stroke::new(1.5, colour));
        }
        if alt {
            self.stroke = None;
            return false;
        }
        let size = Vec2::new(rect.width(), rect.height());
        let projection = Projection::new(&self.camera, size);
        if response.drag_started_by(egui::PointerButton::Primary)
            && let Some(start) = ui.input(|i| i.pointer.press_origin())
        {
            let hold = (kind == BrushKind::Grab).then(|| {
                let centre = Vec2::new(start.x - rect.min.x, start.y - rect.min.y);
                let held = under_brush(&projection, tips, centre, self.hair_brush_radius);
                let doc = self.doc.as_ref()?;
                let mesh = doc.asset().mesh();
                let tip = mesh.layers.len() - 1;
                let pivot = median_point(held.iter().map(|(v, _)| mesh.layers[tip][*v as usize]))?;
                let mut drag = TipDrag::weighted(mesh, &held);
                if let Some(head) = doc.head_surface() {
                    drag = drag.outside(head);
                }
                Some((drag, start, pivot))
            });
            self.stroke = Some(BrushStroke { last: start, hold: hold.flatten() });
        }
        let Some(stroke) = &mut self.stroke else { return false };
        self.interacting = true;
        let Some(doc) = self.doc.as_mut() else { return true };
        if let Some(pos) = response.interact_pointer_pos() {
            let moves = if let Some((drag, start, pivot)) = &mut stroke.hold {
                let moved = self.camera.drag_point(
                    pivot.as_vec3(),
                    Vec2::new(pos.x - start.x, pos.y - start.y),
                    size.y,
                );
                drag.moves_with(&DAffine3::from_translation(moved.as_dvec3() - *pivot))
            } else if pos.distance(stroke.last) >= 1.0 || kind != BrushKind::Comb {
                let centre = Vec2::new(pos.x - rect.min.x, pos.y - rect.min.y);
                let weighted = under_brush(&projection, tips, centre, self.hair_brush_radius);
                let mesh = doc.asset().mesh();
                let tip = mesh.layers.len() - 1;
                let depth = median_point(weighted.iter().map(|(v, _)| mesh.layers[tip][*v as usize]));
                let delta = Vec2::new(pos.x - stroke.last.x, pos.y - stroke.last.y);
                let world = depth.map_or(DVec3::ZERO, |d| {
                    self.camera.drag_point(d.as_vec3(), delta, size.y).as_dvec3() - d
                });
                let displacements =
                    dab(kind, mesh, &weighted, world, self.brush_strength, shift, doc.hair_length());
                stroke.last = pos;
                if displacements.is_empty() {
                    Vec::new()
                } else {
                    let touched: Vec<(u32, f64)> = displacements.iter().map(|(v, _)| (*v, 1.0)).collect();
                    let mut drag = TipDrag::weighted(mesh, &touched);
                    if let Some(head) = doc.head_surface() {
                        drag = drag.outside(head);
                    }
                    drag.moves_by(&displacements)
                }
            } else {
                Vec::new()
            };
            if !moves.is_empty()
                && let Err(e) = doc.sculpt(&moves, None, Some(Gesture::Brush))
            {
                self.error = Some(e.to_string());
            }
        }
        if response.drag_stopped() || !ui.input(|i| i.pointer.primary_down()) {
            self.stroke = None;
            doc.end_gesture();
        }
        true
    }

    /// The *Sculpt* panel: the tool (select and transform, or a brush), its radius and
    /// strength.
    pub(super) fn sculpt_panel(&mut self, ui: &mut egui::Ui) {
        ui.horizontal_wrapped(|ui| {
            if ui
                .selectable_label(self.hair_brush.is_none(), "Select")
                .on_hover_text("Click, box and A select tips; G, R, S move them")
                .clicked()
            {
                self.hair_brush = None;
            }
            for kind in BrushKind::ALL {
                if ui
                    .selectable_label(self.hair_brush == Some(kind), kind.name())
                    .on_hover_text(kind.hint())
                    .clicked()
                {
                    self.hair_brush = Some(kind);
                }
            }
        });
        if self.hair_brush.is_some() {
            ui.horizontal(|ui| {
                let l = ui.label("Radius");
                ui.add(egui::Slider::new(&mut self.hair_brush_radius, 4.0..=300.0).suffix(" px"))
                    .labelled_by(l.id);
            });
            ui.horizontal(|ui| {
                let l = ui.label("Strength");
                ui.add(egui::Slider::new(&mut self.brush_strength, 0.0..=1.0)).labelled_by(l.id);
            });
            ui.label("Drag to brush, Shift for the opposite, Alt-drag to orbit.");
        }
    }
}
