//! The side panels: conversion (scalp painting, the head frame, the conversion settings),
//! sculpting, style and scene.

use glam::DVec3;
use hairmesh::convert::LayerShape;

use super::*;

impl EditorApp {
    pub(super) fn side_panel(&mut self, ui: &mut egui::Ui) {
        egui::CollapsingHeader::new("Conversion").default_open(true).show(ui, |ui| self.conversion_panel(ui));
        egui::CollapsingHeader::new("Sculpt").default_open(true).show(ui, |ui| self.sculpt_panel(ui));
        egui::CollapsingHeader::new("Style").default_open(true).show(ui, |ui| self.style_panel(ui));
        egui::CollapsingHeader::new("Scene").default_open(true).show(ui, |ui| self.scene_panel(ui));
    }

    fn conversion_panel(&mut self, ui: &mut egui::Ui) {
        // Scalp painting: the way to choose a scalp without typing a selector.
        ui.horizontal(|ui| match &self.scalp_paint {
            None => {
                let can = self.doc.as_ref().and_then(Document::scalp_file).is_some();
                if ui
                    .add_enabled(can, egui::Button::new("Paint scalp"))
                    .on_hover_text(
                        "Paint the faces that grow hair with a brush; the hair is converted again from them",
                    )
                    .clicked()
                {
                    self.start_scalp_paint();
                }
            }
            Some(paint) => {
                ui.label(format!("{} faces painted", paint.count()));
                if ui.button("Apply").clicked() {
                    self.apply_scalp_paint();
                } else if ui.button("Cancel").clicked() {
                    self.scalp_paint = None;
                }
            }
        });
        if let Some(paint) = &mut self.scalp_paint {
            ui.horizontal(|ui| {
                let label = ui.label("Brush");
                ui.add(egui::Slider::new(&mut self.brush_radius, 4.0..=200.0).suffix(" px"))
                    .labelled_by(label.id);
            });
            if let Some(frame) = &self.head_frame {
                ui.horizontal(|ui| {
                    let label = ui.label("Hairline");
                    let slider = egui::Slider::new(&mut self.hairline_offset, -0.8..=0.6)
                        .suffix(" radii")
                        .custom_formatter(|v, _| format!("{v:+.2}"));
                    let moved = ui.add(slider).labelled_by(label.id).on_hover_text(
                        "Height of the suggested hairline over the skull's centre (tilted: high on the forehead, low at the nape)",
                    );
                    let suggest = ui.button("Suggest").on_hover_text(
                        "Select the faces above the hairline suggested by the head's frame (replaces the painting)",
                    );
                    if moved.changed() || suggest.clicked() {
                        paint.suggest_hairline(frame, self.hairline_offset);
                    }
                });
            }
            ui.label("Drag to paint, Shift-drag to erase, Alt-drag to orbit.");
        }
        self.head_frame_row(ui);
        let c = &mut self.convert;
        egui::Grid::new("conversion").num_columns(2).show(ui, |ui| {
            let l = ui.label("Scalp faces");
            ui.text_edit_singleline(&mut c.scalp)
                .labelled_by(l.id)
                .on_hover_text("auto (the suggested hairline), all, name:NAME, above:NX,NY,NZ,OFFSET, sphere:CX,CY,CZ,R, faces:LIST (Paint scalp writes it)");
            ui.end_row();
            let l = ui.label("Layers");
            ui.add(egui::DragValue::new(&mut c.layers).range(1..=hairmesh::hair_mesh::MAX_LAYERS))
                .labelled_by(l.id);
            ui.end_row();
            let l = ui.label("Length");
            let mut auto = c.length.is_none();
            ui.horizontal(|ui| {
                if ui.checkbox(&mut auto, "auto").changed() {
                    c.length = if auto { None } else { Some(1.0) };
                }
                if let Some(length) = &mut c.length {
                    ui.add(egui::DragValue::new(length).speed(0.01).range(1e-4..=1e4)).labelled_by(l.id);
                }
            });
            ui.end_row();
            ui.label("Shape");
            ui.horizontal(|ui| {
                let extrude = matches!(c.shape, LayerShape::Extrude { .. });
                if ui.selectable_label(extrude, "extrude").clicked() && !extrude {
                    c.shape = LayerShape::Extrude { droop: 0.3 };
                }
                let drape = matches!(c.shape, LayerShape::Drape { .. });
                if ui.selectable_label(drape, "drape").clicked() && !drape {
                    c.shape = LayerShape::Drape {
                        centre: DVec3::ZERO,
                        comb: DVec3::new(0.0, 0.0, -2.5),
                        lift: 0.05,
                    };
                }
            });
            ui.end_row();
            match &mut c.shape {
                LayerShape::Extrude { droop } => {
                    let l = ui.label("Droop");
                    ui.add(egui::Slider::new(droop, 0.0..=1.0)).labelled_by(l.id);
                    ui.end_row();
                }
                LayerShape::Drape { centre, comb, lift } => {
                    let l = ui.label("Head centre");
                    vec3_edit(ui, centre, l.id);
                    ui.end_row();
                    let l = ui.label("Comb");
                    vec3_edit(ui, comb, l.id);
                    ui.end_row();
                    let l = ui.label("Lift");
                    ui.add(egui::Slider::new(lift, 0.0..=0.5)).labelled_by(l.id);
                    ui.end_row();
                }
                LayerShape::MorphTargets => {
                    ui.label("Layers from");
                    ui.label("the file's morph targets");
                    ui.end_row();
                }
            }
            let l = ui.label("Strands");
            ui.horizontal(|ui| {
                let mut by_density = c.density.is_some();
                let toggle = ui
                    .checkbox(&mut by_density, "by density")
                    .on_hover_text("strands per unit of scalp area instead of a total");
                if toggle.changed() {
                    c.density = by_density.then_some(1000.0);
                }
                match &mut c.density {
                    Some(d) => {
                        ui.add(egui::DragValue::new(d).range(1e-3..=1e9).speed(10.0)).labelled_by(l.id)
                    }
                    None => ui
                        .add(
                            egui::DragValue::new(&mut c.strands)
                                .range(1..=hairmesh::asset::MAX_TOTAL_STRANDS)
                                .speed(100.0),
                        )
                        .labelled_by(l.id),
                };
            });
            ui.end_row();
            let l = ui.label("Root seed");
            ui.add(egui::DragValue::new(&mut c.seed)).labelled_by(l.id);
            ui.end_row();
            ui.label("Collision");
            ui.checkbox(&mut c.collision, "keep strands out of the head").on_hover_text(
                "The asset carries the head's distance field and every strand vertex is pushed out of the head (off: only the hair mesh is kept out)",
            );
            ui.end_row();
        });
        let scalp = self.doc.as_ref().and_then(Document::scalp_file).filter(|f| f.is_file());
        ui.horizontal(|ui| {
            let busy = self.conversion.is_some();
            let button = ui.add_enabled(!busy && scalp.is_some(), egui::Button::new("Convert again"));
            if button.on_disabled_hover_text("open a scalp mesh first (File > Open)").clicked()
                && let Some(f) = scalp
            {
                self.start_conversion(f);
            }
            if busy {
                ui.add(egui::Spinner::new());
            }
        });
    }

    /// What *Mirror* mirrors across: the head's plane of symmetry, or x = 0 without a head.
    pub(super) fn mirror_plane(&self) -> crate::sculpt::MirrorPlane {
        self.head_frame.as_ref().map(crate::sculpt::MirrorPlane::of_head).unwrap_or_default()
    }

    /// The head's frame in words, and the corrections an artist may need: a scan whose back
    /// was taken for its face, or one turned on its side.
    fn head_frame_row(&mut self, ui: &mut egui::Ui) {
        let Some(frame) = &mut self.head_frame else { return };
        let axis = |d: DVec3| -> String {
            let names = [(DVec3::X, "+X"), (DVec3::NEG_X, "−X"), (DVec3::Y, "+Y"), (DVec3::NEG_Y, "−Y")];
            let names = names.into_iter().chain([(DVec3::Z, "+Z"), (DVec3::NEG_Z, "−Z")]);
            names
                .into_iter()
                .find(|(a, _)| a.dot(d) > 0.9999)
                .map_or_else(|| format!("({:.2}, {:.2}, {:.2})", d.x, d.y, d.z), |(_, n)| n.to_owned())
        };
        ui.horizontal_wrapped(|ui| {
            ui.label(format!(
                "Head: up {}, face {}, skull radius {:.3}",
                axis(frame.up),
                axis(frame.front),
                frame.radius
            ))
            .on_hover_text("Estimated from the head mesh; presets, the drape and gravity follow it");
            let mut changed = None;
            if ui.small_button("Turn face").on_hover_text("Turn the face direction 90° about up").clicked() {
                changed = Some(frame.turned(90.0));
            }
            if ui.small_button("Flip face").on_hover_text("The face is on the other side").clicked() {
                changed = Some(frame.flipped());
            }
            let up_axes = [DVec3::Y, DVec3::Z, DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z, DVec3::NEG_X];
            if ui.small_button("Next up").on_hover_text("Take the file's next axis as up").clicked() {
                let i = up_axes.iter().position(|a| a.dot(frame.up) > 0.9999).map_or(0, |i| i + 1);
                changed = frame.with_up(up_axes[i % up_axes.len()]);
            }
            if let Some(f) = changed {
                *frame = f;
                self.convert.up = f.up;
                self.note = Some("head frame changed: apply a preset or convert again to use it".into());
            }
        });
    }

    fn style_panel(&mut self, ui: &mut egui::Ui) {
        let Some(doc) = &mut self.doc else {
            ui.label("Open a scalp mesh or a hair asset (File > Open).");
            return;
        };
        ui.horizontal_wrapped(|ui| {
            ui.label("Presets:");
            for p in PRESETS {
                if ui.button(p.name).clicked() {
                    self.pending_preset = Some(p);
                }
            }
        });
        // Slider ranges follow the hair's length, so one panel fits any head's units.
        let h = doc.hair_length().max(1e-6);
        let mut style = doc.style();
        let mut gesture: Option<String> = None;
        let mut released = false;
        egui::Grid::new("style").num_columns(2).striped(true).show(ui, |ui| {
            // The slider spans what is useful for this hair; a typed value may go further, up to
            // the field's range (`Style::fields`), which the hover text states.
            let mut slider = |ui: &mut egui::Ui, name: &str, value: &mut f64, max: f64| {
                let label = ui.label(name);
                let field = style_field(name);
                let range = Style::range(&field)
                    .map_or(String::new(), |r| format!("{}: {}..={}", field, r.start(), r.end()));
                let r = ui
                    .add(egui::Slider::new(value, 0.0..=max).clamping(egui::SliderClamping::Never))
                    .labelled_by(label.id)
                    .on_hover_text(range);
                if r.changed() {
                    gesture = Some(name.to_owned());
                }
                released |= r.drag_stopped() || r.lost_focus();
                ui.end_row();
            };
            slider(ui, "Width", &mut style.width, 0.02 * h);
            slider(ui, "Tip width", &mut style.tip_width, 1.0);
            slider(ui, "Root fade", &mut style.root_fade, 1.0);
            slider(ui, "Length variation", &mut style.length_variation, 1.0);
            slider(ui, "Curl radius", &mut style.curl.radius, 0.2 * h);
            slider(ui, "Curl frequency", &mut style.curl.frequency, 20.0 / h);
            slider(ui, "Curl phase", &mut style.curl.phase, 1.0);
            slider(ui, "Wave amplitude", &mut style.wave.amplitude, 0.1 * h);
            slider(ui, "Wave frequency", &mut style.wave.frequency, 20.0 / h);
            slider(ui, "Wave coherence", &mut style.wave.coherence, 1.0);
            slider(ui, "Frizz amplitude", &mut style.frizz.amplitude, 0.1 * h);
            slider(ui, "Frizz frequency", &mut style.frizz.frequency, 40.0 / h);
            slider(ui, "Frizz exponent", &mut style.frizz.exponent, 4.0);
            slider(ui, "Clump strength", &mut style.clump.strength, 1.0);
            slider(ui, "Clump exponent", &mut style.clump.exponent, 4.0);
            slider(ui, "Twist", &mut style.twist, 4.0);
            slider(ui, "Stray fraction", &mut style.stray.fraction, 1.0);
            slider(ui, "Stray amplitude", &mut style.stray.amplitude, 0.1 * h);
            let label = ui.label("Seed");
            let r = ui.add(egui::DragValue::new(&mut style.seed)).labelled_by(label.id);
            if r.changed() {
                gesture = Some("Seed".into());
            }
            ui.end_row();
        });
        let mut color = doc.color();
        let mut color_changed = false;
        ui.horizontal(|ui| {
            let label = ui.label("Colour");
            let r = egui::color_picker::color_edit_button_rgb(ui, &mut color.rgb).labelled_by(label.id);
            color_changed |= r.changed();
            let label = ui.label("variation");
            let r = ui.add(egui::Slider::new(&mut color.variation, 0.0..=1.0)).labelled_by(label.id);
            color_changed |= r.changed();
            released |= r.drag_stopped();
        });
        if let Some(name) = gesture {
            let style = sanitized(style);
            doc.set_style(style.clamped(), Some(Gesture::Style(name)));
            self.interacting = true;
        }
        if color_changed {
            doc.set_color(color, Some(Gesture::Color));
            self.interacting = true;
        }
        if released {
            doc.end_gesture();
        }
        // A slider is being dragged (the viewport's drags set this themselves).
        self.interacting |= ui.ctx().dragged_id().is_some();
        if let Some(p) = self.pending_preset.take() {
            self.apply_preset(p);
        }
    }

    fn scene_panel(&mut self, ui: &mut egui::Ui) {
        let e = &mut self.scene.effects;
        ui.horizontal(|ui| {
            ui.label("Transparency");
            for (t, name) in [
                (Transparency::Opaque, "opaque"),
                (Transparency::Blended, "blended"),
                (Transparency::Oit, "OIT"),
            ] {
                ui.selectable_value(&mut e.transparency, t, name);
            }
        });
        ui.checkbox(&mut e.shadows, "Self-shadowing (deep opacity maps)");
        ui.checkbox(&mut e.ao, "Ambient occlusion");
        ui.checkbox(&mut self.show_overlay, "Hair-mesh overlay");
        ui.checkbox(&mut self.show_inner, "Inner vertices (drag by hand)").on_hover_text(
            "Every hair-mesh vertex is shown (inner ones hollow) and dragged on its own, instead of the tips; a later move of outer vertices places the inner ones again",
        );
        ui.checkbox(&mut self.mirror_x, "Mirror (symmetric edits)").on_hover_text(
            "Edits move the columns mirrored across the head's plane of symmetry too (x = 0 without a head)",
        );
        ui.horizontal(|ui| {
            let label = ui.label("Soft selection");
            ui.add(egui::Slider::new(&mut self.soft_radius, 0.0..=1.0))
                .labelled_by(label.id)
                .on_hover_text("Tips within this fraction of the hair's length of the dragged one follow it, less the further they are (0: only the dragged column)");
        });
        if let Some(doc) = &self.doc {
            let layers = doc.asset().mesh().layer_count() as u32;
            ui.horizontal(|ui| {
                let label = ui.label("Layer");
                self.layer_pick = self.layer_pick.clamp(1, layers.max(1));
                ui.add(egui::DragValue::new(&mut self.layer_pick).range(1..=layers.max(1)))
                    .labelled_by(label.id)
                    .on_hover_text("Layer 1 is the first above the roots");
                let pick = self.layer_pick;
                if ui
                    .button("Insert before")
                    .on_hover_text(
                        "A layer halfway between this one and the one below, on every column's curve",
                    )
                    .clicked()
                {
                    self.edit_layers(
                        &crate::document::LayerOp::Insert { at: pick },
                        &format!("layer inserted before layer {pick}"),
                    );
                }
                if ui.add_enabled(layers > 1, egui::Button::new("Remove")).clicked() {
                    self.edit_layers(
                        &crate::document::LayerOp::Remove { layer: pick },
                        &format!("layer {pick} removed"),
                    );
                }
            });
            ui.horizontal(|ui| {
                let label = ui.label("G/R/S hold");
                self.held_layer = self.held_layer.min(layers);
                ui.add(
                    egui::DragValue::new(&mut self.held_layer)
                        .range(0..=layers)
                        .custom_formatter(|v, _| if v < 0.5 { "tips".into() } else { format!("layer {v:.0}") }),
                )
                .labelled_by(label.id)
                .on_hover_text("The layer of the selected columns a grab, rotation or scale takes hold of: it and the layers above follow the transform, the ones below bend");
            });
        }
        ui.horizontal(|ui| {
            ui.label("Selected bundles");
            let hint = "The faces whose every corner is selected end a layer earlier or later (keys [ and ])";
            if ui.button("Shorter").on_hover_text(hint).clicked() {
                self.step_tip_layers(-1);
            }
            if ui.button("Longer").on_hover_text(hint).clicked() {
                self.step_tip_layers(1);
            }
            if ui
                .button("Extrude")
                .on_hover_text("The selected faces' bundles grow by a layer past their tips (E)")
                .clicked()
            {
                self.extrude_selected_faces();
            }
        });
        ui.separator();
        // LOD preview: the distance the hair is seen from, and what the generator drew there.
        ui.horizontal(|ui| {
            let label = ui.label("Distance");
            let r = ui
                .add(egui::Slider::new(&mut self.camera.distance, 0.05..=200.0).logarithmic(true))
                .labelled_by(label.id);
            if r.dragged() {
                self.interacting = true;
            }
        });
        if let (Some(s), Some(doc)) = (&self.shown, &self.doc) {
            ui.label(format!(
                "LOD: {} of {} strands, {} vertices drawn",
                s.strands,
                doc.asset().total_strands(),
                s.vertices
            ));
        }
    }
}
