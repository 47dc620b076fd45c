use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};

use super::context::DeviceShared;
use crate::error::VkResultExt;
use crate::{Context, GpuError, Result};

/// How to create a [`Buffer`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BufferDesc {
    pub size: u64,
    pub usage: vk::BufferUsageFlags,
    pub location: MemoryLocation,
}

impl BufferDesc {
    /// A device-local storage buffer that can also be copied to and from.
    pub fn storage(size: u64) -> Self {
        Self {
            size,
            usage: vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::TRANSFER_DST,
            location: MemoryLocation::GpuOnly,
        }
    }

    pub fn usage(mut self, usage: vk::BufferUsageFlags) -> Self {
        self.usage |= usage;
        self
    }

    pub fn location(mut self, location: MemoryLocation) -> Self {
        self.location = location;
        self
    }
}

/// A buffer and its memory; both are freed on drop.
pub struct Buffer {
    shared: Arc<DeviceShared>,
    pub raw: vk::Buffer,
    allocation: Option<Allocation>,
    pub desc: BufferDesc,
    name: String,
    /// The buffer's device address (storage buffers on devices with `bufferDeviceAddress`; 0
    /// elsewhere).
    address: vk::DeviceAddress,
}

impl std::fmt::Debug for Buffer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Buffer").field("name", &self.name).field("size", &self.desc.size).finish()
    }
}

impl Buffer {
    pub fn new(ctx: &Context, name: &str, desc: BufferDesc) -> Result<Self> {
        let max_alloc = 1u64 << 31;
        if desc.size == 0 || desc.size > max_alloc {
            return Err(GpuError::OverBudget {
                name: name.into(),
                requested: desc.size,
                budget: max_alloc,
                why: "buffers must be 1 byte to 2 GiB",
            });
        }
        let device = ctx.device();
        // Every storage buffer gets an address where the device has them: kernels may read it
        // through a buffer reference (Capabilities::buffer_device_address says why).
        let addressable = ctx.capabilities().buffer_device_address
            && desc.usage.contains(vk::BufferUsageFlags::STORAGE_BUFFER);
        let usage =
            if addressable { desc.usage | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS } else { desc.usage };
        let info = vk::BufferCreateInfo::default()
            .size(desc.size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let raw = unsafe { device.create_buffer(&info, None) }.call("vkCreateBuffer")?;
        // SAFETY: `raw` was just created from this device.
        let requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        let allocation = ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location: desc.location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: the buffer has no memory bound and is not in use.
                unsafe { device.destroy_buffer(raw, None) };
                return Err(GpuError::Allocation { name: name.into(), source });
            }
        };
        let mut buffer = Buffer {
            shared: ctx.shared.clone(),
            raw,
            allocation: Some(allocation),
            desc,
            name: name.into(),
            address: 0,
        };
        let alloc = buffer
            .allocation
            .as_ref()
            .ok_or(GpuError::Vulkan { call: "allocate", result: vk::Result::ERROR_UNKNOWN })?;
        // SAFETY: memory and offset come from an allocation made for this buffer's requirements.
        unsafe { device.bind_buffer_memory(raw, alloc.memory(), alloc.offset()) }
            .call("vkBindBufferMemory")?;
        if addressable {
            // SAFETY: the buffer was created with SHADER_DEVICE_ADDRESS usage on a device with the
            // feature enabled, and its memory is bound.
            buffer.address = unsafe {
                device.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(raw))
            };
        }
        ctx.set_name(raw, name);
        Ok(buffer)
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn size(&self) -> u64 {
        self.desc.size
    }

    /// The device address of a storage buffer, where the device has them (0 elsewhere: a
    /// kernel given 0 reads the buffer through its binding instead).
    pub fn device_address(&self) -> u64 {
        self.address
    }

    /// The mapped bytes of a host-visible buffer.
    pub fn mapped(&self) -> Option<&[u8]> {
        self.allocation.as_ref()?.mapped_slice()
    }

    /// The mapped bytes of a host-visible buffer, for writing.
    pub fn mapped_mut(&mut self) -> Option<&mut [u8]> {
        self.allocation.as_mut()?.mapped_slice_mut()
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // Destroyed now, or after the open submissions that may use it (DeviceShared::retire).
        self.shared.retire(super::context::Retired::Buffer {
            raw: self.raw,
            allocation: self.allocation.take(),
            name: std::mem::take(&mut self.name),
        });
    }
}

/// How to create an [`Image`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageDesc {
    pub extent: vk::Extent3D,
    pub format: vk::Format,
    pub usage: vk::ImageUsageFlags,
    pub image_type: vk::ImageType,
    /// Samples per texel (multisampled colour and depth targets).
    pub samples: vk::SampleCountFlags,
}

impl ImageDesc {
    pub fn d2(width: u32, height: u32, format: vk::Format, usage: vk::ImageUsageFlags) -> Self {
        Self {
            extent: vk::Extent3D { width, height, depth: 1 },
            format,
            usage,
            image_type: vk::ImageType::TYPE_2D,
            samples: vk::SampleCountFlags::TYPE_1,
        }
    }

    pub fn d3(extent: vk::Extent3D, format: vk::Format, usage: vk::ImageUsageFlags) -> Self {
        Self {
            extent,
            format,
            usage,
            image_type: vk::ImageType::TYPE_3D,
            samples: vk::SampleCountFlags::TYPE_1,
        }
    }

    /// A multisampled image with `samples` samples per texel (1, 2, 4 or 8).
    pub fn with_samples(mut self, samples: u32) -> Self {
        self.samples = sample_count(samples);
        self
    }

    pub fn with_usage(mut self, usage: vk::ImageUsageFlags) -> Self {
        self.usage |= usage;
        self
    }

    fn aspect(&self) -> vk::ImageAspectFlags {
        match self.format {
            vk::Format::D32_SFLOAT | vk::Format::D16_UNORM => vk::ImageAspectFlags::DEPTH,
            _ => vk::ImageAspectFlags::COLOR,
        }
    }
}

/// An image, its memory and a view of the whole image; all freed on drop.
pub struct Image {
    shared: Arc<DeviceShared>,
    pub raw: vk::Image,
    pub view: vk::ImageView,
    allocation: Option<Allocation>,
    pub desc: ImageDesc,
    name: String,
}

impl std::fmt::Debug for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Image")
            .field("name", &self.name)
            .field("extent", &self.desc.extent)
            .field("format", &self.desc.format)
            .finish()
    }
}

impl Image {
    pub fn new(ctx: &Context, name: &str, desc: ImageDesc) -> Result<Self> {
        let e = desc.extent;
        if e.width == 0 || e.height == 0 || e.depth == 0 {
            return Err(GpuError::OverBudget {
                name: name.into(),
                requested: 0,
                budget: 0,
                why: "images must have a non-zero extent",
            });
        }
        let device = ctx.device();
        let info = vk::ImageCreateInfo::default()
            .image_type(desc.image_type)
            .format(desc.format)
            .extent(desc.extent)
            .mip_levels(1)
            .array_layers(1)
            .samples(desc.samples)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        let raw = unsafe { device.create_image(&info, None) }.call("vkCreateImage")?;
        // SAFETY: `raw` was just created from this device.
        let requirements = unsafe { device.get_image_memory_requirements(raw) };
        let allocation = match ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        }) {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: not bound, not in use.
                unsafe { device.destroy_image(raw, None) };
                return Err(GpuError::Allocation { name: name.into(), source });
            }
        };
        // SAFETY: memory from an allocation made for this image's requirements.
        let bound = unsafe { device.bind_image_memory(raw, allocation.memory(), allocation.offset()) };
        let mut image = Image {
            shared: ctx.shared.clone(),
            raw,
            view: vk::ImageView::null(),
            allocation: Some(allocation),
            desc,
            name: name.into(),
        };
        bound.call("vkBindImageMemory")?;
        let view_type = if desc.image_type == vk::ImageType::TYPE_3D {
            vk::ImageViewType::TYPE_3D
        } else {
            vk::ImageViewType::TYPE_2D
        };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(view_type)
            .format(desc.format)
            .subresource_range(image.full_range());
        // SAFETY: the image is bound to memory; the view covers its single mip and layer.
        image.view = unsafe { device.create_image_view(&view_info, None) }.call("vkCreateImageView")?;
        ctx.set_name(raw, name);
        ctx.set_name(image.view, &format!("{name} view"));
        Ok(image)
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn full_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: self.desc.aspect(),
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        }
    }

    pub fn layers(&self) -> vk::ImageSubresourceLayers {
        vk::ImageSubresourceLayers {
            aspect_mask: self.desc.aspect(),
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        }
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        // Destroyed now, or after the open submissions that may use it (DeviceShared::retire).
        self.shared.retire(super::context::Retired::Image {
            raw: self.raw,
            view: self.view,
            allocation: self.allocation.take(),
            name: std::mem::take(&mut self.name),
        });
    }
}

/// A sampler; destroyed on drop.
pub struct Sampler {
    shared: Arc<DeviceShared>,
    pub raw: vk::Sampler,
}

impl std::fmt::Debug for Sampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sampler").finish()
    }
}

impl Sampler {
    /// Linear filtering, clamp to edge, no mipmaps, normalized coordinates.
    pub fn linear_clamp(ctx: &Context, name: &str) -> Result<Self> {
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(0.0);
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device().create_sampler(&info, None) }.call("vkCreateSampler")?;
        ctx.set_name(raw, name);
        Ok(Self { shared: ctx.shared.clone(), raw })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        // SAFETY: submissions are synchronous, so the sampler is idle.
        unsafe { self.shared.device.destroy_sampler(self.raw, None) };
    }
}

/// The sample-count flag of `samples` (1, 2, 4, 8; other values round down to one of those).
pub fn sample_count(samples: u32) -> vk::SampleCountFlags {
    match samples {
        0 | 1 => vk::SampleCountFlags::TYPE_1,
        2 | 3 => vk::SampleCountFlags::TYPE_2,
        4..=7 => vk::SampleCountFlags::TYPE_4,
        _ => vk::SampleCountFlags::TYPE_8,
    }
}
