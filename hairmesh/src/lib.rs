//! Hair meshes: the data model, scalp import, curves between layers, blue-noise root sets and
//! (in progress) the textures and the CPU f64 reference strand generator. No Vulkan here.
//!
//! Formulas follow `DESIGN.md` (the corrected versions of the hair-mesh paper's equations).

pub mod asset;
pub mod asset_io;
pub mod atomic;
pub mod convert;
pub mod curve;
pub mod dynamics;
mod error;
pub mod export;
mod gltf_source;
pub mod hair_mesh;
pub mod head;
pub mod head_field;
pub mod head_frame;
pub mod import;
pub mod inner;
pub mod input;
pub mod lattice;
pub mod layer_ops;
pub mod output;
pub mod procedural;
pub mod reference;
pub mod rng;
pub mod roots;
pub mod scalp;
pub mod strands;
pub mod style;
pub mod teapot;
pub mod terminal;
pub mod texture;

pub use error::{HairMeshError, Result};
pub use hair_mesh::{BundleFace, DrapeParams, ExtrudeParams, HairMesh};
pub use scalp::{ScalpMesh, ScalpSelector};
