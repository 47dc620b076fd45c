//! Compiles `shaders/` under the generator contract (`src/contract.rs`), whose constants become
//! the GLSL header `hk_gen_contract.glsl`. Its folder is passed to dependants' build scripts as
//! `DEP_HAIRKIT_GEN_GPU_INCLUDE` (this package's `links` key), the declared bindings as
//! `DEP_HAIRKIT_GEN_GPU_BINDINGS`, the shader folder (for consumers that `#include
//! "hair_gen.glsl"` to generate inside their own shaders) as `DEP_HAIRKIT_GEN_GPU_SHADERS`.

#[allow(dead_code, reason = "build.rs uses only the tables of the contract")]
#[path = "src/contract.rs"]
mod contract;

fn main() {
    println!("cargo:rerun-if-changed=src/contract.rs");
    let header = shader_build::GlslHeader {
        file_name: contract::HEADER_FILE.into(),
        title: "gen-gpu's generator contract (gen-gpu/src/contract.rs)".into(),
        defines: contract::GLSL_DEFINES.iter().map(|(name, value)| ((*name).to_owned(), *value)).collect(),
    };
    let spec = shader_build::Contract {
        headers: vec![header],
        include_dirs: vec![],
        bindings: contract::BINDINGS.to_vec(),
    };
    shader_build::compile_shader_dir_with("shaders", &spec);
    match shader_build::include_dir() {
        Ok(dir) => println!("cargo:include={}", dir.display()),
        Err(e) => panic!("{e}"),
    }
    // Consumers that generate inside their own shaders include hair_gen.glsl from here.
    match std::env::var("CARGO_MANIFEST_DIR") {
        Ok(dir) => println!("cargo:shaders={}", std::path::Path::new(&dir).join("shaders").display()),
        Err(e) => panic!("CARGO_MANIFEST_DIR: {e}"),
    }
    let bindings: Vec<String> = contract::BINDINGS.iter().map(u32::to_string).collect();
    println!("cargo:bindings={}", bindings.join(","));
}
