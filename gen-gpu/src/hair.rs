//! A hair asset on the GPU: the textures, the bundle table and the root sample sets.

use ash::vk;
use hairmesh::asset::HairAsset;
use hairmesh::roots::SampleDomain;
use hairmesh::texture::Texture3;

use crate::{Buffer, BufferDesc, Context, GpuError, Image, ImageDesc, Result, Sampler};

/// Texel precision of the uploaded textures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TexturePrecision {
    /// RGBA32F where the device can filter it linearly, else RGBA16F.
    #[default]
    Auto,
    F32,
    F16,
}

/// Bytes per uploaded texture, for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureBytes {
    pub hair_mesh: u64,
    pub uv: u64,
    pub w: u64,
    pub u: u64,
    pub v: u64,
    /// Bundle table and root sample sets.
    pub buffers: u64,
}

impl TextureBytes {
    pub fn total(&self) -> u64 {
        self.hair_mesh + self.uv + self.w + self.u + self.v + self.buffers
    }
}

/// `Bundle` in `hair_gen.glsl` (std430, 48 bytes): bounds with face size and hair length, then
/// strands, domain | root symmetry << 1, sample set, packed cell.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuBundle {
    bounds_min: [f32; 4],
    bounds_max: [f32; 4],
    info: [u32; 4],
}

/// Largest slice side whose cells pack into the bundle table (14 bits per axis).
const CELL_AXIS_LIMIT: u32 = 1 << 14;

/// An uploaded hair asset. Owns its GPU objects.
#[derive(Debug)]
pub struct GpuHair {
    pub(crate) hair_mesh: Image,
    pub(crate) uv: Image,
    pub(crate) w: Image,
    pub(crate) u: Image,
    pub(crate) v: Image,
    pub(crate) sampler: Sampler,
    pub(crate) bundles: Buffer,
    pub(crate) samples: Buffer,
    pub(crate) sample_sets: Buffer,
    pub(crate) bundle_count: u32,
    pub(crate) total_strands: u64,
    pub precision: TexturePrecision,
    pub bytes: TextureBytes,
    /// The asset's CPU description (layout, normalization, style, bundle table).
    pub asset: HairAsset,
}

fn texels(tex: &Texture3, channels: u32, half: bool) -> Vec<u8> {
    let n = tex.channels as usize;
    let mut out = Vec::with_capacity(tex.data.len() / n * channels as usize * if half { 2 } else { 4 });
    for texel in tex.data.chunks_exact(n) {
        for c in 0..channels as usize {
            let v = texel.get(c).copied().unwrap_or(0.0);
            if half {
                out.extend(half::f16::from_f64(v).to_le_bytes());
            } else {
                out.extend((v as f32).to_le_bytes());
            }
        }
    }
    out
}

impl GpuHair {
    /// Uploads an asset's five textures (formats by `precision` and the device), bundle table
    /// and sample sets.
    pub fn upload(ctx: &Context, asset: &HairAsset, precision: TexturePrecision) -> Result<Self> {
        let caps = ctx.capabilities();
        let precision = match precision {
            TexturePrecision::Auto if caps.linear_filter_rgba32f => TexturePrecision::F32,
            TexturePrecision::Auto => TexturePrecision::F16,
            p => p,
        };
        let half = precision == TexturePrecision::F16;
        let t = &asset.textures;
        let max3d = caps.max_image_dimension_3d;
        if t.layout.width > max3d || t.layout.height > max3d || t.layout.curve_slices() > max3d {
            return Err(GpuError::OverBudget {
                name: "hair-mesh texture".into(),
                requested: u64::from(t.layout.width.max(t.layout.height).max(t.layout.curve_slices())),
                budget: u64::from(max3d),
                why: "maxImageDimension3D",
            });
        }
        let (rgba, rg, r) = if half {
            (vk::Format::R16G16B16A16_SFLOAT, vk::Format::R16G16_SFLOAT, vk::Format::R16_SFLOAT)
        } else {
            (vk::Format::R32G32B32A32_SFLOAT, vk::Format::R32G32_SFLOAT, vk::Format::R32_SFLOAT)
        };
        let upload = |name: &str, tex: &Texture3, format, channels| -> Result<(Image, u64)> {
            let extent = vk::Extent3D { width: tex.width, height: tex.height, depth: tex.depth };
            let data = texels(tex, channels, half);
            let len = data.len() as u64;
            let desc = if tex.depth > 1 || name != "uv" {
                ImageDesc::d3(extent, format, vk::ImageUsageFlags::SAMPLED)
            } else {
                ImageDesc::d2(tex.width, tex.height, format, vk::ImageUsageFlags::SAMPLED)
            };
            Ok((ctx.create_image_with_data(name, desc, &data)?, len))
        };
        let (hair_mesh, hm_bytes) = upload("hair_mesh", &t.hair_mesh, rgba, 4)?;
        let (uv, uv_bytes) = upload("uv", &t.uv, rg, 2)?;
        let (w, w_bytes) = upload("w", &t.w, r, 1)?;
        let (u, u_bytes) = upload("u", &t.u, rgba, 4)?;
        let (v, v_bytes) = upload("v", &t.v, rgba, 4)?;

        // Cells pack into one u32 each (hair_gen.glsl, block_coord).
        if t.layout.width > CELL_AXIS_LIMIT || t.layout.height > CELL_AXIS_LIMIT {
            return Err(GpuError::OverBudget {
                name: "texture slice".into(),
                requested: u64::from(t.layout.width.max(t.layout.height)),
                budget: u64::from(CELL_AXIS_LIMIT),
                why: "14-bit cell coordinates",
            });
        }
        // Sample sets: squares first, then triangles; bundle b uses set b mod count of its domain.
        let mut points: Vec<u32> = Vec::new();
        let mut set_info: Vec<[u32; 2]> = Vec::new();
        for set in asset.square_sets.iter().chain(&asset.triangle_sets) {
            set_info.push([points.len() as u32, set.points.len() as u32]);
            points.extend(set.points.iter().map(|p| hairmesh::roots::pack_sample(*p)));
        }
        let squares = asset.square_sets.len() as u32;
        let triangles = asset.triangle_sets.len() as u32;
        let gpu_bundles: Vec<GpuBundle> = asset
            .bundles
            .iter()
            .enumerate()
            .map(|(b, info)| {
                let (domain, set) = match info.domain {
                    SampleDomain::Square => (0, b as u32 % squares.max(1)),
                    SampleDomain::Triangle => (1, squares + b as u32 % triangles.max(1)),
                };
                let symmetry = u32::from(asset.root_symmetry(b as u32));
                let cell = &t.layout.cells[b];
                let cell = cell.x | (cell.y << 14) | (u32::from(cell.orientation.code()) << 28);
                let lo = info.bounds_min.as_vec3();
                let hi = info.bounds_max.as_vec3();
                GpuBundle {
                    bounds_min: [lo.x, lo.y, lo.z, info.face_size() as f32],
                    bounds_max: [hi.x, hi.y, hi.z, info.length as f32],
                    info: [info.strands, domain | (symmetry << 1), set, cell],
                }
            })
            .collect();
        let storage = |bytes: &[u8]| BufferDesc::storage(bytes.len().max(16) as u64);
        let bundle_bytes: &[u8] = bytemuck::cast_slice(&gpu_bundles);
        let sample_bytes: &[u8] = bytemuck::cast_slice(&points);
        let set_bytes: &[u8] = bytemuck::cast_slice(&set_info);
        let bundles = ctx.create_buffer_with_data("bundles", storage(bundle_bytes), bundle_bytes)?;
        let samples = ctx.create_buffer_with_data("root samples", storage(sample_bytes), sample_bytes)?;
        let sample_sets = ctx.create_buffer_with_data("root sample sets", storage(set_bytes), set_bytes)?;
        Ok(Self {
            hair_mesh,
            uv,
            w,
            u,
            v,
            sampler: Sampler::linear_clamp(ctx, "hair texture sampler")?,
            bundles,
            samples,
            sample_sets,
            bundle_count: asset.bundles.len() as u32,
            total_strands: asset.total_strands(),
            precision,
            bytes: TextureBytes {
                hair_mesh: hm_bytes,
                uv: uv_bytes,
                w: w_bytes,
                u: u_bytes,
                v: v_bytes,
                buffers: (bundle_bytes.len() + sample_bytes.len() + set_bytes.len()) as u64,
            },
            asset: asset.clone(),
        })
    }

    /// The root uv texture (2D). Resident for styling keyed on uv; today's styling ops do not
    /// sample it.
    pub fn uv_texture(&self) -> &Image {
        &self.uv
    }

    pub fn bundle_count(&self) -> u32 {
        self.bundle_count
    }

    /// Strands with LOD off.
    pub fn total_strands(&self) -> u64 {
        self.total_strands
    }
}
