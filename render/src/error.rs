//! render's error type.

use crate::scene::SceneError;

/// What can go wrong loading or rendering a scene.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("{}", asset_message(path, source))]
    Asset {
        path: std::path::PathBuf,
        #[source]
        source: hairmesh::HairMeshError,
    },
    #[error(transparent)]
    Gpu(#[from] gen_gpu::GpuError),
    /// The planned frame graph cannot run (a renderer bug, not the scene's).
    #[error("the frame graph cannot run: {error}")]
    Graph { error: crate::graph::GraphError },
    #[error("no character with generated hair has the key `{key}`")]
    UnknownHair { key: String },
    #[error(
        "the compute rasterizer (\"raster\": \"compute\") cannot draw this scene: {why}; use \"auto\" or \"triangles\""
    )]
    RasterUnavailable { why: String },
    #[error("cannot render this view: {why}")]
    InvalidView { why: String },
    #[error("{path}: {message}")]
    Animation { path: std::path::PathBuf, message: String },
    #[error("{path}: lights[{light}]: {message}")]
    Light { path: std::path::PathBuf, light: usize, message: String },
}

impl From<crate::graph::GraphError> for RenderError {
    fn from(error: crate::graph::GraphError) -> Self {
        Self::Graph { error }
    }
}

/// An asset error names its file once: hairmesh's errors mostly start with the path already.
fn asset_message(path: &std::path::Path, source: &hairmesh::HairMeshError) -> String {
    let text = source.to_string();
    if text.contains(&path.display().to_string()) { text } else { format!("{}: {text}", path.display()) }
}
