//! Build-time GLSL → SPIR-V for the crates that run shaders, and the typed description of each
//! compiled module that those crates embed.
//!
//! A crate's `build.rs` calls [`compile_shader_dir`]; it compiles every stage file
//! (`*.comp`, `*.vert`, `*.frag`, `*.task`, `*.mesh`) with `glslangValidator`, reads the
//! compiler's dependency file so that editing an `#include`d file triggers a rebuild, and writes
//! `shaders.rs` into `OUT_DIR` with one [`ShaderSpirv`] constant per module (name in upper snake
//! case: `strips.mesh` → `STRIPS_MESH`) plus `ALL`. Compile errors are shown as
//! `cargo:warning=file:line: message` and fail the build.
//!
//! [`compile_shader_dir_with`] adds a *binding contract*: GLSL headers generated from the
//! calling crate's Rust constants are written into `OUT_DIR/include` (so `#include` finds them),
//! every `binding = <number>` literal in the crate's GLSL is refused (bindings come from the
//! generated macros), and every descriptor binding of every compiled module must be one the
//! contract declares — a shader that uses an undeclared binding fails the build.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A pipeline stage, read from the module's `OpEntryPoint`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShaderStage {
    Vertex,
    Fragment,
    Compute,
    Task,
    Mesh,
}

/// One compiled module with the metadata read from its SPIR-V.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSpirv {
    /// Source file name, e.g. `strips.mesh`.
    pub name: &'static str,
    pub stage: ShaderStage,
    /// `local_size_{x,y,z}`; `[1, 1, 1]` for stages without one.
    pub workgroup_size: [u32; 3],
    /// SPIR-V words, little-endian bytes as the compiler wrote them.
    pub spirv: &'static [u8],
    /// The push-constant block's byte range `[first member's offset, end of the last]`, read
    /// from the module (`None`: it declares none): what the Rust side must push there.
    pub push_constants: Option<[u32; 2]>,
}

impl ShaderSpirv {
    /// The module as 32-bit words (copies, since embedded bytes carry no alignment guarantee).
    pub fn words(&self) -> Vec<u32> {
        self.spirv.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
    }
}

const STAGE_EXTENSIONS: &[&str] = &["comp", "vert", "frag", "task", "mesh"];

/// A generated GLSL header: `#define` lines written from Rust constants.
#[derive(Clone, Debug, Default)]
pub struct GlslHeader {
    /// File name the shaders `#include`, e.g. `hk_gen_contract.glsl`.
    pub file_name: String,
    /// What the header is for (its first comment line).
    pub title: String,
    /// `(macro, value)` pairs, written as `#define MACRO VALUEu` (unsigned, as GLSL bindings and
    /// counts are).
    pub defines: Vec<(String, u64)>,
}

impl GlslHeader {
    /// The header's text.
    pub fn text(&self) -> String {
        let guard = self.file_name.replace(['.', '-'], "_").to_uppercase();
        let mut text = format!(
            "// {}\n// Generated at build time from Rust constants by shader-build. Do not edit.\n#ifndef {guard}\n#define {guard}\n",
            self.title
        );
        for (name, value) in &self.defines {
            let _ = writeln!(text, "#define {name} {value}u");
        }
        text.push_str("#endif\n");
        text
    }
}

/// The binding contract of a crate's shaders (see the crate docs).
#[derive(Clone, Debug, Default)]
pub struct Contract {
    /// Headers to generate into `OUT_DIR/include`.
    pub headers: Vec<GlslHeader>,
    /// More folders to search for `#include`s (a dependency's generated headers).
    pub include_dirs: Vec<PathBuf>,
    /// Every descriptor binding (set 0) a module of this crate may use.
    pub bindings: Vec<u32>,
}

/// Compiles every stage file in `dir` (relative to the calling crate's manifest) into `OUT_DIR`
/// and writes `OUT_DIR/shaders.rs`. Call from `build.rs`; panics with the compiler's messages on
/// failure, which is how a build script reports errors.
pub fn compile_shader_dir(dir: &str) {
    report(try_compile_shader_dir(dir, None));
}

/// [`compile_shader_dir`] under a binding [`Contract`].
pub fn compile_shader_dir_with(dir: &str, contract: &Contract) {
    report(try_compile_shader_dir(dir, Some(contract)));
}

fn report(result: Result<(), String>) {
    if let Err(message) = result {
        for line in message.lines() {
            println!("cargo:warning={line}");
        }
        panic!("shader compilation failed:\n{message}");
    }
}

/// Where [`compile_shader_dir_with`] writes the generated headers (`OUT_DIR/include`).
pub fn include_dir() -> Result<PathBuf, String> {
    Ok(PathBuf::from(std::env::var("OUT_DIR").map_err(|e| e.to_string())?).join("include"))
}

/// `binding = <digits>` in GLSL source outside comments: bindings must come from the contract's
/// macros. Returns `(line number, line)` of each.
pub fn binding_literals(source: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (number, line) in source.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find("binding") {
            let after = rest[at + "binding".len()..].trim_start();
            if let Some(value) = after.strip_prefix('=')
                && value.trim_start().starts_with(|c: char| c.is_ascii_digit())
            {
                found.push((number + 1, line.trim().to_owned()));
                break;
            }
            rest = &rest[at + "binding".len()..];
        }
    }
    found
}

fn try_compile_shader_dir(dir: &str, contract: Option<&Contract>) -> Result<(), String> {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").map_err(|e| e.to_string())?);
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").map_err(|e| e.to_string())?);
    let src_dir = manifest.join(dir);
    println!("cargo:rerun-if-changed={}", src_dir.display());
    compile_dir(&src_dir, &out_dir, contract)
}

fn compile_dir(src_dir: &Path, out_dir: &Path, contract: Option<&Contract>) -> Result<(), String> {
    let src_dir = src_dir.to_path_buf();
    let mut include_dirs = vec![src_dir.clone()];
    // Every file of the folder (stages and includes), listed once.
    let mut all_sources: Vec<PathBuf> = std::fs::read_dir(&src_dir)
        .map_err(|e| format!("cannot read shader folder {}: {e}", src_dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    all_sources.sort();
    if let Some(contract) = contract {
        let generated = out_dir.join("include");
        std::fs::create_dir_all(&generated).map_err(|e| format!("{}: {e}", generated.display()))?;
        for header in &contract.headers {
            let path = generated.join(&header.file_name);
            let text = header.text();
            // Rewritten only when it changes, so dependants do not rebuild for nothing.
            if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
                std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
            }
        }
        include_dirs.push(generated);
        include_dirs.extend(contract.include_dirs.iter().cloned());
        let mut literals = String::new();
        for src in &all_sources {
            let text = std::fs::read_to_string(src).unwrap_or_default();
            for (line, code) in binding_literals(&text) {
                let _ = writeln!(
                    literals,
                    "{}:{line}: ERROR: a binding number written as a literal (`{code}`); use the contract's macro",
                    src.display()
                );
            }
        }
        if !literals.is_empty() {
            return Err(literals);
        }
    }
    let compiler = std::env::var("GLSLANG_VALIDATOR").unwrap_or_else(|_| "glslangValidator".into());
    println!("cargo:rerun-if-env-changed=GLSLANG_VALIDATOR");

    let sources: Vec<PathBuf> = all_sources
        .into_iter()
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| STAGE_EXTENSIONS.contains(&e)))
        .collect();

    let mut module =
        String::from("// Generated by shader-build from the GLSL in this crate. Do not edit.\n\n");
    let mut all = Vec::new();
    let mut errors = String::new();
    for src in &sources {
        let file_name = src
            .file_name()
            .and_then(|n| n.to_str())
            .ok_or_else(|| format!("non-UTF-8 shader file name {}", src.display()))?;
        let spv = out_dir.join(format!("{file_name}.spv"));
        let dep = out_dir.join(format!("{file_name}.d"));
        let output = Command::new(&compiler)
            .args(["-V", "--target-env", "vulkan1.3", "-g"])
            .args(include_dirs.iter().map(|d| format!("-I{}", d.display())))
            .arg("--depfile")
            .arg(&dep)
            .arg("-o")
            .arg(&spv)
            .arg(src)
            .output()
            .map_err(|e| {
                format!(
                    "cannot run `{compiler}` ({e}). Install glslang-tools, e.g. with `cargo xtask setup`."
                )
            })?;
        if !output.status.success() {
            let text = String::from_utf8_lossy(&output.stdout).to_string()
                + &String::from_utf8_lossy(&output.stderr);
            for line in text.lines().filter(|l| l.contains("ERROR") || l.contains("WARNING")) {
                let _ = writeln!(errors, "{line}");
            }
            continue;
        }
        for included in read_depfile(&dep) {
            println!("cargo:rerun-if-changed={}", included.display());
        }
        let bytes = std::fs::read(&spv).map_err(|e| format!("cannot read {}: {e}", spv.display()))?;
        let info = reflect(&bytes).map_err(|e| format!("{file_name}: {e}"))?;
        if let Some(contract) = contract {
            for binding in &info.bindings {
                if !contract.bindings.contains(binding) {
                    let _ = writeln!(
                        errors,
                        "{}: ERROR: uses descriptor binding {binding}, which the binding contract does not declare (declared: {:?})",
                        src.display(),
                        contract.bindings
                    );
                }
            }
        }
        let const_name = file_name.replace(['.', '-'], "_").to_uppercase();
        let _ = writeln!(
            module,
            "pub const {const_name}: ShaderSpirv = ShaderSpirv {{\n    name: {file_name:?},\n    \
             stage: ShaderStage::{:?},\n    workgroup_size: {:?},\n    spirv: include_bytes!({:?}),\n    \
             push_constants: {:?},\n}};\n",
            info.stage,
            info.workgroup_size,
            spv.display().to_string(),
            info.push_constants
        );
        all.push(const_name);
    }
    if !errors.is_empty() {
        return Err(errors);
    }
    let _ = writeln!(
        module,
        "/// Every module of this crate, for validation tests.\npub const ALL: &[ShaderSpirv] = &[{}];",
        all.join(", ")
    );
    std::fs::write(out_dir.join("shaders.rs"), module).map_err(|e| e.to_string())
}

/// The files a glslang dependency file lists (`out.spv: a.comp b.glsl ...`).
fn read_depfile(path: &Path) -> Vec<PathBuf> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let deps = text.split_once(": ").map_or("", |(_, d)| d);
    deps.split_whitespace().filter(|d| *d != "\\").map(PathBuf::from).collect()
}

#[derive(Debug, PartialEq, Eq)]
struct Reflection {
    stage: ShaderStage,
    workgroup_size: [u32; 3],
    /// Every `Binding` decoration, sorted, without repeats.
    bindings: Vec<u32>,
    /// The push-constant block's byte range, if the module declares one.
    push_constants: Option<[u32; 2]>,
}

/// The descriptor bindings a SPIR-V module declares (its `Binding` decorations), sorted.
pub fn reflect_bindings(bytes: &[u8]) -> Result<Vec<u32>, String> {
    reflect(bytes).map(|r| r.bindings)
}

/// The byte range of a SPIR-V module's push-constant block: from its first member's offset to
/// the end of its last (`None` if it declares no push constants).
pub fn reflect_push_constants(bytes: &[u8]) -> Result<Option<[u32; 2]>, String> {
    reflect(bytes).map(|r| r.push_constants)
}

/// What the push-constant reflection needs of a module's types: sizes follow the explicit
/// layout (`Offset`, `ArrayStride`, `MatrixStride`) the compiler wrote.
#[derive(Debug, Default)]
struct Types {
    /// Scalar, vector, matrix, array and pointer types: (kind, operands after the result id).
    defs: std::collections::HashMap<u32, (u32, Vec<u32>)>,
    /// Struct members' offsets and matrix strides.
    member_offsets: std::collections::HashMap<(u32, u32), u32>,
    member_matrix_strides: std::collections::HashMap<(u32, u32), u32>,
    array_strides: std::collections::HashMap<u32, u32>,
}

impl Types {
    const OP_TYPE_BOOL: u32 = 20;
    const OP_TYPE_INT: u32 = 21;
    const OP_TYPE_FLOAT: u32 = 22;
    const OP_TYPE_VECTOR: u32 = 23;
    const OP_TYPE_MATRIX: u32 = 24;
    const OP_TYPE_ARRAY: u32 = 28;
    const OP_TYPE_STRUCT: u32 = 30;
    const OP_TYPE_POINTER: u32 = 32;

    /// The bytes a value of type `id` takes (a member of struct `parent` at `member` for
    /// matrices, whose stride is a member decoration).
    fn size(
        &self,
        id: u32,
        member_of: Option<(u32, u32)>,
        constants: &std::collections::HashMap<u32, u32>,
        depth: u32,
    ) -> Result<u32, String> {
        if depth > 16 {
            return Err("push-constant types nest too deep".into());
        }
        let (kind, ops) =
            self.defs.get(&id).ok_or_else(|| format!("push-constant member of unknown type %{id}"))?;
        Ok(match *kind {
            Self::OP_TYPE_BOOL => 4,
            Self::OP_TYPE_INT | Self::OP_TYPE_FLOAT => ops[0] / 8,
            Self::OP_TYPE_VECTOR => self.size(ops[0], None, constants, depth + 1)? * ops[1],
            Self::OP_TYPE_MATRIX => {
                let stride = member_of
                    .and_then(|m| self.member_matrix_strides.get(&m).copied())
                    .map_or_else(|| self.size(ops[0], None, constants, depth + 1), Ok)?;
                stride * ops[1]
            }
            Self::OP_TYPE_ARRAY => {
                let length = constants.get(&ops[1]).copied().ok_or("array length is not a constant")?;
                let stride = match self.array_strides.get(&id) {
                    Some(s) => *s,
                    None => self.size(ops[0], None, constants, depth + 1)?,
                };
                stride * length
            }
            Self::OP_TYPE_STRUCT => self.extent(id, constants, depth + 1)?.map_or(0, |[_, end]| end),
            // A pointer in a push-constant block is a physical-storage-buffer address.
            Self::OP_TYPE_POINTER => 8,
            other => return Err(format!("push-constant member of unsupported type (opcode {other})")),
        })
    }

    /// `[first member's offset, end of the last]` of struct `id`.
    fn extent(
        &self,
        id: u32,
        constants: &std::collections::HashMap<u32, u32>,
        depth: u32,
    ) -> Result<Option<[u32; 2]>, String> {
        let (_, members) = self.defs.get(&id).ok_or_else(|| format!("unknown struct %{id}"))?;
        let mut range: Option<[u32; 2]> = None;
        for (m, &member_type) in members.iter().enumerate() {
            let m = m as u32;
            let offset =
                *self.member_offsets.get(&(id, m)).ok_or("push-constant member without an Offset")?;
            let end = offset + self.size(member_type, Some((id, m)), constants, depth)?;
            range = Some(match range {
                None => [offset, end],
                Some([lo, hi]) => [lo.min(offset), hi.max(end)],
            });
        }
        Ok(range)
    }
}

/// Reads the entry point's execution model, `LocalSize`, bindings and push-constant range from
/// a SPIR-V module.
fn reflect(bytes: &[u8]) -> Result<Reflection, String> {
    const MAGIC: u32 = 0x0723_0203;
    const OP_ENTRY_POINT: u32 = 15;
    const OP_EXECUTION_MODE: u32 = 16;
    const OP_EXECUTION_MODE_ID: u32 = 331;
    const OP_CONSTANT: u32 = 43;
    const OP_SPEC_CONSTANT: u32 = 50;
    const OP_DECORATE: u32 = 71;
    const OP_MEMBER_DECORATE: u32 = 72;
    const OP_VARIABLE: u32 = 59;
    const DECORATION_BINDING: u32 = 33;
    const DECORATION_ARRAY_STRIDE: u32 = 6;
    const DECORATION_MATRIX_STRIDE: u32 = 7;
    const DECORATION_OFFSET: u32 = 35;
    const STORAGE_PUSH_CONSTANT: u32 = 9;
    const MODE_LOCAL_SIZE: u32 = 17;
    const MODE_LOCAL_SIZE_ID: u32 = 38;
    if !bytes.len().is_multiple_of(4) || bytes.len() < 20 {
        return Err("SPIR-V size is not a whole number of words".into());
    }
    let words: Vec<u32> =
        bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    if words[0] != MAGIC {
        return Err("not SPIR-V (bad magic number)".into());
    }
    let mut stage = None;
    let mut workgroup_size = [1, 1, 1];
    // SPIR-V 1.6 (Vulkan 1.3) modules give the size as constant ids; constants are declared
    // after the execution modes, so resolve the ids at the end.
    let mut size_ids = None;
    let mut constants = std::collections::HashMap::new();
    let mut bindings = Vec::new();
    let mut types = Types::default();
    // Pointer types to push-constant storage (pointer id → pointee) and the variables of them.
    let mut push_pointers = std::collections::HashMap::new();
    let mut push_variables = Vec::new();
    let mut i = 5;
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        let opcode = words[i] & 0xffff;
        if count == 0 || i + count > words.len() {
            return Err("truncated SPIR-V instruction".into());
        }
        let operands = &words[i + 1..i + count];
        match opcode {
            OP_ENTRY_POINT if stage.is_none() => {
                stage = Some(match operands[0] {
                    0 => ShaderStage::Vertex,
                    4 => ShaderStage::Fragment,
                    5 => ShaderStage::Compute,
                    5364 => ShaderStage::Task,
                    5365 => ShaderStage::Mesh,
                    other => return Err(format!("unsupported execution model {other}")),
                });
            }
            OP_EXECUTION_MODE if operands.len() >= 5 && operands[1] == MODE_LOCAL_SIZE => {
                workgroup_size = [operands[2], operands[3], operands[4]];
            }
            OP_EXECUTION_MODE_ID if operands.len() >= 5 && operands[1] == MODE_LOCAL_SIZE_ID => {
                size_ids = Some([operands[2], operands[3], operands[4]]);
            }
            OP_CONSTANT | OP_SPEC_CONSTANT if operands.len() == 3 => {
                constants.insert(operands[1], operands[2]);
            }
            OP_DECORATE if operands.len() >= 3 && operands[1] == DECORATION_BINDING => {
                bindings.push(operands[2]);
            }
            OP_DECORATE if operands.len() >= 3 && operands[1] == DECORATION_ARRAY_STRIDE => {
                types.array_strides.insert(operands[0], operands[2]);
            }
            OP_MEMBER_DECORATE if operands.len() >= 4 && operands[2] == DECORATION_OFFSET => {
                types.member_offsets.insert((operands[0], operands[1]), operands[3]);
            }
            OP_MEMBER_DECORATE if operands.len() >= 4 && operands[2] == DECORATION_MATRIX_STRIDE => {
                types.member_matrix_strides.insert((operands[0], operands[1]), operands[3]);
            }
            Types::OP_TYPE_POINTER if operands.len() >= 3 && operands[1] == STORAGE_PUSH_CONSTANT => {
                push_pointers.insert(operands[0], operands[2]);
                types.defs.insert(operands[0], (opcode, operands[1..].to_vec()));
            }
            Types::OP_TYPE_BOOL
            | Types::OP_TYPE_INT
            | Types::OP_TYPE_FLOAT
            | Types::OP_TYPE_VECTOR
            | Types::OP_TYPE_MATRIX
            | Types::OP_TYPE_ARRAY
            | Types::OP_TYPE_STRUCT
            | Types::OP_TYPE_POINTER
                if !operands.is_empty() =>
            {
                types.defs.insert(operands[0], (opcode, operands[1..].to_vec()));
            }
            OP_VARIABLE if operands.len() >= 3 && operands[2] == STORAGE_PUSH_CONSTANT => {
                push_variables.push(operands[0]);
            }
            _ => {}
        }
        i += count;
    }
    if let Some(ids) = size_ids {
        for (size, id) in workgroup_size.iter_mut().zip(ids) {
            *size = *constants
                .get(&id)
                .ok_or_else(|| format!("LocalSizeId names %{id}, which is not a 32-bit constant"))?;
        }
    }
    let stage = stage.ok_or("no OpEntryPoint")?;
    bindings.sort_unstable();
    bindings.dedup();
    let mut push_constants: Option<[u32; 2]> = None;
    for pointer in push_variables {
        let block =
            *push_pointers.get(&pointer).ok_or("push-constant variable of an unknown pointer type")?;
        if let Some([lo, hi]) = types.extent(block, &constants, 0)? {
            push_constants = Some(match push_constants {
                None => [lo, hi],
                Some([a, b]) => [lo.min(a), hi.max(b)],
            });
        }
    }
    Ok(Reflection { stage, workgroup_size, bindings, push_constants })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn module(words: &[u32]) -> Vec<u8> {
        let mut all = vec![0x0723_0203, 0x0001_0600, 0, 100, 0];
        all.extend_from_slice(words);
        all.iter().flat_map(|w| w.to_le_bytes()).collect()
    }

    #[test]
    fn reflects_compute_local_size() {
        // OpEntryPoint GLCompute %4 "main"; OpExecutionMode %4 LocalSize 64 2 1
        let bytes =
            module(&[(5 << 16) | 15, 5, 4, u32::from_le_bytes(*b"main"), 0, (6 << 16) | 16, 4, 17, 64, 2, 1]);
        assert_eq!(
            reflect(&bytes),
            Ok(Reflection {
                stage: ShaderStage::Compute,
                workgroup_size: [64, 2, 1],
                bindings: vec![],
                push_constants: None
            })
        );
    }

    #[test]
    fn reflects_local_size_id() {
        // OpEntryPoint GLCompute %4 "main"; OpExecutionModeId %4 LocalSizeId %7 %8 %8;
        // %7 = OpConstant %uint 64; %8 = OpConstant %uint 1
        let bytes = module(&[
            (5 << 16) | 15,
            5,
            4,
            u32::from_le_bytes(*b"main"),
            0,
            (6 << 16) | 331,
            4,
            38,
            7,
            8,
            8,
            (4 << 16) | 43,
            6,
            7,
            64,
            (4 << 16) | 43,
            6,
            8,
            1,
        ]);
        assert_eq!(
            reflect(&bytes),
            Ok(Reflection {
                stage: ShaderStage::Compute,
                workgroup_size: [64, 1, 1],
                bindings: vec![],
                push_constants: None
            })
        );
    }

    #[test]
    fn reflects_bindings() {
        // OpEntryPoint GLCompute %4 "main"; OpDecorate %9 Binding 12; OpDecorate %9 DescriptorSet 0;
        // OpDecorate %10 Binding 3
        let bytes = module(&[
            (5 << 16) | 15,
            5,
            4,
            u32::from_le_bytes(*b"main"),
            0,
            (4 << 16) | 71,
            9,
            33,
            12,
            (4 << 16) | 71,
            9,
            34,
            0,
            (4 << 16) | 71,
            10,
            33,
            3,
        ]);
        assert_eq!(reflect_bindings(&bytes), Ok(vec![3, 12]));
    }

    #[test]
    fn finds_binding_literals_but_not_macros_or_comments() {
        let source = "layout(std430, set = 0, binding = 12) buffer A { uint a[]; };\n\
                      layout(set = 0, binding = HK_BINDING_X) uniform sampler3D t;\n\
                      // an example: binding = 3\n\
                      layout(binding=7) buffer B { uint b[]; };\n";
        let found: Vec<usize> = binding_literals(source).into_iter().map(|(line, _)| line).collect();
        assert_eq!(found, vec![1, 4]);
    }

    #[test]
    fn headers_define_every_constant() {
        let header = GlslHeader {
            file_name: "hk_test.glsl".into(),
            title: "test".into(),
            defines: vec![("HK_A".into(), 3), ("HK_B".into(), 12)],
        };
        let text = header.text();
        assert!(text.contains("#define HK_A 3u\n"));
        assert!(text.contains("#define HK_B 12u\n"));
        assert!(text.contains("#ifndef HK_TEST_GLSL"));
    }

    /// A scratch folder with one shader, compiled under `contract`.
    fn compile_one(name: &str, source: &str, contract: &Contract) -> Result<(), String> {
        let root = std::env::temp_dir().join(format!("shader-build-test-{name}-{}", std::process::id()));
        let (src, out) = (root.join("src"), root.join("out"));
        std::fs::create_dir_all(&src).map_err(|e| e.to_string())?;
        std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
        std::fs::write(src.join("probe.comp"), source).map_err(|e| e.to_string())?;
        let result = compile_dir(&src, &out, Some(contract));
        let _ = std::fs::remove_dir_all(&root);
        result
    }

    fn probe_contract() -> Contract {
        Contract {
            headers: vec![GlslHeader {
                file_name: "hk_probe.glsl".into(),
                title: "probe".into(),
                defines: vec![("HK_DECLARED".into(), 3), ("HK_UNDECLARED".into(), 42)],
            }],
            include_dirs: vec![],
            bindings: vec![3],
        }
    }

    const PROBE: &str = "#version 460\n#extension GL_GOOGLE_include_directive : require\n\
        #include \"hk_probe.glsl\"\nlayout(local_size_x = 1) in;\n\
        layout(std430, set = 0, binding = BINDING) buffer Out { uint values[]; };\n\
        void main() { values[0] = 1u; }\n";

    #[test]
    fn a_shader_with_an_undeclared_binding_fails_the_build() {
        if Command::new("glslangValidator").arg("--version").output().is_err() {
            panic!("glslangValidator is missing: run `cargo xtask setup`");
        }
        let contract = probe_contract();
        compile_one("declared", &PROBE.replace("BINDING", "HK_DECLARED"), &contract)
            .expect("a declared binding compiles");
        let undeclared = compile_one("undeclared", &PROBE.replace("BINDING", "HK_UNDECLARED"), &contract)
            .expect_err("binding 42 is not in the contract");
        assert!(undeclared.contains("binding 42"), "{undeclared}");
        let literal = compile_one("literal", &PROBE.replace("BINDING", "3"), &contract)
            .expect_err("a literal binding is refused");
        assert!(literal.contains("literal"), "{literal}");
    }

    #[test]
    fn rejects_garbage() {
        assert!(reflect(&[1, 2, 3]).is_err());
        assert!(reflect(&module(&[(9 << 16) | 15])).is_err());
        assert!(reflect(&module(&[])).is_err());
    }

    /// A block with a scalar, a vector, a matrix, an array and a buffer address, compiled by
    /// glslang: its range is the first member's offset to the end of the last.
    #[test]
    fn reflects_the_push_constant_range() {
        let dir = std::env::temp_dir().join(format!("shader-build-push-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let src = dir.join("push.comp");
        std::fs::write(
            &src,
            "#version 460\n#extension GL_EXT_buffer_reference : require\n\
             layout(buffer_reference, std430) buffer Ref { uint x; };\n\
             layout(local_size_x = 1) in;\n\
             layout(push_constant) uniform P { layout(offset = 16) uint a; vec3 b; mat4 m; float c[3]; Ref r; } p;\n\
             layout(std430, binding = 0) buffer O { float o[]; };\n\
             void main() { o[0] = float(p.a) + p.b.x + p.m[0][0] + p.c[2] + float(p.r.x); }\n",
        )
        .expect("write");
        let spv = dir.join("push.spv");
        let compiler = std::env::var("GLSLANG_VALIDATOR").unwrap_or_else(|_| "glslangValidator".into());
        let status = Command::new(compiler)
            .args(["-V", "--target-env", "vulkan1.3", "-o"])
            .arg(&spv)
            .arg(&src)
            .output()
            .expect("glslangValidator runs (installed by `cargo xtask setup`)");
        assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stdout));
        let bytes = std::fs::read(&spv).expect("spv");
        // a at 16, b at 32 (vec3: 16-aligned), m at 48 (64 bytes), c at 112 (3 × 4), r at 128 (8).
        assert_eq!(reflect_push_constants(&bytes), Ok(Some([16, 136])));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
