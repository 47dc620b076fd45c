fn main() {
    shader_build::compile_shader_dir("shaders");
}
