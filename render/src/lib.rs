//! hairkit's renderer. Today: writing rendered images to disk and the `hairkit` command
//! (`info`, `demo`). The strand rasterizer, scenes and the volume path build on this.

pub mod output;

pub use gen_gpu::diagnostics::RgbaImage;
