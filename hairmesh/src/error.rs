use std::path::PathBuf;

/// Everything that can go wrong in `hairmesh`. Errors about files name the file.
#[derive(Debug, thiserror::Error)]
pub enum HairMeshError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error(
        "{path}: requires the glTF extension {extension}, which hairmesh cannot decode; re-export the file without mesh compression"
    )]
    UnsupportedExtension { path: PathBuf, extension: String },
    #[error("{path}: no triangles or polygons to use as a scalp{detail}")]
    NoFaces { path: PathBuf, detail: String },
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error("invalid {what}: {message}")]
    InvalidParameter { what: &'static str, message: String },
}

pub type Result<T, E = HairMeshError> = std::result::Result<T, E>;
