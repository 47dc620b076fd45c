//! Selecting the hair mesh's tips and transforming them in the viewport, with a polygon
//! modeller's habits: click selects a column (Shift-click adds or removes it), Shift-drag boxes
//! tips in (Ctrl-drag boxes them out), A selects every tip facing the camera, Alt+A none, Escape
//! none; G, R and S grab, rotate and scale the selection ([`crate::transform`]) with mirror and
//! soft selection; every column bends under its tip, the inner vertices follow and everything
//! stays out of the head ([`crate::sculpt`]). `[` and `]` end the selected faces' bundles a
//! layer earlier or later (bundles of different lengths: a fringe, a long back); E extrudes
//! them by a layer.

use egui::{Color32, Key, Pos2, Rect, Stroke};
use glam::{DVec3, Vec2, Vec3};
use hairmesh::asset::VertexMove;

use super::EditorApp;
use crate::document::{Document, Gesture};
use crate::sculpt::TipDrag;
use crate::transform::{Axis, ModalTransform, TransformKind, median_point};

/// A grab, rotation or scale in progress.
#[derive(Debug)]
pub(super) struct Modal {
    pub(super) op: ModalTransform,
    pub(super) sculpt: TipDrag,
    /// The pointer, last seen (viewport pixels).
    pointer: Vec2,
    /// What it does, for the status bar.
    pub(super) status: String,
}

/// A box being dragged out: where it started, and whether it adds or removes tips.
#[derive(Clone, Copy, Debug)]
pub(super) struct BoxSelect {
    from: Pos2,
    add: bool,
}

impl EditorApp {
    /// Selection and transform input for this frame. `tips` are the outer layer's tips that
    /// can be picked (NaN for those facing away or hidden). Returns whether it took the
    /// pointer (no orbit, no vertex drag) this frame.
    pub(super) fn modelling_input(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        rect: Rect,
        tips: &[Vec3],
        painter: &egui::Painter,
    ) -> bool {
        if self.scalp_paint.is_some() || !self.show_overlay {
            self.modal = None;
            self.box_select = None;
            return false;
        }
        if self.modal.is_some() {
            self.modal_step(ui, response, rect);
            return true;
        }
        let keyboard = response.hovered() && !ui.ctx().text_edit_focused();
        let (shift, ctrl, alt) = ui.input(|i| (i.modifiers.shift, i.modifiers.command, i.modifiers.alt));
        if keyboard && self.drag.is_none() {
            if ui.input(|i| i.key_pressed(Key::A)) {
                self.selection = if alt {
                    Vec::new()
                } else {
                    (0..tips.len() as u32).filter(|&v| tips[v as usize].is_finite()).collect()
                };
            }
            let kind = ui.input(|i| {
                [
                    (Key::G, TransformKind::Grab),
                    (Key::R, TransformKind::Rotate),
                    (Key::S, TransformKind::Scale),
                ]
                .into_iter()
                .find(|(k, _)| i.key_pressed(*k) && i.modifiers.is_none())
                .map(|(_, kind)| kind)
            });
            let step = ui.input(|i| {
                (i.key_pressed(Key::CloseBracket) as i32) - (i.key_pressed(Key::OpenBracket) as i32)
            });
            if step != 0 {
                self.step_tip_layers(step);
            }
            if ui.input(|i| i.key_pressed(Key::E) && i.modifiers.is_none()) {
                self.extrude_selected_faces();
            }
            if let Some(kind) = kind {
                let at = response.hover_pos().unwrap_or(rect.center()) - rect.min;
                self.start_transform(kind, Vec2::new(at.x, at.y));
                return true;
            }
        }
        // A box from empty space with Shift (add) or Ctrl (remove).
        if response.drag_started_by(egui::PointerButton::Primary)
            && self.press_vertex.is_none()
            && (shift || ctrl)
            && let Some(from) = ui.input(|i| i.pointer.press_origin())
        {
            self.box_select = Some(BoxSelect { from, add: !ctrl });
        }
        if let Some(b) = self.box_select {
            let to = response.interact_pointer_pos().unwrap_or(b.from);
            let area = Rect::from_two_pos(b.from, to);
            painter.rect_stroke(
                area,
                0.0,
                Stroke::new(1.0, Color32::from_rgb(255, 200, 80)),
                egui::StrokeKind::Inside,
            );
            if response.drag_stopped() || !ui.input(|i| i.pointer.primary_down()) {
                self.box_select = None;
                let projection =
                    crate::camera::Projection::new(&self.camera, Vec2::new(rect.width(), rect.height()));
                for (v, p) in tips.iter().enumerate() {
                    let inside = projection
                        .project(*p)
                        .is_some_and(|(px, _)| area.contains(rect.min + egui::vec2(px.x, px.y)));
                    if inside {
                        self.set_selected(v as u32, b.add);
                    }
                }
            }
            return true;
        }
        if response.clicked() {
            match (self.hovered_vertex, shift) {
                (Some(v), true) => {
                    let selected = self.selection.contains(&v);
                    self.set_selected(v, !selected);
                }
                (Some(v), false) => self.selection = vec![v],
                (None, true) => {}
                (None, false) => self.selection.clear(),
            }
        }
        if keyboard && ui.input(|i| i.key_pressed(Key::Escape)) {
            self.selection.clear();
        }
        false
    }

    /// Adds `v` to the selection or removes it (kept sorted, without repeats).
    fn set_selected(&mut self, v: u32, selected: bool) {
        match (self.selection.binary_search(&v), selected) {
            (Err(at), true) => self.selection.insert(at, v),
            (Ok(at), false) => {
                self.selection.remove(at);
            }
            _ => {}
        }
    }

    /// Starts grabbing, rotating or scaling the selection with the pointer at `pointer`
    /// (viewport pixels).
    pub fn start_transform(&mut self, kind: TransformKind, pointer: Vec2) {
        let Some(doc) = &self.doc else { return };
        let mesh = doc.asset().mesh();
        // The layer G/R/S take hold of: the tips, or the one the panel names.
        let tip = mesh.layers.len() - 1;
        let held = if self.held_layer == 0 { tip } else { (self.held_layer as usize).min(tip) };
        self.selection.retain(|&v| (v as usize) < mesh.vertex_count());
        let Some(pivot) = median_point(self.selection.iter().map(|&v| mesh.layers[held][v as usize])) else {
            self.note = Some("select tips first (click, Shift-click, Shift-drag a box, A for all)".into());
            return;
        };
        let mirror = self.mirror_x;
        let plane = self.mirror_plane();
        let soft_radius = self.soft_radius * doc.hair_length();
        let mut sculpt = TipDrag::selection(
            mesh,
            &self.selection,
            |v| if mirror { crate::sculpt::mirror_vertex(mesh, v, &plane) } else { None },
            soft_radius,
        )
        .across(plane);
        if held != tip {
            sculpt = sculpt.at_layer(held as u32);
        }
        if let Some(head) = doc.head_surface() {
            sculpt = sculpt.outside(head);
        }
        let status = format!("{kind:?}: move the pointer");
        self.modal = Some(Modal { op: ModalTransform::new(kind, pivot, pointer), sculpt, pointer, status });
    }

    /// One frame of a running transform: keys, pointer, confirm or cancel, and the moves.
    fn modal_step(&mut self, ui: &egui::Ui, response: &egui::Response, rect: Rect) {
        let Some(modal) = &mut self.modal else { return };
        let mut confirm = false;
        let mut cancel = false;
        ui.input(|i| {
            for event in &i.events {
                match event {
                    egui::Event::Text(t) => t.chars().for_each(|c| {
                        modal.op.type_char(c);
                    }),
                    egui::Event::Key { key, pressed: true, modifiers, .. } => match key {
                        Key::X | Key::Y | Key::Z => {
                            let axis = match key {
                                Key::X => Axis::X,
                                Key::Y => Axis::Y,
                                _ => Axis::Z,
                            };
                            if modifiers.shift {
                                modal.op.toggle_plane(axis);
                            } else {
                                modal.op.toggle_axis(axis);
                            }
                        }
                        Key::Backspace => modal.op.backspace(),
                        Key::Enter => confirm = true,
                        Key::Escape => cancel = true,
                        _ => {}
                    },
                    _ => {}
                }
            }
            if i.pointer.button_pressed(egui::PointerButton::Primary) {
                confirm = true;
            }
            if i.pointer.button_pressed(egui::PointerButton::Secondary) {
                cancel = true;
            }
        });
        if let Some(p) = response.hover_pos() {
            modal.pointer = Vec2::new(p.x - rect.min.x, p.y - rect.min.y);
        }
        self.interacting = true;
        if cancel {
            self.modal = None;
            if let Some(doc) = self.doc.as_mut()
                && let Err(e) = doc.cancel_gesture(&Gesture::Transform)
            {
                self.error = Some(e.to_string());
            }
            self.note = Some("transform cancelled".into());
            return;
        }
        let size = Vec2::new(rect.width(), rect.height());
        let transform = modal.op.transform(&self.camera, size, modal.pointer);
        let moves: Vec<VertexMove> = modal.sculpt.moves_with(&transform);
        modal.status = modal.op.describe(&transform);
        let recipe = modal.sculpt.recipe(transform);
        if let Some(doc) = self.doc.as_mut()
            && let Err(e) = doc.sculpt(&moves, Some(recipe), Some(Gesture::Transform))
        {
            self.error = Some(e.to_string());
        }
        if confirm {
            self.modal = None;
            if let Some(doc) = self.doc.as_mut() {
                doc.end_gesture();
            }
        }
    }

    /// The faces (bundles) whose every column is selected: a polygon modeller's faces of a
    /// vertex selection.
    pub(super) fn selected_faces(&self, doc: &Document) -> Vec<u32> {
        let faces = &doc.asset().mesh().faces;
        (0..faces.len() as u32)
            .filter(|&f| faces[f as usize].vertices().iter().all(|v| self.selection.binary_search(v).is_ok()))
            .collect()
    }

    /// Ends the selected faces' bundles `delta` layers later (negative: earlier), each within
    /// 1..=L; one undo step.
    pub fn step_tip_layers(&mut self, delta: i32) {
        let Some(doc) = &self.doc else { return };
        let faces = self.selected_faces(doc);
        if faces.is_empty() {
            self.note =
                Some("select every corner of the faces to shorten or lengthen (Shift-drag a box)".into());
            return;
        }
        let last = doc.asset().mesh().layer_count() as i64;
        let tips: Vec<(u32, u32)> = faces
            .iter()
            .map(|&f| {
                (f, (i64::from(doc.asset().tip_layer(f)) + i64::from(delta)).clamp(1, last.max(1)) as u32)
            })
            .collect();
        let (shortest, longest) = tips.iter().fold((u32::MAX, 0), |(lo, hi), &(_, l)| (lo.min(l), hi.max(l)));
        let result = self.doc.as_mut().map(|doc| doc.set_tip_layers(&tips));
        match result {
            Some(Err(e)) => self.error = Some(e.to_string()),
            _ => {
                let layers = if shortest == longest {
                    format!("layer {shortest}")
                } else {
                    format!("layers {shortest}..{longest}")
                };
                self.note = Some(format!("{} bundles end at {layers} of {last}", tips.len()));
            }
        }
    }

    /// Extrudes the selected faces' bundles by a layer (E): a new outer layer when one of them
    /// ends at the outer layer, reached by them alone.
    pub fn extrude_selected_faces(&mut self) {
        let Some(doc) = &self.doc else { return };
        let faces = self.selected_faces(doc);
        if faces.is_empty() {
            self.note = Some("select every corner of the faces to extrude (Shift-drag a box)".into());
            return;
        }
        let n = faces.len();
        self.edit_layers(
            &crate::document::LayerOp::Extrude { faces },
            &format!("{n} bundles extruded by a layer"),
        );
    }

    /// Runs a layer edit, reporting `done` or the error.
    pub fn edit_layers(&mut self, op: &crate::document::LayerOp, done: &str) {
        let Some(doc) = self.doc.as_mut() else { return };
        match doc.edit_layers(op) {
            Ok(()) => self.note = Some(format!("{done}: {} layers", doc.asset().mesh().layer_count())),
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// The columns to highlight: those a transform moves, else the hovered and selected ones.
    pub(super) fn highlighted_columns(&self) -> Vec<u32> {
        match (&self.modal, &self.drag) {
            (Some(m), _) => m.sculpt.columns().collect(),
            (None, Some(d)) => std::iter::once(d.vertex).chain(d.mirror).chain(d.sculpt.columns()).collect(),
            (None, None) => self.hovered_vertex.into_iter().chain(self.selection.iter().copied()).collect(),
        }
    }

    /// The bounds of the selected columns, if any is selected.
    pub(super) fn selection_bounds(&self, doc: &Document) -> Option<(DVec3, DVec3)> {
        let mesh = doc.asset().mesh();
        let points: Vec<DVec3> = self
            .selection
            .iter()
            .filter(|&&v| (v as usize) < mesh.vertex_count())
            .flat_map(|&v| mesh.column(v))
            .collect();
        (!points.is_empty()).then(|| crate::sculpt::point_bounds(&points))
    }
}
