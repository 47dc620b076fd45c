//! Vulkan through `ash` for hairkit: a headless context, RAII resources, build-time shaders,
//! per-pass GPU timing, and (built on these) on-the-fly strand generation.
//!
//! ```no_run
//! use gen_gpu::{Context, ContextDesc};
//! let ctx = Context::new(&ContextDesc::default())?;
//! println!("{}", ctx.capabilities());
//! # Ok::<(), gen_gpu::GpuError>(())
//! ```

pub mod accuracy;
mod caps;
mod command;
mod context;
pub mod diagnostics;
mod error;
mod generator;
mod hair;
mod path;
mod pipeline;
mod resource;
mod stored;

pub use ash::vk;
pub use caps::{Capabilities, MeshShaderLimits};
pub use command::{Attachments, FrameTimings, PassTiming, Recorder};
pub use context::{Context, ContextDesc, Validation, ValidationMessage};
pub use error::{GpuError, Result};
pub use generator::{
    COLOR_FORMAT, Capture, CapturedStrand, DEPTH_FORMAT, DrawExtras, FRAGMENT_PUSH_OFFSET, Filtering,
    FragmentStage, FrameBuffers, FrameInputs, GenerationStats, Generator, GeneratorOptions, MAX_VERTICES,
    VERTEX_BYTES,
};
pub use gpu_allocator::MemoryLocation;
pub use hair::{GpuHair, TextureBytes, TexturePrecision};
pub use path::{GenerationPath, PathChoice};
pub use pipeline::{
    Binding, Blend, ComputePipeline, ComputePipelineDesc, GraphicsPipeline, GraphicsPipelineDesc,
    GraphicsStages, Pipeline,
};
pub use resource::{Buffer, BufferDesc, Image, ImageDesc, Sampler, sample_count};
pub use stored::StoredStrands;

/// The SPIR-V modules of this crate, compiled from `gen-gpu/shaders` at build time.
pub mod shaders {
    pub use shader_build::{ShaderSpirv, ShaderStage};
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}
