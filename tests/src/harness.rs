use std::panic::AssertUnwindSafe;
use std::process::ExitCode;
use std::sync::Arc;

use gen_gpu::{Context, ContextDesc, GenerationPath, Validation};
use libtest_mimic::{Arguments, Completion, Failed, Trial};

/// What a GPU test needs from the device.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Requirements {
    pub mesh_shader: bool,
    /// 64-bit buffer atomics (the compute rasterizer).
    pub int64_atomics: bool,
    /// GPU timestamps (per-pass timings).
    pub timestamps: bool,
    /// Buffer device addresses (storage reached beyond a binding's range).
    pub buffer_device_address: bool,
}

impl Requirements {
    pub const NONE: Self =
        Self { mesh_shader: false, int64_atomics: false, timestamps: false, buffer_device_address: false };
    pub const BUFFER_DEVICE_ADDRESS: Self = Self { buffer_device_address: true, ..Self::NONE };
    pub const MESH_SHADER: Self = Self { mesh_shader: true, ..Self::NONE };
    pub const INT64_ATOMICS: Self = Self { int64_atomics: true, ..Self::NONE };
    /// The compute rasterizer's per-pass timings.
    pub const INT64_ATOMICS_AND_TIMESTAMPS: Self =
        Self { int64_atomics: true, timestamps: true, ..Self::NONE };
}

type Body = Box<dyn FnOnce(&Context) -> anyhow::Result<()> + Send>;

/// One GPU test: a name, what it needs, and its body.
pub struct GpuTest {
    name: String,
    requires: Requirements,
    body: Body,
}

impl std::fmt::Debug for GpuTest {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuTest").field("name", &self.name).field("requires", &self.requires).finish()
    }
}

impl GpuTest {
    pub fn new(
        name: &str,
        requires: Requirements,
        body: impl FnOnce(&Context) -> anyhow::Result<()> + Send + 'static,
    ) -> Self {
        Self { name: name.into(), requires, body: Box::new(body) }
    }
}

fn env_flag(name: &str) -> bool {
    std::env::var(name).is_ok_and(|v| v == "1")
}

/// Runs `body` and turns validation-layer errors reported meanwhile into a failure.
pub fn run_checked(ctx: &Context, body: impl FnOnce(&Context) -> anyhow::Result<()>) -> Result<(), Failed> {
    // Messages from earlier work are not this test's fault.
    ctx.take_validation_errors();
    let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| body(ctx)));
    let errors = ctx.take_validation_errors();
    let mut failure = match outcome {
        Ok(Ok(())) => String::new(),
        Ok(Err(e)) => format!("{e:#}\n"),
        Err(panic) => {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                .unwrap_or_else(|| "panic".into());
            format!("panicked: {msg}\n")
        }
    };
    for e in &errors {
        failure.push_str(&format!("validation error [{}]: {}\n", e.id_name, e.text));
    }
    if failure.is_empty() { Ok(()) } else { Err(failure.into()) }
}

impl Requirements {
    /// Why `caps`' device cannot run a test needing these, if it cannot; `mesh_is_required`:
    /// a missing mesh shader is a failure (HAIRKIT_REQUIRE_MESH_SHADER=1), not a reason to skip.
    fn unmet(&self, caps: &gen_gpu::Capabilities, mesh_is_required: bool) -> Option<String> {
        if self.mesh_shader && caps.mesh_shader.is_none() && !mesh_is_required {
            return Some(format!("{} lacks VK_EXT_mesh_shader", caps.device_name));
        }
        if self.int64_atomics && !caps.buffer_int64_atomics {
            return Some(format!("{} lacks 64-bit buffer atomics", caps.device_name));
        }
        if self.timestamps && caps.timestamp_period_ns.is_none() {
            return Some(format!("{} has no GPU timestamps", caps.device_name));
        }
        if self.buffer_device_address && !caps.buffer_device_address {
            return Some(format!("{} lacks buffer device addresses", caps.device_name));
        }
        None
    }
}

/// Whether this process runs under `cargo nextest` (one test per process, listed first).
fn under_nextest() -> bool {
    std::env::var_os("NEXTEST").is_some()
}

/// The entry point of a GPU test binary: creates the context once, reports the device, and
/// runs `tests` one at a time (they share the device and its validation log).
///
/// Under `cargo nextest` every test runs in a process of its own, and a test that finds at run
/// time that it cannot run would count as passed: there, the listing probes the device and
/// marks the tests it cannot run as ignored (nextest reports them as skipped), and a test that
/// would still be ignored at run time fails with its reason instead.
pub fn run_gpu_tests(tests: Vec<GpuTest>) -> ExitCode {
    let mut args = Arguments::from_args();
    args.test_threads = Some(1);
    let require_gpu = env_flag("HAIRKIT_REQUIRE_GPU");
    let require_mesh = env_flag("HAIRKIT_REQUIRE_MESH_SHADER");
    let nextest = under_nextest();

    let ctx = if args.list {
        Err("listing only".to_owned())
    } else {
        Context::new(&ContextDesc { validation: Validation::On, device: None }).map_err(|e| e.to_string())
    };
    // The device's capabilities while listing for nextest (no validation: nothing is run); an
    // error where there is no usable device.
    let listed_caps = (args.list && nextest).then(|| {
        Context::new(&ContextDesc { validation: Validation::Off, device: None })
            .map(|c| c.capabilities().clone())
            .map_err(drop)
    });
    match &ctx {
        Ok(ctx) => {
            let caps = ctx.capabilities();
            eprintln!(
                "GPU tests on: {} ({}, {}), Vulkan {}.{}, VK_EXT_mesh_shader: {}, validation: on, default path: {}",
                caps.device_name,
                caps.driver_name,
                caps.driver_info,
                caps.api_version.0,
                caps.api_version.1,
                if caps.mesh_shader.is_some() { "yes" } else { "no" },
                GenerationPath::default_for(caps),
            );
        }
        Err(e) if !args.list => eprintln!("GPU tests: no usable Vulkan device: {e}"),
        Err(_) => {}
    }
    let ctx = ctx.map(Arc::new);
    let trials = tests
        .into_iter()
        .map(|t| {
            let ctx = ctx.clone();
            let GpuTest { name, requires, body } = t;
            let unrunnable = match &listed_caps {
                None => false,
                Some(Ok(caps)) => requires.unmet(caps, require_mesh).is_some(),
                // Without a device the test runs (and fails) only where a GPU is required.
                Some(Err(())) => !require_gpu,
            };
            // A test that cannot run here: ignored with its reason, but a failure under nextest,
            // whose listing already left out the tests it could not run.
            let skip = move |reason: String| -> Result<Completion, Failed> {
                if nextest {
                    Err(format!("cannot run here ({reason}) although the listing said it could").into())
                } else {
                    Ok(Completion::ignored_with(reason))
                }
            };
            Trial::ignorable_test(name, move || {
                let ctx = match &ctx {
                    Ok(c) => c,
                    Err(e) if require_gpu => {
                        return Err(format!("no GPU although HAIRKIT_REQUIRE_GPU=1: {e}").into());
                    }
                    Err(e) => return skip(format!("no Vulkan device: {e}")),
                };
                let caps = ctx.capabilities();
                if requires.mesh_shader && caps.mesh_shader.is_none() && require_mesh {
                    return Err(format!(
                        "{} lacks VK_EXT_mesh_shader, although HAIRKIT_REQUIRE_MESH_SHADER=1",
                        caps.device_name
                    )
                    .into());
                }
                if let Some(reason) = requires.unmet(caps, require_mesh) {
                    return skip(reason);
                }
                run_checked(ctx, body).map(|()| Completion::Completed)
            })
            .with_ignored_flag(unrunnable)
        })
        .collect();
    libtest_mimic::run(&args, trials).exit_code()
}
