//! `hair-editor`: an egui application to shape hair meshes and style hair with a live preview.
//!
//! The crate is split the way egui apps are tested: **state** that knows nothing about
//! drawing ([`document::Document`]: the asset, edits, undo/redo, saving;
//! [`camera::OrbitCamera`]: the viewport camera and the projection the overlay and picking
//! share with the renderer), the **preview worker** ([`preview::PreviewWorker`]: hairkit's
//! renderer on its own Vulkan device in a thread, latest request wins), and the **UI**
//! ([`app::EditorApp::ui`]), a function of that state that `egui_kittest` drives headlessly
//! in the tests and `eframe` drives in a window (`src/main.rs`).

pub mod app;
pub mod brush;
pub mod camera;
pub mod document;
pub mod presets;
pub mod preview;
pub mod scalp_paint;
pub mod sculpt;
pub mod session;
pub mod transform;
pub mod xwd;

use std::path::PathBuf;

/// What can go wrong while editing; every message names the file and the problem.
#[derive(Debug, thiserror::Error)]
pub enum EditorError {
    #[error("{}: {source}", path.display())]
    Asset { path: PathBuf, source: hairmesh::HairMeshError },
    #[error("{}: {message}", path.display())]
    Mesh { path: PathBuf, message: String },
    #[error("{}: {message}", path.display())]
    Io { path: PathBuf, message: String },
    #[error("edit refused: {source}")]
    Edit { source: hairmesh::HairMeshError },
    #[error("{}: not a scalp mesh (.glb, .gltf, .obj) or a hair asset (a folder with hair.json)", path.display())]
    UnknownFile { path: PathBuf },
    #[error("the document has not been saved yet: use Save As")]
    NoSavePath,
    #[error("nothing to export yet: the preview has not rendered a frame")]
    NoFrame,
    #[error("preview: {message}")]
    Preview { message: String },
}
