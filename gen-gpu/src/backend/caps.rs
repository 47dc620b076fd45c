use std::ffi::CStr;
use std::fmt;

use ash::vk;

/// What a device can do, as far as hairkit cares. Printed by `hairkit info`.
#[derive(Clone, Debug)]
pub struct Capabilities {
    pub device_name: String,
    pub device_type: vk::PhysicalDeviceType,
    pub vendor_id: u32,
    pub device_id: u32,
    pub driver_name: String,
    pub driver_info: String,
    /// Vulkan version the device supports (`major.minor.patch`).
    pub api_version: (u32, u32, u32),
    /// Task + mesh shader limits when VK_EXT_mesh_shader offers both stages.
    pub mesh_shader: Option<MeshShaderLimits>,
    pub subgroup_size: u32,
    /// Whether RGBA32F images may be sampled with linear filtering (else RGBA16F is used).
    pub linear_filter_rgba32f: bool,
    pub linear_filter_rgba16f: bool,
    /// Nanoseconds per timestamp tick; `None` when the queue has no timestamps.
    pub timestamp_period_ns: Option<f32>,
    pub max_storage_buffer_range: u32,
    pub min_storage_buffer_offset_alignment: u64,
    pub max_push_constants_size: u32,
    pub max_compute_work_group_count: [u32; 3],
    pub max_image_dimension_3d: u32,
    pub pipeline_statistics_query: bool,
    pub sampler_anisotropy: bool,
    /// Bits of sub-texel precision in filtering weights: hardware trilinear filtering is exact
    /// to about 2^-bits of the difference between neighbouring texels.
    pub sub_texel_precision_bits: u32,
    /// 64-bit integers in shaders (`shaderInt64`): the generate pass stores each vertex as one
    /// `u64vec4` (`generate_int64.comp`), which CPU devices write in one loop over the SIMD
    /// lanes instead of two.
    pub shader_int64: bool,
    /// 64-bit integer atomics on storage buffers (`shaderInt64` + `shaderBufferInt64Atomics`):
    /// what the compute strand rasterizer's visibility buffer needs.
    pub buffer_int64_atomics: bool,
    /// Buffer device addresses (`bufferDeviceAddress`, core in Vulkan 1.2 and required by
    /// 1.3): kernels read their hottest buffers through `GL_EXT_buffer_reference` pointers, which
    /// CPU devices (llvmpipe) gather with vector instructions, where a storage-buffer load of a
    /// divergent address is a loop over the SIMD lanes.
    pub buffer_device_address: bool,
    /// How many threads run a dispatch's workgroups, each a contiguous run of them in index
    /// order: llvmpipe's worker threads (`LP_NUM_THREADS`, else the CPUs this process may run
    /// on, as llvmpipe counts them), 1 on other devices (GPUs schedule workgroups dynamically).
    /// Kernels order their work by it (`dispatch_order.glsl`, [`crate::dispatch_order`]).
    pub dispatch_workers: u32,
}

/// Limits of VK_EXT_mesh_shader that generation must respect (queried, never assumed).
#[derive(Clone, Copy, Debug)]
pub struct MeshShaderLimits {
    pub max_output_vertices: u32,
    pub max_output_primitives: u32,
    pub max_output_memory_size: u32,
    pub max_mesh_work_group_invocations: u32,
    pub max_task_work_group_invocations: u32,
    pub max_task_work_group_count: [u32; 3],
    pub max_task_work_group_total_count: u32,
    pub max_mesh_work_group_count: [u32; 3],
    pub max_preferred_mesh_work_group_invocations: u32,
    pub max_preferred_task_work_group_invocations: u32,
    pub max_task_payload_size: u32,
}

impl Capabilities {
    pub fn is_cpu(&self) -> bool {
        self.device_type == vk::PhysicalDeviceType::CPU
    }

    /// Reads the capabilities of `physical`.
    ///
    /// # Safety
    /// `physical` must be a device enumerated from `instance`.
    pub(crate) unsafe fn query(instance: &ash::Instance, physical: vk::PhysicalDevice) -> Self {
        let mut mesh_props = vk::PhysicalDeviceMeshShaderPropertiesEXT::default();
        let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
        let mut subgroup_props = vk::PhysicalDeviceSubgroupProperties::default();
        // SAFETY: `physical` comes from `instance`, per this function's contract.
        let has_mesh_ext = unsafe { has_device_extension(instance, physical, ash::ext::mesh_shader::NAME) };
        let mut props2 = vk::PhysicalDeviceProperties2::default()
            .push_next(&mut driver_props)
            .push_next(&mut subgroup_props);
        if has_mesh_ext {
            props2 = props2.push_next(&mut mesh_props);
        }
        // SAFETY: the chained structs live until the call returns; `physical` is valid.
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let props = props2.properties;

        let mut mesh_features = vk::PhysicalDeviceMeshShaderFeaturesEXT::default();
        let mut v12_features = vk::PhysicalDeviceVulkan12Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut v12_features);
        if has_mesh_ext {
            features2 = features2.push_next(&mut mesh_features);
        }
        // SAFETY: as above.
        unsafe { instance.get_physical_device_features2(physical, &mut features2) };
        let features = features2.features;
        let buffer_int64_atomics =
            features.shader_int64 == vk::TRUE && v12_features.shader_buffer_int64_atomics == vk::TRUE;
        let buffer_device_address = v12_features.buffer_device_address == vk::TRUE;

        let filterable = |format| {
            // SAFETY: valid physical device and format enum.
            let f = unsafe { instance.get_physical_device_format_properties(physical, format) };
            f.optimal_tiling_features.contains(vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR)
        };
        // SAFETY: valid physical device.
        let queues = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let timestamps = queues.iter().any(|q| {
            q.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
                && q.timestamp_valid_bits > 0
        });
        let mesh_shader = (mesh_features.task_shader == vk::TRUE && mesh_features.mesh_shader == vk::TRUE)
            .then_some(MeshShaderLimits {
                max_output_vertices: mesh_props.max_mesh_output_vertices,
                max_output_primitives: mesh_props.max_mesh_output_primitives,
                max_output_memory_size: mesh_props.max_mesh_output_memory_size,
                max_mesh_work_group_invocations: mesh_props.max_mesh_work_group_invocations,
                max_task_work_group_invocations: mesh_props.max_task_work_group_invocations,
                max_task_work_group_count: mesh_props.max_task_work_group_count,
                max_task_work_group_total_count: mesh_props.max_task_work_group_total_count,
                max_mesh_work_group_count: mesh_props.max_mesh_work_group_count,
                max_preferred_mesh_work_group_invocations: mesh_props
                    .max_preferred_mesh_work_group_invocations,
                max_preferred_task_work_group_invocations: mesh_props
                    .max_preferred_task_work_group_invocations,
                max_task_payload_size: mesh_props.max_task_payload_size,
            });
        let driver_name = cstr_field(&driver_props.driver_name);
        Capabilities {
            device_name: cstr_field(&props.device_name),
            device_type: props.device_type,
            vendor_id: props.vendor_id,
            device_id: props.device_id,
            dispatch_workers: dispatch_workers(props.device_type, &driver_name),
            driver_name,
            driver_info: cstr_field(&driver_props.driver_info),
            api_version: (
                vk::api_version_major(props.api_version),
                vk::api_version_minor(props.api_version),
                vk::api_version_patch(props.api_version),
            ),
            mesh_shader,
            subgroup_size: subgroup_props.subgroup_size,
            linear_filter_rgba32f: filterable(vk::Format::R32G32B32A32_SFLOAT),
            linear_filter_rgba16f: filterable(vk::Format::R16G16B16A16_SFLOAT),
            timestamp_period_ns: timestamps.then_some(props.limits.timestamp_period),
            max_storage_buffer_range: props.limits.max_storage_buffer_range,
            min_storage_buffer_offset_alignment: props.limits.min_storage_buffer_offset_alignment,
            max_push_constants_size: props.limits.max_push_constants_size,
            max_compute_work_group_count: props.limits.max_compute_work_group_count,
            max_image_dimension_3d: props.limits.max_image_dimension3_d,
            pipeline_statistics_query: features.pipeline_statistics_query == vk::TRUE,
            sampler_anisotropy: features.sampler_anisotropy == vk::TRUE,
            sub_texel_precision_bits: props.limits.sub_texel_precision_bits,
            shader_int64: features.shader_int64 == vk::TRUE,
            buffer_int64_atomics,
            buffer_device_address,
        }
    }
}

/// llvmpipe runs compute (and task) dispatches on a pool of `LP_NUM_THREADS` threads, by default
/// one per CPU the process may run on (none with one CPU: the dispatch runs inline), splitting
/// each dispatch's workgroups into one contiguous run per thread (Mesa's `lp_cs_tpool`). Capped
/// at llvmpipe's 32 threads.
fn dispatch_workers(device_type: vk::PhysicalDeviceType, driver_name: &str) -> u32 {
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    llvmpipe_workers(device_type, driver_name, std::env::var("LP_NUM_THREADS").ok().as_deref(), cpus)
}

/// [`dispatch_workers`] with the environment and the CPU count given.
fn llvmpipe_workers(
    device_type: vk::PhysicalDeviceType,
    driver_name: &str,
    lp_num_threads: Option<&str>,
    cpus: usize,
) -> u32 {
    if device_type != vk::PhysicalDeviceType::CPU || !driver_name.contains("llvmpipe") {
        return 1;
    }
    // Mesa reads LP_NUM_THREADS as a number (anything else: its default); 0 runs dispatches
    // inline, one run.
    let threads = lp_num_threads.and_then(|v| v.trim().parse::<usize>().ok()).unwrap_or(cpus);
    threads.clamp(1, 32) as u32
}

pub(crate) fn cstr_field(chars: &[std::ffi::c_char]) -> String {
    // Vulkan NUL-terminates these fixed arrays; a missing NUL just ends at the array.
    let bytes: Vec<u8> = chars.iter().take_while(|c| **c != 0).map(|c| *c as u8).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// # Safety
/// `physical` must come from `instance`.
pub(crate) unsafe fn has_device_extension(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    name: &CStr,
) -> bool {
    // SAFETY: valid instance and device, per the caller.
    let exts = unsafe { instance.enumerate_device_extension_properties(physical) }.unwrap_or_default();
    exts.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
}

fn yes_no(b: bool) -> &'static str {
    if b { "yes" } else { "no" }
}

impl fmt::Display for Capabilities {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (ma, mi, pa) = self.api_version;
        writeln!(f, "device:                 {} ({:?})", self.device_name, self.device_type)?;
        writeln!(f, "driver:                 {} ({})", self.driver_name, self.driver_info)?;
        writeln!(f, "vendor/device id:       {:#06x}/{:#06x}", self.vendor_id, self.device_id)?;
        writeln!(f, "Vulkan API:             {ma}.{mi}.{pa}")?;
        match &self.mesh_shader {
            Some(m) => {
                writeln!(f, "VK_EXT_mesh_shader:     yes (task + mesh)")?;
                writeln!(
                    f,
                    "  mesh output:          {} vertices, {} primitives, {} bytes",
                    m.max_output_vertices, m.max_output_primitives, m.max_output_memory_size
                )?;
                writeln!(
                    f,
                    "  invocations:          mesh {} (preferred {}), task {} (preferred {})",
                    m.max_mesh_work_group_invocations,
                    m.max_preferred_mesh_work_group_invocations,
                    m.max_task_work_group_invocations,
                    m.max_preferred_task_work_group_invocations
                )?;
                writeln!(
                    f,
                    "  task groups:          {:?} (total {}), payload {} bytes",
                    m.max_task_work_group_count, m.max_task_work_group_total_count, m.max_task_payload_size
                )?;
                writeln!(f, "  mesh groups:          {:?}", m.max_mesh_work_group_count)?;
            }
            None => writeln!(f, "VK_EXT_mesh_shader:     no")?,
        }
        writeln!(f, "subgroup size:          {}", self.subgroup_size)?;
        writeln!(
            f,
            "linear filter RGBA32F:  {} (RGBA16F: {})",
            yes_no(self.linear_filter_rgba32f),
            yes_no(self.linear_filter_rgba16f)
        )?;
        match self.timestamp_period_ns {
            Some(p) => writeln!(f, "timestamp period:       {p} ns")?,
            None => writeln!(f, "timestamp period:       no timestamps")?,
        }
        writeln!(
            f,
            "max storage buffer:     {} bytes ({} MiB)",
            self.max_storage_buffer_range,
            self.max_storage_buffer_range / (1 << 20)
        )?;
        writeln!(f, "max push constants:     {} bytes", self.max_push_constants_size)?;
        writeln!(f, "max 3D image:           {}", self.max_image_dimension_3d)?;
        writeln!(f, "sub-texel precision:    {} bits", self.sub_texel_precision_bits)?;
        writeln!(f, "64-bit integers:        {}", yes_no(self.shader_int64))?;
        writeln!(f, "64-bit buffer atomics:  {}", yes_no(self.buffer_int64_atomics))?;
        writeln!(f, "buffer device address:  {}", yes_no(self.buffer_device_address))?;
        writeln!(f, "dispatch workers:       {}", self.dispatch_workers)?;
        write!(f, "pipeline statistics:    {}", yes_no(self.pipeline_statistics_query))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_workers_follow_llvmpipe_threads_and_are_one_elsewhere() {
        let cpu = vk::PhysicalDeviceType::CPU;
        assert_eq!(llvmpipe_workers(cpu, "llvmpipe", None, 2), 2);
        assert_eq!(llvmpipe_workers(cpu, "llvmpipe", Some("6"), 2), 6);
        assert_eq!(llvmpipe_workers(cpu, "llvmpipe", Some("0"), 2), 1);
        assert_eq!(llvmpipe_workers(cpu, "llvmpipe", Some("lots"), 3), 3);
        assert_eq!(llvmpipe_workers(cpu, "llvmpipe", None, 128), 32);
        assert_eq!(llvmpipe_workers(cpu, "SwiftShader", None, 8), 1);
        assert_eq!(llvmpipe_workers(vk::PhysicalDeviceType::DISCRETE_GPU, "NVIDIA", None, 16), 1);
    }
}
