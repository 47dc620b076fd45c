use std::sync::Arc;

use ash::vk;
use shader_build::{ShaderSpirv, ShaderStage};

use super::context::DeviceShared;
use super::pipeline_registry::{GraphicsState, PipelineKey, PipelineObjects};
use crate::error::VkResultExt;
use crate::{Context, Result};

/// One descriptor binding of set 0 (bound with push descriptors).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Binding {
    pub binding: u32,
    pub ty: vk::DescriptorType,
    pub stages: vk::ShaderStageFlags,
}

impl Binding {
    pub fn storage_buffer(binding: u32, stages: vk::ShaderStageFlags) -> Self {
        Self { binding, ty: vk::DescriptorType::STORAGE_BUFFER, stages }
    }

    /// A storage buffer at each of `bindings`, for `stages`.
    pub fn storage_buffers(bindings: &[u32], stages: vk::ShaderStageFlags) -> Vec<Self> {
        bindings.iter().map(|&b| Self::storage_buffer(b, stages)).collect()
    }
}

/// How to create a compute [`Pipeline`].
#[derive(Clone, Copy, Debug)]
pub struct ComputePipelineDesc<'a> {
    pub name: &'a str,
    pub shader: &'a ShaderSpirv,
    pub bindings: &'a [Binding],
    pub push_constant_size: u32,
    /// `(constant_id, value)` specialization constants, all 32-bit.
    pub specialization: &'a [(u32, u32)],
}

impl<'a> ComputePipelineDesc<'a> {
    /// A kernel without specialization constants (most of them).
    pub fn new(
        name: &'a str,
        shader: &'a ShaderSpirv,
        bindings: &'a [Binding],
        push_constant_size: u32,
    ) -> Self {
        Self { name, shader, bindings, push_constant_size, specialization: &[] }
    }
}

/// The stages before rasterization.
#[derive(Clone, Copy, Debug)]
pub enum GraphicsStages<'a> {
    /// A vertex shader (vertex pulling: no vertex input state).
    Vertex(&'a ShaderSpirv),
    /// Optional task shader + mesh shader (VK_EXT_mesh_shader).
    Mesh { task: Option<&'a ShaderSpirv>, mesh: &'a ShaderSpirv },
}

/// How fragments combine with the colour target.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Blend {
    /// Replace.
    #[default]
    Replace,
    /// Premultiplied alpha "over".
    Over,
    /// Sum (accumulation targets such as opacity maps).
    Additive,
}

/// How to create a graphics [`Pipeline`] drawing triangles with dynamic rendering.
#[derive(Clone, Copy, Debug)]
pub struct GraphicsPipelineDesc<'a> {
    pub name: &'a str,
    pub stages: GraphicsStages<'a>,
    pub fragment: &'a ShaderSpirv,
    pub bindings: &'a [Binding],
    pub push_constant_size: u32,
    pub specialization: &'a [(u32, u32)],
    pub color_format: vk::Format,
    pub depth_format: Option<vk::Format>,
    pub blend: Blend,
    /// Depth writes (with a depth format; the depth test is on whenever there is one).
    pub depth_write: bool,
    /// Colour writes (off for passes that only store into buffers).
    pub color_write: bool,
    /// Rasterization samples (1 = no MSAA); must match the attachments'.
    pub samples: u32,
    /// Depth test [`vk::CompareOp::LESS`] unless a pass needs another (e.g. a resolve writing
    /// `gl_FragDepth`).
    pub depth_compare: vk::CompareOp,
}

/// A pipeline with its layout (and push-descriptor set layout). The Vulkan objects belong to
/// the device's pipeline registry (made once per device for the same shaders, bindings,
/// constants and state; destroyed with the device); this handle keeps the device alive.
pub struct Pipeline {
    _shared: Arc<DeviceShared>,
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub bind_point: vk::PipelineBindPoint,
    pub push_constant_stages: vk::ShaderStageFlags,
    /// Each stage's push-constant block as its SPIR-V declares it (byte ranges): what
    /// [`crate::Recorder::push_constants`] checks a Rust struct against.
    push_blocks: Vec<[u32; 2]>,
    name: String,
}

pub type ComputePipeline = Pipeline;
pub type GraphicsPipeline = Pipeline;

impl std::fmt::Debug for Pipeline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pipeline").field("name", &self.name).field("bind_point", &self.bind_point).finish()
    }
}

/// The layouts of a pipeline being made: destroyed if it fails before [`Unfinished::finish`].
struct Unfinished<'a> {
    device: &'a ash::Device,
    layouts: Option<(vk::DescriptorSetLayout, vk::PipelineLayout)>,
}

impl Unfinished<'_> {
    fn finish(mut self, raw: vk::Pipeline) -> PipelineObjects {
        let (set_layout, layout) = self.layouts.take().unwrap_or_default();
        PipelineObjects { raw, layout, set_layout }
    }
}

impl Drop for Unfinished<'_> {
    fn drop(&mut self) {
        if let Some((set_layout, layout)) = self.layouts.take() {
            let objects = PipelineObjects { raw: vk::Pipeline::null(), layout, set_layout };
            // SAFETY: made on this device by the failed creation, never used.
            unsafe { objects.destroy(self.device) };
        }
    }
}

/// A shader module that lives only while a pipeline is created.
struct ShaderModule<'a> {
    device: &'a ash::Device,
    raw: vk::ShaderModule,
}

impl<'a> ShaderModule<'a> {
    fn new(ctx: &'a Context, shader: &ShaderSpirv) -> Result<Self> {
        let words = shader.words();
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: `words` is SPIR-V produced by glslang at build time and outlives the call.
        let raw = unsafe { ctx.device().create_shader_module(&info, None) }.call("vkCreateShaderModule")?;
        ctx.set_name(raw, shader.name);
        Ok(Self { device: ctx.device(), raw })
    }
}

impl Drop for ShaderModule<'_> {
    fn drop(&mut self) {
        // SAFETY: pipelines created from the module do not need it after creation.
        unsafe { self.device.destroy_shader_module(self.raw, None) };
    }
}

pub(crate) fn stage_flag(stage: ShaderStage) -> vk::ShaderStageFlags {
    match stage {
        ShaderStage::Vertex => vk::ShaderStageFlags::VERTEX,
        ShaderStage::Fragment => vk::ShaderStageFlags::FRAGMENT,
        ShaderStage::Compute => vk::ShaderStageFlags::COMPUTE,
        ShaderStage::Task => vk::ShaderStageFlags::TASK_EXT,
        ShaderStage::Mesh => vk::ShaderStageFlags::MESH_EXT,
    }
}

struct Specialization {
    entries: Vec<vk::SpecializationMapEntry>,
    data: Vec<u8>,
}

impl Specialization {
    fn new(constants: &[(u32, u32)]) -> Self {
        let entries = constants
            .iter()
            .enumerate()
            .map(|(i, (id, _))| vk::SpecializationMapEntry {
                constant_id: *id,
                offset: (i * 4) as u32,
                size: 4,
            })
            .collect();
        let data = constants.iter().flat_map(|(_, v)| v.to_le_bytes()).collect();
        Self { entries, data }
    }

    fn info(&self) -> vk::SpecializationInfo<'_> {
        vk::SpecializationInfo::default().map_entries(&self.entries).data(&self.data)
    }
}

impl Pipeline {
    fn layout(
        ctx: &Context,
        name: &str,
        bindings: &[Binding],
        push_constant_size: u32,
        push_stages: vk::ShaderStageFlags,
    ) -> Result<(vk::DescriptorSetLayout, vk::PipelineLayout)> {
        let vk_bindings: Vec<_> = bindings
            .iter()
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.binding)
                    .descriptor_type(b.ty)
                    .descriptor_count(1)
                    .stage_flags(b.stages)
            })
            .collect();
        let set_info = vk::DescriptorSetLayoutCreateInfo::default()
            .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
            .bindings(&vk_bindings);
        let device = ctx.device();
        // SAFETY: valid device and create info.
        let set_layout = unsafe { device.create_descriptor_set_layout(&set_info, None) }
            .call("vkCreateDescriptorSetLayout")?;
        let ranges =
            [vk::PushConstantRange { stage_flags: push_stages, offset: 0, size: push_constant_size }];
        let set_layouts = [set_layout];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_constant_size > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        // SAFETY: valid device, the set layout was just created.
        match unsafe { device.create_pipeline_layout(&layout_info, None) } {
            Ok(layout) => {
                ctx.set_name(set_layout, &format!("{name} set layout"));
                ctx.set_name(layout, &format!("{name} layout"));
                Ok((set_layout, layout))
            }
            Err(result) => {
                // SAFETY: unused set layout.
                unsafe { device.destroy_descriptor_set_layout(set_layout, None) };
                Err(crate::GpuError::Vulkan { call: "vkCreatePipelineLayout", result })
            }
        }
    }

    /// Creates a compute pipeline (or finds the device's pipeline made from the same desc).
    pub fn compute(ctx: &Context, desc: &ComputePipelineDesc<'_>) -> Result<Self> {
        let push_stages = vk::ShaderStageFlags::COMPUTE;
        // Every compute pipeline gets the dispatch order's worker count (a map entry for a
        // constant the shader does not declare is ignored).
        let mut constants = desc.specialization.to_vec();
        if !constants.iter().any(|(id, _)| *id == crate::contract::DISPATCH_WORKERS_CONSTANT_ID) {
            constants.push((crate::contract::DISPATCH_WORKERS_CONSTANT_ID, ctx.dispatch_workers()));
        }
        let key = PipelineKey::new(&[desc.shader], desc.bindings, desc.push_constant_size, &constants, None);
        let objects = ctx.shared.pipelines.get_or_create(ctx.device(), key, || {
            let (set_layout, layout) =
                Self::layout(ctx, desc.name, desc.bindings, desc.push_constant_size, push_stages)?;
            let unfinished = Unfinished { device: ctx.device(), layouts: Some((set_layout, layout)) };
            let module = ShaderModule::new(ctx, desc.shader)?;
            let spec = Specialization::new(&constants);
            let spec_info = spec.info();
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module.raw)
                .name(c"main")
                .specialization_info(&spec_info);
            let info = vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout);
            // SAFETY: valid device; module, layout and create info outlive the call.
            let raw =
                unsafe { ctx.device().create_compute_pipelines(vk::PipelineCache::null(), &[info], None) }
                    .map_err(|(_, e)| e)
                    .call("vkCreateComputePipelines")?;
            ctx.set_name(raw[0], desc.name);
            Ok(unfinished.finish(raw[0]))
        })?;
        let blocks: Vec<[u32; 2]> = desc.shader.push_constants.into_iter().collect();
        Ok(Self::handle(ctx, objects, vk::PipelineBindPoint::COMPUTE, push_stages, blocks, desc.name))
    }

    /// The handle callers hold to the registry's `objects`.
    fn handle(
        ctx: &Context,
        objects: PipelineObjects,
        bind_point: vk::PipelineBindPoint,
        push_constant_stages: vk::ShaderStageFlags,
        push_blocks: Vec<[u32; 2]>,
        name: &str,
    ) -> Self {
        Pipeline {
            _shared: ctx.shared.clone(),
            raw: objects.raw,
            layout: objects.layout,
            bind_point,
            push_constant_stages,
            push_blocks,
            name: name.into(),
        }
    }

    /// Why pushing `len` bytes at `offset` does not match what the shaders declare, if it does
    /// not. No stage may read push constants past the pushed bytes where it overlaps them (it
    /// would read stale bytes); a compute shader's block must be the pushed bytes exactly, up to
    /// a 16-byte alignment's padding at the end. Graphics pipelines may be pushed more than a
    /// stage reads (a depth-only variant shares its colour variant's constants). A Rust struct
    /// that mirrors a GLSL block by hand gets these from a field missing on either side.
    pub fn push_mismatch(&self, offset: u32, len: u32) -> Option<String> {
        let end = offset + len;
        for &[lo, hi] in &self.push_blocks {
            if lo < end && offset < hi && (lo < offset || hi > end) {
                return Some(format!(
                    "{}: a shader reads push constants {lo}..{hi}, but {offset}..{end} is pushed",
                    self.name
                ));
            }
        }
        if self.bind_point == vk::PipelineBindPoint::COMPUTE
            && let Some(&[lo, hi]) = self.push_blocks.first()
            && (lo != offset || end > hi.next_multiple_of(16))
        {
            return Some(format!(
                "{}: {offset}..{end} is pushed, but the kernel declares {lo}..{hi}",
                self.name
            ));
        }
        None
    }

    /// Creates a graphics pipeline (triangle lists, no culling, optional depth test).
    pub fn graphics(ctx: &Context, desc: &GraphicsPipelineDesc<'_>) -> Result<Self> {
        let pre_raster: Vec<&ShaderSpirv> = match desc.stages {
            GraphicsStages::Vertex(v) => vec![v],
            GraphicsStages::Mesh { task, mesh } => task.into_iter().chain([mesh]).collect(),
        };
        let push_stages = pre_raster
            .iter()
            .chain([&desc.fragment])
            .fold(vk::ShaderStageFlags::empty(), |acc, s| acc | stage_flag(s.stage));
        let shaders: Vec<&ShaderSpirv> = pre_raster.into_iter().chain([desc.fragment]).collect();
        let state = GraphicsState {
            color_format: desc.color_format.as_raw(),
            depth_format: desc.depth_format.map(vk::Format::as_raw),
            blend: desc.blend,
            depth_write: desc.depth_write,
            color_write: desc.color_write,
            samples: desc.samples,
            depth_compare: desc.depth_compare.as_raw(),
        };
        let key = PipelineKey::new(
            &shaders,
            desc.bindings,
            desc.push_constant_size,
            desc.specialization,
            Some(state),
        );
        let objects = ctx
            .shared
            .pipelines
            .get_or_create(ctx.device(), key, || Self::create_graphics(ctx, desc, &shaders, push_stages))?;
        let blocks: Vec<[u32; 2]> = shaders.iter().filter_map(|s| s.push_constants).collect();
        Ok(Self::handle(ctx, objects, vk::PipelineBindPoint::GRAPHICS, push_stages, blocks, desc.name))
    }

    fn create_graphics(
        ctx: &Context,
        desc: &GraphicsPipelineDesc<'_>,
        shaders: &[&ShaderSpirv],
        push_stages: vk::ShaderStageFlags,
    ) -> Result<PipelineObjects> {
        let (set_layout, layout) =
            Self::layout(ctx, desc.name, desc.bindings, desc.push_constant_size, push_stages)?;
        let unfinished = Unfinished { device: ctx.device(), layouts: Some((set_layout, layout)) };
        let modules = shaders.iter().map(|s| ShaderModule::new(ctx, s)).collect::<Result<Vec<_>>>()?;
        let spec = Specialization::new(desc.specialization);
        let spec_info = spec.info();
        let stages: Vec<_> = shaders
            .iter()
            .zip(&modules)
            .map(|(s, m)| {
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(stage_flag(s.stage))
                    .module(m.raw)
                    .name(c"main")
                    .specialization_info(&spec_info)
            })
            .collect();
        let is_mesh = matches!(desc.stages, GraphicsStages::Mesh { .. });
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(super::resource::sample_count(desc.samples));
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(desc.depth_format.is_some())
            .depth_write_enable(desc.depth_format.is_some() && desc.depth_write)
            .depth_compare_op(desc.depth_compare);
        let write_mask =
            if desc.color_write { vk::ColorComponentFlags::RGBA } else { vk::ColorComponentFlags::empty() };
        let blended = |dst| {
            vk::PipelineColorBlendAttachmentState::default()
                .blend_enable(true)
                .src_color_blend_factor(vk::BlendFactor::ONE)
                .dst_color_blend_factor(dst)
                .color_blend_op(vk::BlendOp::ADD)
                .src_alpha_blend_factor(vk::BlendFactor::ONE)
                .dst_alpha_blend_factor(dst)
                .alpha_blend_op(vk::BlendOp::ADD)
                .color_write_mask(write_mask)
        };
        let attachment = match desc.blend {
            Blend::Replace => vk::PipelineColorBlendAttachmentState::default().color_write_mask(write_mask),
            Blend::Over => blended(vk::BlendFactor::ONE_MINUS_SRC_ALPHA),
            Blend::Additive => blended(vk::BlendFactor::ONE),
        };
        let attachments = [attachment];
        let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let color_formats = [desc.color_format];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(desc.depth_format.unwrap_or(vk::Format::UNDEFINED));
        let mut info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        if !is_mesh {
            info = info.vertex_input_state(&vertex_input).input_assembly_state(&input_assembly);
        }
        // SAFETY: valid device; every struct the create info points to outlives the call.
        let raw = unsafe { ctx.device().create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
            .map_err(|(_, e)| e)
            .call("vkCreateGraphicsPipelines")?;
        ctx.set_name(raw[0], desc.name);
        Ok(unfinished.finish(raw[0]))
    }

    pub fn name(&self) -> &str {
        &self.name
    }
}
