//! hairkit's renderer: scenes ([`scene`]) of characters whose hair is generated on the fly
//! (or explicit strands), rendered by [`frame::SceneRenderer`] with the passes their effects
//! ask for: hair shading with coverage AA, order-independent transparency, deep-opacity-map
//! self-shadowing ([`shadow`]), the compute rasterizer ([`raster`]), hair volumes for the volume
//! LOD path and ambient occlusion ([`volume`]). Also cameras ([`camera`]) and image output ([`output`]). A
//! library only: the `hairkit`, `hair-render` and `hair-bench` commands, crowd-scene writing
//! and plots live in the `hairkit-cli` crate (`cli/`).

pub mod animation;
pub mod camera;
pub mod contract;
pub mod cpu;
pub mod error;
pub mod frame;
pub mod graph;
pub mod instance;
pub mod occluder;
pub mod output;
pub mod passes;
pub mod raster;
pub mod scene;
pub mod shadow;
pub mod sim_cache;
pub mod target;
pub mod volume;

pub use error::RenderError;
pub use gen_gpu::RgbaImage;

/// The SPIR-V of this crate's shaders, compiled from `render/shaders` at build time.
pub mod shaders {
    pub use shader_build::{ShaderSpirv, ShaderStage};
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

// render's consumer bindings follow gen-gpu's own.
const _: () = {
    let mut i = 0;
    while i < contract::OIT_FILL_BINDINGS.len() {
        assert!(contract::OIT_FILL_BINDINGS[i] >= gen_gpu::contract::binding::FIRST_CONSUMER);
        i += 1;
    }
};
