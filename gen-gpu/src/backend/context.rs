use std::ffi::{CStr, CString, c_void};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::caps::{Capabilities, cstr_field, has_device_extension};
use crate::error::VkResultExt;
use crate::{GpuError, Result};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Whether the Khronos validation layer is enabled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Validation {
    Off,
    On,
    /// On when `HAIRKIT_VALIDATION` is `1` (the test command sets it).
    #[default]
    FromEnv,
}

/// How to create a [`Context`].
#[derive(Clone, Debug, Default)]
pub struct ContextDesc {
    pub validation: Validation,
    /// A device index (as listed by `hairkit info --all`) or a case-insensitive substring of the
    /// device name. `None` reads `HAIRKIT_DEVICE`, and without it picks discrete > integrated >
    /// virtual > CPU.
    pub device: Option<String>,
}

/// A message from the validation layer.
#[derive(Clone, Debug)]
pub struct ValidationMessage {
    pub severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    pub id_name: String,
    pub text: String,
}

/// Validation-layer output collected by the debug messenger; shared with the callback.
#[derive(Debug, Default)]
struct ValidationLog {
    errors: Mutex<Vec<ValidationMessage>>,
}

/// A headless Vulkan device: instance, device, one graphics+compute queue, a memory allocator.
///
/// Cheap to clone; every resource keeps the device alive through an `Arc`, so the device is
/// destroyed after the last resource, and the allocator is dropped before the device.
#[derive(Clone)]
pub struct Context {
    pub(crate) shared: Arc<DeviceShared>,
    /// The `DISPATCH_WORKERS` compute pipelines created through this handle get
    /// ([`Context::dispatch_workers`]).
    dispatch_workers: u32,
}

impl std::fmt::Debug for Context {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Context").field("device", &self.shared.caps.device_name).finish()
    }
}

pub(crate) struct DeviceShared {
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    debug_utils_instance: Option<ash::ext::debug_utils::Instance>,
    messenger: vk::DebugUtilsMessengerEXT,
    // Read by the messenger callback through a raw pointer; must outlive `messenger`.
    validation_log: Box<ValidationLog>,
    pub(crate) debug_utils: Option<ash::ext::debug_utils::Device>,
    pub(crate) device: ash::Device,
    pub(crate) mesh_shader: Option<ash::ext::mesh_shader::Device>,
    pub(crate) push_descriptor: ash::khr::push_descriptor::Device,
    queue: Mutex<vk::Queue>,
    pub(crate) command_pool: Mutex<vk::CommandPool>,
    /// Every pipeline made on the device, made once per desc (see `pipeline_registry`).
    pub(crate) pipelines: super::pipeline_registry::PipelineRegistry,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    pub(crate) caps: Capabilities,
    validation: bool,
    /// Command buffers being recorded or in flight (see [`DeviceShared::retire`]).
    pub(crate) open_submissions: Mutex<usize>,
    /// Resources dropped while a submission was open: destroyed when none is.
    pub(crate) deferred: Mutex<Vec<Retired>>,
}

/// A resource whose handles outlive its Rust value until no submission can still use it.
pub(crate) enum Retired {
    Buffer {
        raw: vk::Buffer,
        allocation: Option<gpu_allocator::vulkan::Allocation>,
        name: String,
    },
    Image {
        raw: vk::Image,
        view: vk::ImageView,
        allocation: Option<gpu_allocator::vulkan::Allocation>,
        name: String,
    },
}

impl Drop for DeviceShared {
    fn drop(&mut self) {
        // SAFETY: every resource holds an Arc to this struct, so none is alive any more; the
        // allocator is dropped (reporting leaks) before the device it allocated from.
        unsafe {
            let _ = self.device.device_wait_idle();
            if let Ok(pool) = self.command_pool.get_mut() {
                self.device.destroy_command_pool(*pool, None);
            }
            // No Pipeline handle is alive: each holds an Arc to this struct.
            self.pipelines.destroy_all(&self.device);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some(du) = &self.debug_utils_instance {
                du.destroy_debug_utils_messenger(self.messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

impl DeviceShared {
    /// Destroys `resource` now if no submission is open, else when the last open one has
    /// completed. A buffer dropped by safe code inside a `submit` closure, after a command that
    /// uses it was recorded, is thus still alive when the queue runs that command.
    pub(crate) fn retire(&self, resource: Retired) {
        let open = self.open_submissions.lock().unwrap_or_else(|e| e.into_inner());
        if *open > 0 {
            self.deferred.lock().unwrap_or_else(|e| e.into_inner()).push(resource);
            return;
        }
        drop(open);
        self.destroy(resource);
    }

    /// Marks a submission as open (recording or in flight).
    pub(crate) fn open_submission(&self) {
        *self.open_submissions.lock().unwrap_or_else(|e| e.into_inner()) += 1;
    }

    /// Marks a submission as completed (its fence waited for, or never submitted) and destroys
    /// what was retired meanwhile once none is open.
    pub(crate) fn close_submission(&self) {
        let mut open = self.open_submissions.lock().unwrap_or_else(|e| e.into_inner());
        *open = open.saturating_sub(1);
        if *open > 0 {
            return;
        }
        let retired = std::mem::take(&mut *self.deferred.lock().unwrap_or_else(|e| e.into_inner()));
        drop(open);
        for r in retired {
            self.destroy(r);
        }
    }

    /// Number of resources waiting for open submissions (tests).
    pub(crate) fn deferred_count(&self) -> usize {
        self.deferred.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    fn destroy(&self, resource: Retired) {
        match resource {
            Retired::Buffer { raw, allocation, name } => {
                // SAFETY: no submission is open (checked by the callers), so no recorded or
                // queued command uses the buffer; memory is freed after the buffer.
                unsafe { self.device.destroy_buffer(raw, None) };
                self.free(allocation, &name);
            }
            Retired::Image { raw, view, allocation, name } => {
                // SAFETY: as for buffers; the view goes before its image, memory after both.
                unsafe {
                    if view != vk::ImageView::null() {
                        self.device.destroy_image_view(view, None);
                    }
                    self.device.destroy_image(raw, None);
                }
                self.free(allocation, &name);
            }
        }
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        // A panic while holding the lock leaves the allocator itself consistent.
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Returns a resource's memory to the allocator (after the resource is destroyed).
    pub(crate) fn free(&self, allocation: Option<gpu_allocator::vulkan::Allocation>, name: &str) {
        if let Some(a) = allocation
            && let Err(e) = self.allocator().free(a)
        {
            log::error!("freeing the memory of `{name}` failed: {e}");
        }
    }
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes a valid callback-data pointer for the duration of the call, and
    // `user_data` is the boxed ValidationLog that outlives the messenger.
    let (data, log) = unsafe { (&*data, &*(user_data as *const ValidationLog)) };
    // SAFETY: non-null strings from the layer are NUL-terminated.
    let text =
        unsafe { data.message_as_c_str() }.map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    // SAFETY: as above.
    let id_name = unsafe { data.message_id_name_as_c_str() }
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        log::error!("vulkan validation: {text}");
        if let Ok(mut errors) = log.errors.lock() {
            errors.push(ValidationMessage { severity, id_name, text });
        }
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log::warn!("vulkan validation: {text}");
    }
    vk::FALSE
}

fn device_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

impl Context {
    /// Buffers and images dropped while a submission was open, waiting for it to complete.
    pub fn resources_awaiting_submissions(&self) -> usize {
        self.shared.deferred_count()
    }

    /// Environment variable naming the device (index or name substring).
    pub const DEVICE_ENV: &'static str = "HAIRKIT_DEVICE";
    /// Environment variable that turns validation on (`1`) for [`Validation::FromEnv`].
    pub const VALIDATION_ENV: &'static str = "HAIRKIT_VALIDATION";

    /// Creates the instance and device. Never opens a window.
    pub fn new(desc: &ContextDesc) -> Result<Self> {
        let validation = match desc.validation {
            Validation::On => true,
            Validation::Off => false,
            Validation::FromEnv => std::env::var(Self::VALIDATION_ENV).is_ok_and(|v| v == "1"),
        };
        // SAFETY: loading the system Vulkan loader; its symbols are used only through ash.
        let entry = unsafe { ash::Entry::load() }?;
        // SAFETY: plain queries on a loaded entry.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }.unwrap_or_default();
        // SAFETY: as above.
        let instance_exts =
            unsafe { entry.enumerate_instance_extension_properties(None) }.unwrap_or_default();
        let has_layer = layers.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
        if validation && !has_layer {
            return Err(GpuError::ValidationLayerMissing);
        }
        let has_debug_utils = instance_exts
            .iter()
            .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == ash::ext::debug_utils::NAME));

        let app_info = vk::ApplicationInfo::default()
            .application_name(c"hairkit")
            .engine_name(c"hairkit")
            .api_version(vk::API_VERSION_1_3);
        let layer_ptrs = if validation { vec![VALIDATION_LAYER.as_ptr()] } else { vec![] };
        let ext_ptrs = if has_debug_utils { vec![ash::ext::debug_utils::NAME.as_ptr()] } else { vec![] };
        let instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_layer_names(&layer_ptrs)
            .enabled_extension_names(&ext_ptrs);
        // SAFETY: the create info and everything it points to live until the call returns.
        let instance = unsafe { entry.create_instance(&instance_info, None) }.call("vkCreateInstance")?;

        // From here on, dropping `partial` cleans up what exists if a later step fails.
        let mut partial = PartialInstance { instance: Some(instance), messenger: None };
        let instance_ref = partial.instance.as_ref().expect("instance was just created");
        let validation_log = Box::new(ValidationLog::default());
        let debug_utils_instance =
            has_debug_utils.then(|| ash::ext::debug_utils::Instance::new(&entry, instance_ref));
        let messenger = match &debug_utils_instance {
            Some(du) => {
                let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                    .message_severity(
                        vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                            | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                    )
                    .message_type(
                        vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                            | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                    )
                    .pfn_user_callback(Some(debug_callback))
                    .user_data(&*validation_log as *const ValidationLog as *mut c_void);
                // SAFETY: `validation_log` is boxed and stored in DeviceShared, which destroys
                // the messenger before dropping the box.
                let m = unsafe { du.create_debug_utils_messenger(&info, None) }
                    .call("vkCreateDebugUtilsMessengerEXT")?;
                partial.messenger = Some((du.clone(), m));
                m
            }
            None => vk::DebugUtilsMessengerEXT::null(),
        };

        let physical = pick_device(instance_ref, desc.device.clone())?;
        // SAFETY: `physical` was enumerated from this instance.
        let caps = unsafe { Capabilities::query(instance_ref, physical) };
        let use_mesh = caps.mesh_shader.is_some();

        // SAFETY: valid physical device.
        let families = unsafe { instance_ref.get_physical_device_queue_family_properties(physical) };
        let queue_family = families
            .iter()
            .position(|q| q.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE))
            .ok_or_else(|| GpuError::NoDevice(": the chosen device has no graphics+compute queue".into()))?
            as u32;

        let mut device_exts = vec![ash::khr::push_descriptor::NAME.as_ptr()];
        if use_mesh {
            device_exts.push(ash::ext::mesh_shader::NAME.as_ptr());
        }
        let priorities = [1.0f32];
        let queue_infos = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let core = vk::PhysicalDeviceFeatures::default()
            .pipeline_statistics_query(caps.pipeline_statistics_query)
            .fragment_stores_and_atomics(true)
            .vertex_pipeline_stores_and_atomics(true)
            .shader_int16(true)
            .shader_int64(caps.shader_int64);
        let mut v11 = vk::PhysicalDeviceVulkan11Features::default().storage_buffer16_bit_access(true);
        let mut v12 = vk::PhysicalDeviceVulkan12Features::default()
            .scalar_block_layout(true)
            .shader_float16(true)
            .host_query_reset(true)
            .shader_buffer_int64_atomics(caps.buffer_int64_atomics)
            .buffer_device_address(caps.buffer_device_address);
        let mut v13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true)
            .maintenance4(true);
        let mut mesh_features =
            vk::PhysicalDeviceMeshShaderFeaturesEXT::default().task_shader(true).mesh_shader(true);
        let mut device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_infos)
            .enabled_extension_names(&device_exts)
            .enabled_features(&core)
            .push_next(&mut v11)
            .push_next(&mut v12)
            .push_next(&mut v13);
        if use_mesh {
            device_info = device_info.push_next(&mut mesh_features);
        }
        // SAFETY: create info and its chain live until the call returns.
        let device =
            unsafe { instance_ref.create_device(physical, &device_info, None) }.call("vkCreateDevice")?;
        // SAFETY: queue 0 of a family we created.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device.
        let command_pool = match unsafe { device.create_command_pool(&pool_info, None) } {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: nothing else was created from the device yet.
                unsafe { device.destroy_device(None) };
                return Err(GpuError::Vulkan { call: "vkCreateCommandPool", result: e });
            }
        };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance_ref.clone(),
            device: device.clone(),
            physical_device: physical,
            // The defaults log leaked allocations when the allocator is dropped.
            debug_settings: Default::default(),
            buffer_device_address: caps.buffer_device_address,
            allocation_sizes: Default::default(),
        });
        let allocator = match allocator {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: only the pool was created from the device.
                unsafe {
                    device.destroy_command_pool(command_pool, None);
                    device.destroy_device(None);
                }
                return Err(GpuError::Allocation { name: "allocator".into(), source });
            }
        };

        let (instance, _) = partial.disarm();
        let debug_utils = has_debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let mesh_shader = use_mesh.then(|| ash::ext::mesh_shader::Device::new(&instance, &device));
        let push_descriptor = ash::khr::push_descriptor::Device::new(&instance, &device);
        let dispatch_workers = caps.dispatch_workers;
        let ctx = Context {
            dispatch_workers,
            shared: Arc::new(DeviceShared {
                _entry: entry,
                instance,
                debug_utils_instance,
                messenger,
                validation_log,
                debug_utils,
                device,
                mesh_shader,
                push_descriptor,
                queue: Mutex::new(queue),
                command_pool: Mutex::new(command_pool),
                pipelines: Default::default(),
                allocator: ManuallyDrop::new(Mutex::new(allocator)),
                caps,
                validation,
                open_submissions: Mutex::new(0),
                deferred: Mutex::new(Vec::new()),
            }),
        };
        ctx.set_name(queue, "main queue");
        ctx.set_name(command_pool, "main command pool");
        Ok(ctx)
    }

    pub fn capabilities(&self) -> &Capabilities {
        &self.shared.caps
    }

    /// The worker count compute pipelines created through this handle order their workgroups'
    /// work by (`dispatch_order.glsl`): the device's [`Capabilities::dispatch_workers`] unless
    /// overridden with [`Context::with_dispatch_workers`].
    pub fn dispatch_workers(&self) -> u32 {
        self.dispatch_workers
    }

    /// A handle to the same device whose compute pipelines order their work for `workers`
    /// threads (at least 1). Only the speed depends on it: the order is a permutation of the
    /// workgroups, and every kernel's result is independent of the order workgroups run in
    /// (tests render with several counts and compare).
    pub fn with_dispatch_workers(&self, workers: u32) -> Context {
        Context { shared: self.shared.clone(), dispatch_workers: workers.max(1) }
    }

    pub fn validation_enabled(&self) -> bool {
        self.shared.validation
    }

    /// Raw device, for recording commands not wrapped by this crate.
    pub fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// The VK_EXT_mesh_shader entry points, when the device has them enabled.
    pub fn mesh_shader_ext(&self) -> Option<&ash::ext::mesh_shader::Device> {
        self.shared.mesh_shader.as_ref()
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.shared.allocator()
    }

    /// How many distinct pipelines this device has made (each desc once).
    pub fn pipelines_made(&self) -> usize {
        self.shared.pipelines.len()
    }

    pub(crate) fn queue(&self) -> MutexGuard<'_, vk::Queue> {
        self.shared.queue.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Validation errors reported since the last call (and clears them).
    pub fn take_validation_errors(&self) -> Vec<ValidationMessage> {
        let mut errors = self.shared.validation_log.errors.lock().unwrap_or_else(|e| e.into_inner());
        std::mem::take(&mut *errors)
    }

    /// Gives a Vulkan object a debug name (shown by the validation layer and GPU debuggers).
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.shared.debug_utils {
            let Ok(name) = CString::new(name) else { return };
            let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&name);
            // SAFETY: the handle belongs to this device; the name outlives the call.
            let _ = unsafe { du.set_debug_utils_object_name(&info) };
        }
    }

    /// Lists the devices this machine offers, as `index: name (type)`.
    pub fn list_devices() -> Result<Vec<String>> {
        // SAFETY: loading the system Vulkan loader.
        let entry = unsafe { ash::Entry::load() }?;
        let app_info = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
        let info = vk::InstanceCreateInfo::default().application_info(&app_info);
        // SAFETY: create info lives until the call returns.
        let instance = unsafe { entry.create_instance(&info, None) }.call("vkCreateInstance")?;
        let names = describe_devices(&instance);
        // SAFETY: no objects were created from this instance.
        unsafe { instance.destroy_instance(None) };
        Ok(names)
    }

    /// Makes one deliberate API misuse (a sampler with anisotropy although the feature is not
    /// enabled) so the test harness can prove that validation errors fail tests.
    #[cfg(feature = "validation-selftest")]
    #[doc(hidden)]
    pub fn misuse_for_validation_selftest(&self) -> Result<()> {
        let info = vk::SamplerCreateInfo::default().anisotropy_enable(true).max_anisotropy(4.0);
        // SAFETY: creating and destroying a sampler is harmless for the driver even though the
        // layer flags the disabled feature, which is the point of this function.
        unsafe {
            let sampler = self.device().create_sampler(&info, None).call("vkCreateSampler")?;
            self.device().destroy_sampler(sampler, None);
        }
        Ok(())
    }
}

/// Destroys a half-built instance when device set-up fails part-way.
struct PartialInstance {
    instance: Option<ash::Instance>,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

impl PartialInstance {
    fn disarm(mut self) -> (ash::Instance, Option<vk::DebugUtilsMessengerEXT>) {
        let messenger = self.messenger.take().map(|(_, m)| m);
        let instance = self.instance.take().expect("disarm is called once");
        (instance, messenger)
    }
}

impl Drop for PartialInstance {
    fn drop(&mut self) {
        // SAFETY: only reached on an error path, before any device object exists.
        unsafe {
            if let Some((du, m)) = self.messenger.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            if let Some(instance) = self.instance.take() {
                instance.destroy_instance(None);
            }
        }
    }
}

fn describe_devices(instance: &ash::Instance) -> Vec<String> {
    // SAFETY: valid instance.
    let devices = unsafe { instance.enumerate_physical_devices() }.unwrap_or_default();
    devices
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            // SAFETY: enumerated from this instance.
            let p = unsafe { instance.get_physical_device_properties(d) };
            format!("{i}: {} ({:?})", cstr_field(&p.device_name), p.device_type)
        })
        .collect()
}

/// What a device must offer (pick_device), for messages.
const REQUIRED: &str = "Vulkan 1.3, VK_KHR_push_descriptor and subgroup vote and ballot in compute shaders";

/// Subgroup vote and ballot in compute shaders: the strand-coherent generation kernels fetch a
/// segment's texels once per subgroup with them (hair_gen.glsl, fetch_corners).
fn subgroup_vote_and_ballot(instance: &ash::Instance, d: vk::PhysicalDevice) -> bool {
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut props = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup);
    // SAFETY: `d` was enumerated from `instance`; the chained struct outlives the call.
    unsafe { instance.get_physical_device_properties2(d, &mut props) };
    let needed =
        vk::SubgroupFeatureFlags::BASIC | vk::SubgroupFeatureFlags::VOTE | vk::SubgroupFeatureFlags::BALLOT;
    // Any subgroup size: the kernels fetch together only in subgroups of 8 or more.
    subgroup.supported_operations.contains(needed)
        && subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
}

fn pick_device(instance: &ash::Instance, selector: Option<String>) -> Result<vk::PhysicalDevice> {
    // SAFETY: valid instance.
    let devices = unsafe { instance.enumerate_physical_devices() }.call("vkEnumeratePhysicalDevices")?;
    let suitable = |d: vk::PhysicalDevice| {
        // SAFETY: enumerated from this instance.
        let p = unsafe { instance.get_physical_device_properties(d) };
        // SAFETY: as above.
        let push = unsafe { has_device_extension(instance, d, ash::khr::push_descriptor::NAME) };
        p.api_version >= vk::API_VERSION_1_3 && push && subgroup_vote_and_ballot(instance, d)
    };
    let selector = selector.or_else(|| std::env::var(Context::DEVICE_ENV).ok().filter(|s| !s.is_empty()));
    if let Some(sel) = selector {
        let found = match sel.parse::<usize>() {
            Ok(i) => devices.get(i).copied(),
            Err(_) => devices.iter().copied().find(|&d| {
                // SAFETY: enumerated from this instance.
                let p = unsafe { instance.get_physical_device_properties(d) };
                cstr_field(&p.device_name).to_lowercase().contains(&sel.to_lowercase())
            }),
        };
        return match found {
            Some(d) if suitable(d) => Ok(d),
            Some(_) => Err(GpuError::NoDevice(format!(": `{sel}` does not offer all of {REQUIRED}"))),
            None => Err(GpuError::DeviceNotFound {
                selector: sel,
                available: describe_devices(instance).join(", "),
            }),
        };
    }
    devices
        .iter()
        .copied()
        .filter(|&d| suitable(d))
        .min_by_key(|&d| {
            // SAFETY: enumerated from this instance.
            device_rank(unsafe { instance.get_physical_device_properties(d) }.device_type)
        })
        .ok_or_else(|| {
            let present = describe_devices(instance);
            GpuError::NoDevice(if present.is_empty() {
                " (no Vulkan device at all; install mesa-vulkan-drivers for lavapipe)".into()
            } else {
                format!(" with {REQUIRED} (present: {})", present.join(", "))
            })
        })
}
