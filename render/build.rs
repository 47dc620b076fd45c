//! Compiles `shaders/` under render's binding contract (`src/contract.rs` → the generated
//! `hk_render_contract.glsl`) with gen-gpu's generated `hk_gen_contract.glsl` on the include
//! path (cargo passes its folder as `DEP_HAIRKIT_GEN_GPU_INCLUDE`), and gen-gpu's shader folder
//! (`DEP_HAIRKIT_GEN_GPU_SHADERS`) for the compute rasterizer's fused generation.

#[allow(dead_code, reason = "build.rs uses only the tables of the contract")]
#[path = "src/contract.rs"]
mod contract;

fn main() {
    println!("cargo:rerun-if-changed=src/contract.rs");
    let gen_include = std::env::var("DEP_HAIRKIT_GEN_GPU_INCLUDE")
        .unwrap_or_else(|_| panic!("gen-gpu's build script did not pass its contract header folder"));
    // The compute rasterizer generates strands inside its own shader: it includes gen-gpu's
    // hair_gen.glsl and binds gen-gpu's bindings besides render's.
    let gen_shaders = std::env::var("DEP_HAIRKIT_GEN_GPU_SHADERS")
        .unwrap_or_else(|_| panic!("gen-gpu's build script did not pass its shader folder"));
    let gen_bindings: Vec<u32> = std::env::var("DEP_HAIRKIT_GEN_GPU_BINDINGS")
        .unwrap_or_else(|_| panic!("gen-gpu's build script did not pass its bindings"))
        .split(',')
        .map(|b| b.parse().unwrap_or_else(|e| panic!("gen-gpu binding {b:?}: {e}")))
        .collect();
    let header = shader_build::GlslHeader {
        file_name: contract::HEADER_FILE.into(),
        title: "render's consumer contract (render/src/contract.rs)".into(),
        defines: contract::GLSL_DEFINES
            .iter()
            .chain(contract::GLSL_CONSTANTS)
            .map(|(name, value)| ((*name).to_owned(), *value))
            .collect(),
    };
    let spec = shader_build::Contract {
        headers: vec![header],
        include_dirs: vec![gen_include.into(), gen_shaders.into()],
        bindings: contract::BINDINGS.iter().copied().chain(gen_bindings).collect(),
    };
    shader_build::compile_shader_dir_with("shaders", &spec);
}
