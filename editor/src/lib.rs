//! `hair-editor`: the egui styling application (issue: editor). Not built yet: this crate holds
//! the workspace slot so that the editor's dependencies stay out of the other crates.
