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
pub mod backend;
pub mod contract;
pub mod diagnostics;
mod dispatch_order;
mod error;
mod generator;
mod hair;
mod path;
mod stored;

pub use ash::vk;
pub use backend::caps::{Capabilities, MeshShaderLimits};
pub use backend::command::{Attachments, FrameTimings, PassSummary, PassTiming, Recorder, TimingSummary};
pub use backend::context::{Context, ContextDesc, Validation, ValidationMessage};
pub use backend::pipeline::{
    Binding, Blend, ComputePipeline, ComputePipelineDesc, GraphicsPipeline, GraphicsPipelineDesc,
    GraphicsStages, Pipeline,
};
pub use backend::resource::{Buffer, BufferDesc, Image, ImageDesc, Sampler, sample_count};
pub use backend::target::{RenderTarget, RgbaImage};
pub use dispatch_order::dispatch_order;
pub use error::{GpuError, Result};
pub use generator::{
    COLOR_FORMAT, Capture, CapturedStrand, DEPTH_FORMAT, DrawExtras, FRAGMENT_PUSH_OFFSET, Filtering,
    FragmentStage, FrameBuffers, FrameInputs, GenerationStats, Generator, GeneratorOptions, MAX_VERTICES,
    SlotSubset, VERTEX_BYTES, strand_bindings, view_matrix,
};
pub use gpu_allocator::MemoryLocation;
pub use hair::{GpuHair, HairUpdate, StagedHairUpdate, TextureBytes, TexturePrecision};
pub use path::{GenerationPath, PathChoice};
pub use stored::{StoredChunk, StoredStrands};

/// The SPIR-V modules of this crate, compiled from `gen-gpu/shaders` at build time.
pub mod shaders {
    pub use shader_build::{ShaderSpirv, ShaderStage};
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

/// The GLSL header generated from [`contract`] at build time (what the shaders `#include`).
pub const CONTRACT_GLSL: &str = include_str!(concat!(env!("OUT_DIR"), "/include/hk_gen_contract.glsl"));

#[cfg(test)]
mod contract_tests {
    use super::contract::{self, binding, location};

    /// `#define NAME VALUEu` lines of the generated header.
    fn defines() -> std::collections::HashMap<String, u64> {
        super::CONTRACT_GLSL
            .lines()
            .filter_map(|l| l.strip_prefix("#define "))
            .filter_map(|l| {
                let (name, value) = l.split_once(' ')?;
                Some((name.to_owned(), value.strip_suffix('u')?.parse().ok()?))
            })
            .collect()
    }

    #[test]
    fn the_generated_header_agrees_with_the_rust_constants() {
        let d = defines();
        let expect = [
            ("HK_BINDING_GEN_PARAMS", u64::from(binding::GEN_PARAMS)),
            ("HK_BINDING_BUNDLES", u64::from(binding::BUNDLES)),
            ("HK_BINDING_ROOT_SAMPLES", u64::from(binding::ROOT_SAMPLES)),
            ("HK_BINDING_SAMPLE_SETS", u64::from(binding::SAMPLE_SETS)),
            ("HK_BINDING_HAIR_MESH_TEXTURE", u64::from(binding::HAIR_MESH_TEXTURE)),
            ("HK_BINDING_U_TEXTURE", u64::from(binding::U_TEXTURE)),
            ("HK_BINDING_V_TEXTURE", u64::from(binding::V_TEXTURE)),
            ("HK_BINDING_HEAD_FIELD", u64::from(binding::HEAD_FIELD)),
            ("HK_BINDING_BUNDLE_LODS", u64::from(binding::BUNDLE_LODS)),
            ("HK_BINDING_STRAND_OFFSETS", u64::from(binding::STRAND_OFFSETS)),
            ("HK_BINDING_STRAND_VERTICES", u64::from(binding::STRAND_VERTICES)),
            ("HK_BINDING_STRAND_INFO", u64::from(binding::STRAND_INFO)),
            ("HK_BINDING_FIRST_CONSUMER", u64::from(binding::FIRST_CONSUMER)),
            ("HK_LOCATION_POSITION_TAU", u64::from(location::POSITION_TAU)),
            ("HK_LOCATION_TANGENT_RANDOM", u64::from(location::TANGENT_RANDOM)),
            ("HK_LOCATION_COVERAGE_SIDE", u64::from(location::COVERAGE_SIDE)),
            ("HK_FRAGMENT_PUSH_OFFSET", u64::from(contract::FRAGMENT_PUSH_OFFSET)),
            ("HK_MAX_SEGMENTS_LOG2", u64::from(contract::MAX_SEGMENTS_LOG2)),
            ("HK_MAX_VERTICES", contract::MAX_VERTICES),
            ("HK_MAX_LAYERS", u64::from(contract::MAX_LAYERS)),
        ];
        for (name, value) in expect {
            assert_eq!(d.get(name), Some(&value), "{name} in the generated header");
        }
        assert_eq!(d.len(), contract::GLSL_DEFINES.len(), "every define is generated once");
        // The generator's own bindings stay below the consumers'.
        assert!(contract::BINDINGS.iter().all(|&b| b < binding::FIRST_CONSUMER));
        assert_eq!(contract::MAX_VERTICES, (1 << hairmesh::reference::MAX_SEGMENTS_LOG2) + 1);
    }

    #[test]
    fn every_module_uses_only_declared_bindings() {
        for module in super::shaders::ALL {
            let used = shader_build::reflect_bindings(module.spirv).expect("reflectable SPIR-V");
            for b in used {
                assert!(contract::BINDINGS.contains(&b), "{} uses undeclared binding {b}", module.name);
            }
        }
    }
}
