//! The window's chrome: shortcuts, the menu bar, the status bar, file dialogs and the modal
//! prompts.

use super::*;

impl EditorApp {
    /// Quits, asking first about unsaved changes.
    pub fn request_quit(&mut self) {
        if self.doc.as_ref().is_some_and(Document::is_dirty) {
            self.pending = Some(PendingAction::Quit);
        } else {
            self.quit = true;
        }
    }

    pub(super) fn open_dialog(&mut self, purpose: DialogPurpose) {
        let start = self
            .doc
            .as_ref()
            .and_then(|d| d.save_path.clone())
            .or_else(|| self.recent.first().cloned())
            .and_then(|p| p.parent().map(Path::to_owned))
            .unwrap_or_else(|| PathBuf::from("."));
        let mut dialog = match purpose {
            DialogPurpose::Open => egui_file::FileDialog::open_file()
                .title("Open a head or scalp mesh, a hair asset (its hair.json) or a session")
                .show_files_filter(Box::new(|p: &Path| {
                    let ext = p.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
                    matches!(ext.as_str(), "glb" | "gltf" | "obj" | "json")
                })),
            DialogPurpose::SaveAs => {
                egui_file::FileDialog::select_folder().title("Save the asset as a folder")
            }
            DialogPurpose::ExportPng => {
                egui_file::FileDialog::save_file().title("Export the viewport as PNG")
            }
            DialogPurpose::ExportScene => egui_file::FileDialog::save_file().title("Export a scene file"),
            DialogPurpose::SaveSession => {
                egui_file::FileDialog::save_file().title("Save the session (the commands that made the hair)")
            }
        }
        .initial_path(start);
        dialog.open();
        self.dialog = Some((purpose, dialog));
    }

    pub(super) fn shortcuts(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        let undo = KeyboardShortcut::new(Modifiers::COMMAND, Key::Z);
        let redo = KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
        let redo_y = KeyboardShortcut::new(Modifiers::COMMAND, Key::Y);
        let save = KeyboardShortcut::new(Modifiers::COMMAND, Key::S);
        let open = KeyboardShortcut::new(Modifiers::COMMAND, Key::O);
        // The longer shortcut first: Ctrl+Shift+Z also matches Ctrl+Z.
        if ctx.input_mut(|i| i.consume_shortcut(&redo) || i.consume_shortcut(&redo_y)) {
            self.redo();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&undo)) {
            self.undo();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&save)) {
            self.save();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&open)) {
            self.open_dialog(DialogPurpose::Open);
        }
    }

    pub(super) fn menu_bar(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…").clicked() {
                    self.open_dialog(DialogPurpose::Open);
                }
                if ui.button("Open sample head").on_hover_text(hairmesh::convert::sample_head::PATH).clicked()
                {
                    self.open_sample_head();
                }
                ui.menu_button("Open recent", |ui| {
                    if self.recent.is_empty() {
                        ui.label("(none)");
                    }
                    for p in self.recent.clone() {
                        if ui.button(p.display().to_string()).clicked() {
                            self.open(&p);
                        }
                    }
                });
                ui.separator();
                let has_doc = self.doc.is_some();
                if ui.add_enabled(has_doc, egui::Button::new("Save")).clicked() {
                    self.save();
                }
                if ui.add_enabled(has_doc, egui::Button::new("Save As…")).clicked() {
                    self.open_dialog(DialogPurpose::SaveAs);
                }
                ui.separator();
                if ui.add_enabled(self.shown.is_some(), egui::Button::new("Export PNG…")).clicked() {
                    self.open_dialog(DialogPurpose::ExportPng);
                }
                let saved = self.doc.as_ref().is_some_and(|d| d.save_path.is_some());
                if ui
                    .add_enabled(saved, egui::Button::new("Export scene…"))
                    .on_disabled_hover_text("save the asset first: the scene names its folder")
                    .clicked()
                {
                    self.open_dialog(DialogPurpose::ExportScene);
                }
                if ui
                    .add_enabled(has_doc, egui::Button::new("Save session…"))
                    .on_hover_text("The commands that made this hairstyle (replay: hair-editor --replay SESSION.json -o ASSET)")
                    .clicked()
                {
                    self.open_dialog(DialogPurpose::SaveSession);
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    self.request_quit();
                }
            });
            ui.menu_button("Edit", |ui| {
                let (u, r) = self.doc.as_ref().map_or((false, false), |d| (d.can_undo(), d.can_redo()));
                if ui.add_enabled(u, egui::Button::new("Undo")).clicked() {
                    self.undo();
                }
                if ui.add_enabled(r, egui::Button::new("Redo")).clicked() {
                    self.redo();
                }
            });
            ui.menu_button("View", |ui| {
                ui.checkbox(&mut self.show_overlay, "Hair-mesh overlay");
                if ui.button("Frame selected (F)").clicked() {
                    self.frame_hair();
                }
            });
        });
    }

    pub(super) fn status_bar(&mut self, ui: &mut egui::Ui) {
        // The document's title is laid out first, from the right, so it keeps its place; the
        // rest fills what is left and is cut short ("…") rather than run under it.
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            if let Some(doc) = &self.doc {
                ui.label(format!("{}{}", doc.title(), if doc.is_dirty() { " •" } else { "" }));
                ui.separator();
            }
            ui.with_layout(egui::Layout::left_to_right(egui::Align::Center), |ui| {
                let text = |ui: &mut egui::Ui, text: String| ui.add(egui::Label::new(text).truncate());
                // A running transform's numbers and keys come first: they are what one reads.
                if let Some(m) = &self.modal {
                    text(ui, m.status.clone());
                    return;
                }
                text(ui, self.device.clone().unwrap_or_else(|| "starting the preview device…".into()));
                ui.separator();
                match &self.shown {
                    Some(s) => text(
                        ui,
                        format!(
                            "{} raster · {} strands · {} vertices · {}×{} {} · {:.0} ms",
                            s.raster,
                            s.strands,
                            s.vertices,
                            s.size[0],
                            s.size[1],
                            if s.draft { "draft" } else { "full" },
                            s.ms
                        ),
                    ),
                    None => text(ui, "no preview yet".into()),
                };
                if let Some(e) = &self.preview_error {
                    ui.separator();
                    ui.add(
                        egui::Label::new(
                            egui::RichText::new(format!("preview: {e}"))
                                .color(Color32::from_rgb(230, 120, 90)),
                        )
                        .truncate(),
                    );
                }
                if let Some(job) = &self.conversion {
                    ui.separator();
                    ui.add(egui::Spinner::new());
                    text(ui, format!("converting {}: {}…", job.file.display(), job.step));
                }
                if let Some(n) = &self.note {
                    ui.separator();
                    text(ui, n.clone());
                }
            });
        });
    }

    pub(super) fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some((purpose, dialog)) = &mut self.dialog {
            let purpose = *purpose;
            dialog.show(ctx);
            if dialog.selected() {
                let path = dialog.path().map(Path::to_owned);
                self.dialog = None;
                if let Some(path) = path {
                    match purpose {
                        DialogPurpose::Open => self.open(&path),
                        DialogPurpose::SaveAs => self.save_as(&path),
                        DialogPurpose::ExportPng => self.export_png(&with_extension(&path, "png")),
                        DialogPurpose::ExportScene => self.export_scene(&with_extension(&path, "json")),
                        DialogPurpose::SaveSession => self.save_session(&with_extension(&path, "json")),
                    }
                }
            } else if !dialog.visible() {
                self.dialog = None;
            }
        }
        if let Some(message) = self.error.clone() {
            let modal = egui::Modal::new(egui::Id::unique("error")).show(ctx, |ui| {
                ui.heading("Error");
                ui.label(message);
                ui.button("OK").clicked()
            });
            if modal.inner || modal.should_close() {
                self.error = None;
            }
        }
        if let Some(action) = self.pending.clone() {
            let title = self.doc.as_ref().map(Document::title).unwrap_or_default();
            let modal = egui::Modal::new(egui::Id::unique("unsaved")).show(ctx, |ui| {
                ui.heading("Unsaved changes");
                ui.label(format!("{title} has changes that are not saved."));
                ui.horizontal(|ui| {
                    if ui.button("Save").clicked() {
                        return Some(true);
                    }
                    if ui.button("Discard").clicked() {
                        return Some(false);
                    }
                    if ui.button("Cancel").clicked() {
                        self.pending = None;
                    }
                    None
                })
                .inner
            });
            if modal.should_close() {
                self.pending = None;
            }
            if let Some(save) = modal.inner {
                self.pending = None;
                if save {
                    self.save();
                }
                let saved = self.doc.as_ref().is_none_or(|d| !d.is_dirty());
                if !save || saved {
                    match action {
                        PendingAction::Open(path) => {
                            self.doc = None;
                            self.open_now(&path);
                        }
                        PendingAction::Quit => self.quit = true,
                    }
                }
            }
        }
    }
}
