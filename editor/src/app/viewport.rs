//! The viewport: the preview image, the camera's orbit, pan and zoom, the hair-mesh overlay,
//! picking and dragging tips, and scalp painting; selection, G/R/S and brushes are in
//! [`super::modelling`] and [`super::brushing`].

use egui::{Color32, Pos2, Rect, Sense, Stroke, Vec2};
use glam::{DVec3, Vec3};

use super::*;

impl EditorApp {
    pub(super) fn viewport(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        self.viewport_rect = rect;
        let ppp = ui.ctx().pixels_per_point();
        self.viewport_size = [(rect.width() * ppp).round() as u32, (rect.height() * ppp).round() as u32];
        let response = ui.allocate_rect(rect, Sense::click_and_drag());
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, srgb(self.scene.background));
        if let Some(t) = &self.texture {
            painter.image(t.id(), rect, Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)), Color32::WHITE);
        }
        let Some(doc) = self.doc.as_ref() else {
            let text = match &self.conversion {
                Some(job) => format!("converting {}…", job.file.display()),
                None => "File > Open a scalp mesh (.glb, .gltf, .obj) or a hair asset folder".into(),
            };
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(16.0),
                Color32::GRAY,
            );
            return;
        };
        let projection = Projection::new(&self.camera, glam::Vec2::new(rect.width(), rect.height()));
        let to_screen =
            |p: DVec3| projection.project(p.as_vec3()).map(|(px, _)| rect.min + Vec2::new(px.x, px.y));
        let mesh = doc.asset().mesh();
        let outer = mesh.layers.len() - 1;
        let pointer = response.hover_pos().map(|p| p - rect.min);
        // Drawn faint and not pickable: a tip on the far side of the hair (seen from its
        // middle, it lies away from the camera: long hair hangs away from the view as much as
        // toward it, so the column's own direction says little), and an outer vertex the head hides (tested
        // against a coarse depth image of the occluder, made again when the view changes).
        let depth = doc.occluder.as_ref().map(|o| {
            let view =
                OverlayView { camera: self.camera, size: [rect.width(), rect.height()], occluder: o.clone() };
            match &self.overlay_depth {
                Some((v, grid)) if *v == view => grid.clone(),
                _ => {
                    let positions: Vec<Vec3> =
                        o.positions.iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
                    let grid = Arc::new(DepthGrid::rasterize(&projection, &positions, &o.indices));
                    self.overlay_depth = Some((view, grid.clone()));
                    grid
                }
            }
        });
        let eye = self.camera.eye().as_dvec3();
        let middle = crate::transform::median_point(mesh.layers[outer].iter().copied()).unwrap_or_default();
        let facing: Vec<bool> = (0..mesh.vertex_count())
            .map(|v| {
                let tip = mesh.layers[outer][v];
                let hidden = depth.as_ref().is_some_and(|grid| {
                    projection
                        .project(tip.as_vec3())
                        .is_some_and(|(pixel, w)| grid.hides(pixel, w, OVERLAY_DEPTH_TOLERANCE))
                });
                (tip - middle).dot(eye - tip) >= 0.0 && !hidden
            })
            .collect();
        let pick_at = |pointer: Vec2| -> Option<u32> {
            pick(
                &projection,
                mesh.layers[outer].iter().zip(&facing).map(|(p, &f)| if f { p.as_vec3() } else { Vec3::NAN }),
                glam::Vec2::new(pointer.x, pointer.y),
                PICK_RADIUS,
            )
            .map(|i| i as u32)
        };
        let by_hand = self.show_inner && self.show_overlay && self.scalp_paint.is_none();
        self.hovered_vertex = if self.show_overlay && !by_hand && self.drag.is_none() && self.modal.is_none()
        {
            pointer.and_then(pick_at)
        } else {
            None
        };
        let tips: Vec<Vec3> = mesh.layers[outer]
            .iter()
            .zip(&facing)
            .map(|(p, &f)| if f { p.as_vec3() } else { Vec3::NAN })
            .collect();

        // Input: drag a vertex, orbit, pan, zoom.
        // The vertex is the one under the pointer when the button went down (a drag starts
        // only after the pointer has moved a few pixels from there).
        if response.hovered() && ui.input(|i| i.pointer.primary_pressed()) {
            self.press_vertex = self.hovered_vertex;
        }
        let modelling = if by_hand {
            self.inner_vertex_input(ui, &response, rect, &projection, &painter)
        } else {
            self.brush_input(ui, &response, rect, &tips, &painter)
                || self.hair_brush.is_none() && self.modelling_input(ui, &response, rect, &tips, &painter)
        };
        let Some(doc) = self.doc.as_ref() else { return };
        let mesh = doc.asset().mesh();
        let primary = response.drag_started_by(egui::PointerButton::Primary);
        if primary
            && !modelling
            && self.hair_brush.is_none()
            && self.scalp_paint.is_none()
            && self.show_overlay
            && let Some(v) = self.press_vertex.take()
        {
            let plane = self.mirror_plane();
            let mirror = if self.mirror_x { crate::sculpt::mirror_vertex(mesh, v, &plane) } else { None };
            let soft_radius = self.soft_radius * doc.hair_length();
            // A dragged tip of a selection carries the whole selection along.
            let mut sculpt = if self.selection.len() > 1 && self.selection.contains(&v) {
                let mirror_x = self.mirror_x;
                crate::sculpt::TipDrag::selection(
                    mesh,
                    &self.selection,
                    |w| if mirror_x { crate::sculpt::mirror_vertex(mesh, w, &plane) } else { None },
                    soft_radius,
                )
                .across(plane)
            } else {
                self.selection = vec![v];
                crate::sculpt::TipDrag::new(mesh, v, mirror, soft_radius).across(plane)
            };
            if let Some(head) = doc.head_surface() {
                sculpt = sculpt.outside(head);
            }
            self.drag = Some(VertexDrag {
                vertex: v,
                mirror,
                tip_start: mesh.layers[outer][v as usize],
                sculpt,
                pointer_start: ui
                    .input(|i| i.pointer.press_origin())
                    .or(response.interact_pointer_pos())
                    .unwrap_or(rect.center()),
            });
        }
        let mut moves = Vec::new();
        let mut recipe = None;
        if let Some(drag) = &mut self.drag {
            if let Some(pos) = response.interact_pointer_pos() {
                let delta = pos - drag.pointer_start;
                let tip = drag.tip_start;
                let moved =
                    self.camera.drag_point(tip.as_vec3(), glam::Vec2::new(delta.x, delta.y), rect.height());
                let translation = glam::DAffine3::from_translation(moved.as_dvec3() - tip);
                moves = drag.sculpt.moves_with(&translation);
                recipe = Some(drag.sculpt.recipe(translation));
            }
            self.interacting = true;
        } else if modelling {
        } else if response.dragged_by(egui::PointerButton::Primary)
            && (self.scalp_paint.is_none() || ui.input(|i| i.modifiers.alt))
        {
            let d = response.drag_delta();
            self.camera.orbit(glam::Vec2::new(d.x, d.y));
            self.interacting = true;
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            let d = response.drag_delta();
            self.camera.pan(glam::Vec2::new(d.x, d.y), rect.height());
            self.interacting = true;
        }
        // F frames the selection (unless a text field has the keyboard).
        let frame_requested =
            ui.ctx().input(|i| i.key_pressed(egui::Key::F)) && !ui.ctx().text_edit_focused();
        if response.hovered() {
            let scroll = ui.ctx().input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.camera.zoom(scroll / 50.0);
                self.interacting = true;
            }
        }
        let drag_ended = response.drag_stopped() && self.drag.is_some();

        // Overlay: the outer layer's edges and vertices, the hovered or dragged column.
        if self.show_overlay && self.scalp_paint.is_none() {
            let edge = Stroke::new(1.0, Color32::from_rgba_unmultiplied(120, 200, 255, 90));
            let far_edge = Stroke::new(1.0, Color32::from_rgba_unmultiplied(120, 200, 255, 22));
            for face in &mesh.faces {
                let vs = face.vertices();
                for k in 0..vs.len() {
                    let (a, b) = (vs[k] as usize, vs[(k + 1) % vs.len()] as usize);
                    if let (Some(pa), Some(pb)) =
                        (to_screen(mesh.layers[outer][a]), to_screen(mesh.layers[outer][b]))
                    {
                        painter.line_segment([pa, pb], if facing[a] && facing[b] { edge } else { far_edge });
                    }
                }
            }
            // Bundles that end before the outer layer: their tip faces, where their strands end.
            let short_edge = Stroke::new(1.5, Color32::from_rgba_unmultiplied(255, 170, 90, 150));
            for (f, face) in mesh.faces.iter().enumerate() {
                let tip = mesh.tip_layer(f) as usize;
                if tip >= outer {
                    continue;
                }
                let vs = face.vertices();
                for k in 0..vs.len() {
                    let (a, b) = (vs[k] as usize, vs[(k + 1) % vs.len()] as usize);
                    if let (Some(pa), Some(pb), true) = (
                        to_screen(mesh.layers[tip][a]),
                        to_screen(mesh.layers[tip][b]),
                        facing[a] && facing[b],
                    ) {
                        painter.line_segment([pa, pb], short_edge);
                    }
                }
            }
            let dot = Color32::from_rgba_unmultiplied(160, 220, 255, 160);
            for (p, &f) in mesh.layers[outer].iter().zip(&facing) {
                if let (Some(s), true) = (to_screen(*p), f) {
                    painter.circle_filled(s, 1.5, dot);
                }
            }
            for v in self.highlighted_columns() {
                let column: Vec<Pos2> = mesh.column(v).into_iter().filter_map(to_screen).collect();
                painter.add(egui::Shape::line(
                    column.clone(),
                    Stroke::new(2.0, Color32::from_rgb(255, 200, 80)),
                ));
                if let Some(tip) = column.last() {
                    painter.circle_stroke(*tip, 5.0, Stroke::new(2.0, Color32::from_rgb(255, 200, 80)));
                }
            }
        }
        if self.scalp_paint.is_some() {
            self.paint_scalp(ui, &response, &painter, rect, &projection, depth.as_deref());
        }
        if !moves.is_empty()
            && let Some(doc) = self.doc.as_mut()
            && let Err(e) = doc.sculpt(&moves, recipe, Some(Gesture::Drag))
        {
            self.error = Some(e.to_string());
        }
        if drag_ended {
            self.drag = None;
            if let Some(doc) = self.doc.as_mut() {
                doc.end_gesture();
            }
        }
        if frame_requested {
            self.frame_hair();
        }
    }

    /// Scalp painting in the viewport: drag to add faces under the brush, Shift-drag to remove
    /// them, Alt-drag to orbit; the painted faces are drawn over the head.
    fn paint_scalp(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        painter: &egui::Painter,
        rect: Rect,
        projection: &Projection,
        depth: Option<&DepthGrid>,
    ) {
        let eye = self.camera.eye();
        let radius = self.brush_radius;
        let (alt, shift) = ui.input(|i| (i.modifiers.alt, i.modifiers.shift));
        let Some(paint) = &mut self.scalp_paint else { return };
        if response.dragged_by(egui::PointerButton::Primary)
            && !alt
            && let Some(pos) = response.interact_pointer_pos()
        {
            let centre = glam::Vec2::new(pos.x - rect.min.x, pos.y - rect.min.y);
            paint.dab(projection, depth, eye, centre, radius, !shift);
            self.interacting = true;
        }
        let fill = Color32::from_rgba_unmultiplied(255, 170, 60, 70);
        let mut mesh = egui::Mesh::default();
        for tri in paint.selected_triangles() {
            let corners: Vec<Pos2> = tri
                .iter()
                .filter_map(|p| {
                    projection.project(p.as_vec3()).map(|(px, _)| rect.min + Vec2::new(px.x, px.y))
                })
                .collect();
            if let [a, b, c] = corners[..] {
                let base = mesh.vertices.len() as u32;
                for p in [a, b, c] {
                    mesh.colored_vertex(p, fill);
                }
                mesh.add_triangle(base, base + 1, base + 2);
            }
        }
        painter.add(egui::Shape::mesh(mesh));
        if let Some(pos) = response.hover_pos() {
            let colour =
                if shift { Color32::from_rgb(255, 110, 90) } else { Color32::from_rgb(255, 200, 80) };
            painter.circle_stroke(pos, radius, Stroke::new(1.5, colour));
        }
    }

    /// Starts painting the scalp of the open scalp document (its file's faces, the current
    /// selection to start from).
    pub fn start_scalp_paint(&mut self) {
        let Some(file) = self.doc.as_ref().and_then(Document::scalp_file) else {
            self.error = Some("open a scalp mesh (.glb, .gltf, .obj) to paint its scalp".into());
            return;
        };
        let selector = hairmesh::ScalpSelector::parse(&self.convert.scalp).unwrap_or_default();
        match hairmesh::import::load_faces(&file, self.convert.references) {
            Ok(mesh) => {
                let paint = crate::scalp_paint::ScalpPaint::new(mesh, &selector, self.head_frame.as_ref());
                self.scalp_paint = Some(paint);
            }
            Err(e) => self.error = Some(e.to_string()),
        }
    }

    /// Ends painting: the painted faces become the scalp selection and the head is converted
    /// again with it.
    pub fn apply_scalp_paint(&mut self) {
        let Some(paint) = self.scalp_paint.take() else { return };
        if paint.count() == 0 {
            self.error = Some("no face is painted: paint the scalp first".into());
            self.scalp_paint = Some(paint);
            return;
        }
        self.convert.scalp = paint.selector().to_string();
        if let Some(file) = self.doc.as_ref().and_then(Document::scalp_file) {
            self.start_conversion(file);
        }
    }
}
