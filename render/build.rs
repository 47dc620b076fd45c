//! Compiles `shaders/` under render's binding contract (`src/contract.rs` → the generated
//! `hk_render_contract.glsl`) with gen-gpu's generated `hk_gen_contract.glsl` on the include
//! path (cargo passes its folder as `DEP_HAIRKIT_GEN_GPU_INCLUDE`).

#[allow(dead_code, reason = "build.rs uses only the tables of the contract")]
#[path = "src/contract.rs"]
mod contract;

fn main() {
    println!("cargo:rerun-if-changed=src/contract.rs");
    let gen_include = std::env::var("DEP_HAIRKIT_GEN_GPU_INCLUDE")
        .unwrap_or_else(|_| panic!("gen-gpu's build script did not pass its contract header folder"));
    let header = shader_build::GlslHeader {
        file_name: contract::HEADER_FILE.into(),
        title: "render's consumer contract (render/src/contract.rs)".into(),
        defines: contract::GLSL_DEFINES.iter().map(|(name, value)| ((*name).to_owned(), *value)).collect(),
    };
    let spec = shader_build::Contract {
        headers: vec![header],
        include_dirs: vec![gen_include.into()],
        bindings: contract::BINDINGS.to_vec(),
    };
    shader_build::compile_shader_dir_with("shaders", &spec);
}
