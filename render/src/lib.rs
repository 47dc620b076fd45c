//! hairkit's renderer: scenes ([`scene`]) of characters whose hair is generated on the fly
//! (or explicit strands), rendered by [`frame::SceneRenderer`] with the passes their effects
//! ask for: hair shading with coverage AA, order-independent transparency, deep-opacity-map
//! self-shadowing ([`shadow`]). Also image output ([`output`]), a plain crowd renderer with
//! gen-gpu's placeholder shading for benchmarks ([`crowd`]), and the `hairkit`, `hair-render`
//! and `hair-bench` commands.

pub mod crowd;
pub mod crowd_scenes;
pub mod frame;
pub mod occluder;
pub mod output;
pub mod plots;
pub mod scene;
pub mod shadow;
pub mod target;

pub use gen_gpu::diagnostics::RgbaImage;
