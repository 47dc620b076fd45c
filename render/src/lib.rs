//! hairkit's renderer. Today: crowds of characters with generated hair drawn into one image,
//! image output and the `hairkit` command (`info`, `demo`). The strand rasterizer's shading,
//! transparency, shadows, scenes and the volume path build on this.

pub mod crowd;
pub mod frame;
pub mod output;
pub mod scene;
pub mod shadow;

pub use gen_gpu::diagnostics::RgbaImage;
