//! Every pipeline a device has made, by what it was made from, so that the same shader with the
//! same bindings, constants and state is made once per device.
//!
//! A renderer made again for the same scene (a test comparing two settings, the editor after a
//! conversion, `hair-bench` per row) asks for the pipelines it asked for before. On lavapipe,
//! making a pipeline — SPIR-V to NIR, NIR's optimisation, then LLVM — costs far more than the
//! small frames such callers draw, and neither Mesa's disk cache (which keeps only the compiled
//! code) nor a `VkPipelineCache` skips the NIR work. The registry owns the Vulkan objects
//! until the device is dropped; the set of distinct pipelines a program makes is small and
//! fixed by its shaders and settings.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::sync::Mutex;

use ash::vk;
use shader_build::ShaderSpirv;

use super::pipeline::{Binding, Blend};
use crate::Result;

/// What a pipeline is made from: equal keys make the same pipeline.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) struct PipelineKey {
    /// Per stage: the shader's name and where its SPIR-V is embedded (unique in the program).
    shaders: Vec<(&'static str, usize, usize)>,
    bindings: Vec<Binding>,
    push_constant_size: u32,
    /// Specialization constants, sorted by id.
    constants: Vec<(u32, u32)>,
    /// Graphics pipelines' fixed-function state; `None` for compute.
    graphics: Option<GraphicsState>,
}

/// The fixed-function state of a graphics pipeline, as raw values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct GraphicsState {
    pub color_format: i32,
    pub depth_format: Option<i32>,
    pub blend: Blend,
    pub depth_write: bool,
    pub color_write: bool,
    pub samples: u32,
    pub depth_compare: i32,
}

impl PipelineKey {
    pub(crate) fn new(
        shaders: &[&ShaderSpirv],
        bindings: &[Binding],
        push_constant_size: u32,
        constants: &[(u32, u32)],
        graphics: Option<GraphicsState>,
    ) -> Self {
        let mut constants = constants.to_vec();
        constants.sort_unstable();
        PipelineKey {
            shaders: shaders.iter().map(|s| (s.name, s.spirv.as_ptr() as usize, s.spirv.len())).collect(),
            bindings: bindings.to_vec(),
            push_constant_size,
            constants,
            graphics,
        }
    }
}

/// The Vulkan objects of one pipeline.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PipelineObjects {
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
}

impl PipelineObjects {
    /// # Safety
    /// The objects were made on `device` and nothing uses them any more.
    pub(crate) unsafe fn destroy(self, device: &ash::Device) {
        // SAFETY: the caller's guarantee; reverse order of creation.
        unsafe {
            if self.raw != vk::Pipeline::null() {
                device.destroy_pipeline(self.raw, None);
            }
            if self.layout != vk::PipelineLayout::null() {
                device.destroy_pipeline_layout(self.layout, None);
            }
            if self.set_layout != vk::DescriptorSetLayout::null() {
                device.destroy_descriptor_set_layout(self.set_layout, None);
            }
        }
    }
}

/// The pipelines of one device.
#[derive(Debug, Default)]
pub(crate) struct PipelineRegistry {
    entries: Mutex<HashMap<PipelineKey, PipelineObjects>>,
}

impl PipelineRegistry {
    /// The pipeline for `key`, made by `create` the first time it is asked for. The lock is
    /// not held while `create` runs (it may take seconds); if another thread made the same
    /// pipeline meanwhile, that one is kept and this one destroyed.
    pub(crate) fn get_or_create(
        &self,
        device: &ash::Device,
        key: PipelineKey,
        create: impl FnOnce() -> Result<PipelineObjects>,
    ) -> Result<PipelineObjects> {
        if let Some(objects) = self.lock().get(&key) {
            return Ok(*objects);
        }
        let made = create()?;
        match self.lock().entry(key) {
            Entry::Occupied(existing) => {
                // SAFETY: made on this device a moment ago and never handed out.
                unsafe { made.destroy(device) };
                Ok(*existing.get())
            }
            Entry::Vacant(slot) => Ok(*slot.insert(made)),
        }
    }

    /// How many distinct pipelines the device has made.
    pub(crate) fn len(&self) -> usize {
        self.lock().len()
    }

    /// # Safety
    /// The device is idle and no [`super::pipeline::Pipeline`] made on it is alive.
    pub(crate) unsafe fn destroy_all(&mut self, device: &ash::Device) {
        let entries = self.entries.get_mut().unwrap_or_else(|e| e.into_inner());
        for (_, objects) in entries.drain() {
            // SAFETY: the caller's guarantee.
            unsafe { objects.destroy(device) };
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<PipelineKey, PipelineObjects>> {
        self.entries.lock().unwrap_or_else(|e| e.into_inner())
    }
}
