use ash::vk;

/// Everything that can go wrong in `gen-gpu`.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "cannot load the Vulkan loader (libvulkan.so.1): {0}. Install libvulkan1, e.g. with `cargo xtask setup`"
    )]
    Loader(#[from] ash::LoadingError),
    #[error(
        "no Vulkan device supports what hairkit needs (Vulkan 1.3, a graphics+compute queue, VK_KHR_push_descriptor){0}"
    )]
    NoDevice(String),
    #[error("no Vulkan device matches `{selector}`; devices present: {available}")]
    DeviceNotFound { selector: String, available: String },
    #[error(
        "the Khronos validation layer was requested but is not installed (package vulkan-validationlayers)"
    )]
    ValidationLayerMissing,
    #[error(
        "the {requested} generation path needs VK_EXT_mesh_shader with task and mesh shaders, which {device} does not offer"
    )]
    MeshShaderUnsupported { requested: &'static str, device: String },
    #[error("unknown generation path `{0}` (expected `auto`, `mesh` or `compute`)")]
    UnknownPath(String),
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan { call: &'static str, result: vk::Result },
    #[error("GPU memory allocation for `{name}` failed: {source}")]
    Allocation {
        name: String,
        #[source]
        source: gpu_allocator::AllocationError,
    },
    #[error("`{name}` needs {requested} bytes, over the budget of {budget} bytes ({why})")]
    OverBudget { name: String, requested: u64, budget: u64, why: &'static str },
    #[error("GPU result differs from the CPU reference: {0}")]
    Mismatch(String),
    #[error("buffer `{name}` holds {size} bytes; cannot read {requested} bytes from it")]
    OutOfRange { name: String, size: u64, requested: u64 },
    #[error("upload to `{name}` at byte {offset} with {size} bytes refused: {why}")]
    BadUpload { name: String, offset: u64, size: u64, why: &'static str },
    #[error("fill of `{name}` at byte {offset} with {size} bytes refused: {why}")]
    BadFill { name: String, offset: u64, size: u64, why: &'static str },
}

pub type Result<T, E = GpuError> = std::result::Result<T, E>;

/// Attaches the name of the failing call to a raw `vk::Result`.
pub(crate) trait VkResultExt<T> {
    fn call(self, call: &'static str) -> Result<T>;
}

impl<T> VkResultExt<T> for std::result::Result<T, vk::Result> {
    fn call(self, call: &'static str) -> Result<T> {
        self.map_err(|result| GpuError::Vulkan { call, result })
    }
}
