use std::fmt;
use std::str::FromStr;

use crate::{Capabilities, GpuError, Result};

/// How strands are generated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GenerationPath {
    /// Task + mesh shaders (VK_EXT_mesh_shader): strands go straight to the rasterizer.
    Mesh,
    /// Compute generation into a buffer, drawn by vertex pulling.
    Compute,
}

/// What the user asked for: a path, or `Auto` for the device's default.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PathChoice {
    #[default]
    Auto,
    Mesh,
    Compute,
}

impl GenerationPath {
    /// The default for a device: mesh shaders on real GPUs; the compute fallback on CPU
    /// devices, where lavapipe serializes mesh output and is slower than vertex pulling
    /// (`docs/benchmarks.md`), and on devices without the extension.
    pub fn default_for(caps: &Capabilities) -> Self {
        if caps.mesh_shader.is_some() && !caps.is_cpu() {
            GenerationPath::Mesh
        } else {
            GenerationPath::Compute
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            GenerationPath::Mesh => "mesh",
            GenerationPath::Compute => "compute",
        }
    }
}

impl fmt::Display for GenerationPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl PathChoice {
    /// Environment variable read by [`PathChoice::from_env`].
    pub const ENV: &'static str = "HAIRKIT_PATH";

    /// `HAIRKIT_PATH` if set, else `Auto`.
    pub fn from_env() -> Result<Self> {
        match std::env::var(Self::ENV) {
            Ok(v) if !v.is_empty() => v.parse(),
            _ => Ok(PathChoice::Auto),
        }
    }

    /// The path to use on a device, `Auto` first looking at `HAIRKIT_PATH` ([`Self::from_env`]);
    /// forcing `mesh` on a device without it is an error.
    ///
    /// ```no_run
    /// # let ctx: gen_gpu::Context = todo!();
    /// let path = gen_gpu::PathChoice::Auto.resolve_with_env(ctx.capabilities())?;
    /// # Ok::<(), gen_gpu::GpuError>(())
    /// ```
    pub fn resolve_with_env(self, caps: &Capabilities) -> Result<GenerationPath> {
        match self {
            PathChoice::Auto => Self::from_env()?,
            p => p,
        }
        .resolve(caps)
    }

    /// The path to use on a device; forcing `mesh` on a device without it is an error.
    pub fn resolve(self, caps: &Capabilities) -> Result<GenerationPath> {
        match self {
            PathChoice::Auto => Ok(GenerationPath::default_for(caps)),
            PathChoice::Compute => Ok(GenerationPath::Compute),
            PathChoice::Mesh if caps.mesh_shader.is_some() => Ok(GenerationPath::Mesh),
            PathChoice::Mesh => {
                Err(GpuError::MeshShaderUnsupported { requested: "mesh", device: caps.device_name.clone() })
            }
        }
    }
}

impl FromStr for PathChoice {
    type Err = GpuError;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(PathChoice::Auto),
            "mesh" => Ok(PathChoice::Mesh),
            "compute" => Ok(PathChoice::Compute),
            _ => Err(GpuError::UnknownPath(s.to_owned())),
        }
    }
}
