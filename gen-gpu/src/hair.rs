//! A hair asset on the GPU: the textures, the bundle table and the root sample sets.

use ash::vk;
use hairmesh::asset::{AssetChange, HairAsset};
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
    /// û with w in its alpha channel (one texture: a fetch reads both).
    pub u: u64,
    pub v: u64,
    /// The head's distance field (0 without one).
    pub head_field: u64,
    /// Bundle table and root sample sets.
    pub buffers: u64,
}

impl TextureBytes {
    pub fn total(&self) -> u64 {
        self.hair_mesh + self.uv + self.u + self.v + self.head_field + self.buffers
    }
}

/// `Bundle` in `hair_gen.glsl` (std430, 48 bytes): bounds with face size and hair length, then
/// strands, domain | root symmetry << 1 | tip layer << 4, sample set, packed cell.
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
    /// û in rgb, w in alpha ([`u_w_texel`]).
    pub(crate) u: Image,
    pub(crate) v: Image,
    /// The head's signed distances (one channel, half floats: only values near the surface
    /// matter, where they are small); a 2×2×2 placeholder when the asset has no field
    /// (`GenParams.head_field.w` = 0 tells the shaders).
    pub(crate) head_field: Image,
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

/// Appends one texel's values as `channels` f16 or f32 samples (missing channels are 0).
fn push_texel(out: &mut Vec<u8>, texel: &[f64], channels: u32, half: bool) {
    for c in 0..channels as usize {
        let v = texel.get(c).copied().unwrap_or(0.0);
        if half {
            out.extend(half::f16::from_f64(v).to_le_bytes());
        } else {
            out.extend((v as f32).to_le_bytes());
        }
    }
}

/// û and w share one GPU texture ([`u_w_texel`]): they must have one extent.
fn check_u_w(t: &hairmesh::texture::HairTextures) -> Result<()> {
    if (t.u.width, t.u.height, t.u.depth) != (t.w.width, t.w.height, t.w.depth) {
        return Err(GpuError::Mismatch(format!(
            "the u texture is {}×{}×{} and w {}×{}×{}: they share one GPU texture",
            t.u.width, t.u.height, t.u.depth, t.w.width, t.w.height, t.w.depth
        )));
    }
    Ok(())
}

/// Texel (x, y, z) of the uploaded û texture: û's three channels, then w (the asset keeps them
/// apart; `hair_gen.glsl` reads both with one fetch). The two have one extent ([`check_u_w`]).
fn u_w_texel(u: &Texture3, w: &Texture3, x: u32, y: u32, z: u32) -> [f64; 4] {
    let (a, b) = (u.texel(x, y, z), w.texel(x, y, z));
    let at = |s: &[f64], i: usize| s.get(i).copied().unwrap_or(0.0);
    [at(a, 0), at(a, 1), at(a, 2), at(b, 0)]
}

fn texels(tex: &Texture3, channels: u32, half: bool) -> Vec<u8> {
    let n = tex.channels as usize;
    let mut out = Vec::with_capacity(tex.data.len() / n * channels as usize * if half { 2 } else { 4 });
    for texel in tex.data.chunks_exact(n) {
        push_texel(&mut out, texel, channels, half);
    }
    out
}

/// Whether two assets keep strands out of the same head: the field an edit shares (cheap), or
/// an equal one.
fn same_head_field(a: &HairAsset, b: &HairAsset) -> bool {
    match (&a.head_field, &b.head_field) {
        (Some(x), Some(y)) => std::sync::Arc::ptr_eq(x, y) || x == y,
        (None, None) => true,
        _ => false,
    }
}

/// Bundle `b`'s entry of the GPU bundle table.
fn gpu_bundle(asset: &HairAsset, b: usize) -> GpuBundle {
    let squares = asset.square_sets.len() as u32;
    let triangles = asset.triangle_sets.len() as u32;
    let info = &asset.bundles[b];
    let (domain, set) = match info.domain {
        SampleDomain::Square => (0, b as u32 % squares.max(1)),
        SampleDomain::Triangle => (1, squares + b as u32 % triangles.max(1)),
    };
    let symmetry = u32::from(asset.root_symmetry(b as u32));
    let cell = &asset.textures.layout.cells[b];
    let cell = cell.x | (cell.y << 14) | (u32::from(cell.orientation.code()) << 28);
    let lo = info.bounds_min.as_vec3();
    let hi = info.bounds_max.as_vec3();
    GpuBundle {
        bounds_min: [lo.x, lo.y, lo.z, info.face_size() as f32],
        bounds_max: [hi.x, hi.y, hi.z, info.length as f32],
        info: [info.strands, domain | (symmetry << 1) | (asset.tip_layer(b as u32) << 4), set, cell],
    }
}

/// An update of a [`GpuHair`] packed for the GPU ([`GpuHair::stage_update`]): its staging
/// buffer lives until the submission recording it has completed (submissions wait for their
/// fence, so until the frame returns).
#[derive(Debug)]
pub struct StagedHairUpdate {
    staging: Buffer,
    /// Copies into the hair-mesh, û-with-w and v̂ textures.
    image_copies: [Vec<vk::BufferImageCopy>; 3],
    bundle_copies: Vec<vk::BufferCopy>,
    pub report: HairUpdate,
    /// The asset revision the GPU copy holds once the update has run.
    pub revision: u64,
}

/// What [`GpuHair::update`] sent to the GPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HairUpdate {
    /// Texel columns (one texel of the slice through every slice) rewritten per texture.
    pub texel_columns: u64,
    /// Copy regions per texture (runs of neighbouring texels in a row).
    pub regions: u64,
    /// Bundle-table entries rewritten.
    pub bundles: u64,
    /// Bytes uploaded, textures and table together.
    pub bytes: u64,
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
        // A 3D texture's longest side against the device's limit.
        let fits_3d = |name: &str, sides: [u32; 3]| -> Result<()> {
            let longest = sides.into_iter().max().unwrap_or(0);
            if longest > max3d {
                return Err(GpuError::OverBudget {
                    name: name.into(),
                    requested: u64::from(longest),
                    budget: u64::from(max3d),
                    why: "maxImageDimension3D",
                });
            }
            Ok(())
        };
        fits_3d("hair-mesh texture", [t.layout.width, t.layout.height, t.layout.curve_slices()])?;
        let (rgba, rg) = if half {
            (vk::Format::R16G16B16A16_SFLOAT, vk::Format::R16G16_SFLOAT)
        } else {
            (vk::Format::R32G32B32A32_SFLOAT, vk::Format::R32G32_SFLOAT)
        };
        let upload = |name: &str, tex: &Texture3, format, data: Vec<u8>| -> Result<(Image, u64)> {
            let extent = vk::Extent3D { width: tex.width, height: tex.height, depth: tex.depth };
            let len = data.len() as u64;
            let desc = if tex.depth > 1 || name != "uv" {
                ImageDesc::d3(extent, format, vk::ImageUsageFlags::SAMPLED)
            } else {
                ImageDesc::d2(tex.width, tex.height, format, vk::ImageUsageFlags::SAMPLED)
            };
            Ok((ctx.create_image_with_data(name, desc, &data)?, len))
        };
        check_u_w(t)?;
        let (hair_mesh, hm_bytes) = upload("hair_mesh", &t.hair_mesh, rgba, texels(&t.hair_mesh, 4, half))?;
        let (uv, uv_bytes) = upload("uv", &t.uv, rg, texels(&t.uv, 2, half))?;
        let mut u_w = Vec::new();
        for z in 0..t.u.depth {
            for y in 0..t.u.height {
                for x in 0..t.u.width {
                    push_texel(&mut u_w, &u_w_texel(&t.u, &t.w, x, y, z), 4, half);
                }
            }
        }
        let (u, u_bytes) = upload("u and w", &t.u, rgba, u_w)?;
        let (v, v_bytes) = upload("v", &t.v, rgba, texels(&t.v, 4, half))?;
        let placeholder = Texture3 { width: 2, height: 2, depth: 2, channels: 1, data: vec![0.0; 8] };
        let field = asset.head_field.as_ref().map_or(&placeholder, |f| &f.distance);
        fits_3d("head field", [field.width, field.height, field.depth])?;
        let field_texels: Vec<u8> =
            field.data.iter().flat_map(|&d| half::f16::from_f64(d).to_bits().to_le_bytes()).collect();
        let (head_field, field_bytes) = upload("head field", field, vk::Format::R16_SFLOAT, field_texels)?;
        let field_bytes = if asset.head_field.is_some() { field_bytes } else { 0 };

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
        let gpu_bundles: Vec<GpuBundle> = (0..asset.bundles.len()).map(|b| gpu_bundle(asset, b)).collect();
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
            u,
            v,
            head_field,
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
                u: u_bytes,
                v: v_bytes,
                head_field: field_bytes,
                buffers: (bundle_bytes.len() + sample_bytes.len() + set_bytes.len()) as u64,
            },
            asset: asset.clone(),
        })
    }

    /// Brings the GPU copy up to date with an edit of its asset ([`HairAsset::move_vertices`]):
    /// uploads only the texel columns and bundle-table entries `change` names, in a submission
    /// of its own. The change must start at the revision this copy holds and end at `asset`'s
    /// (merge several with [`AssetChange::then`]); an asset whose layout, normalization, bundles
    /// or sample sets differ from the uploaded one needs [`Self::upload`] instead. Both are
    /// refused with [`GpuError::Mismatch`], leaving the copy as it was.
    pub fn update(&mut self, ctx: &Context, asset: &HairAsset, change: &AssetChange) -> Result<HairUpdate> {
        let staged = self.stage_update(ctx, asset, change)?;
        ctx.submit("update hair", |rec| {
            self.record_update(rec, &staged);
            Ok(())
        })?;
        Ok(staged.report)
    }

    /// [`Self::update`]'s first half, for a frame graph's upload pass: checks `change`, packs
    /// its texels and bundle entries into a staging buffer and takes `asset` as the copy's
    /// description (its revision is the one caches are keyed by from now on). The GPU copy is
    /// current once [`Self::record_update`]'s commands have run; until then nothing may read it.
    pub fn stage_update(
        &mut self,
        ctx: &Context,
        asset: &HairAsset,
        change: &AssetChange,
    ) -> Result<StagedHairUpdate> {
        let (old, new) = (&self.asset, asset);
        if change.since != old.revision() || change.revision != new.revision() {
            return Err(GpuError::Mismatch(format!(
                "the GPU hair holds revision {} and the asset is at {}, but the change covers {}..{}: \
                 pass every change in order (AssetChange::then merges them) or upload again",
                old.revision(),
                new.revision(),
                change.since,
                change.revision
            )));
        }
        let (ot, nt) = (&old.textures, &new.textures);
        if ot.layout != nt.layout
            || ot.normalization != nt.normalization
            || old.bundles.len() != new.bundles.len()
            || old.square_sets != new.square_sets
            || old.triangle_sets != new.triangle_sets
            || !same_head_field(old, new)
        {
            return Err(GpuError::Mismatch(
                "the asset's layout, normalization, bundles, sample sets or head field changed: upload it again".into(),
            ));
        }
        check_u_w(nt)?;
        let slice = nt.layout.slice_texels();
        if let Some(t) = change.texels.iter().find(|&&t| u64::from(t) >= slice) {
            return Err(GpuError::Mismatch(format!("changed texel {t} is outside the {slice}-texel slice")));
        }
        if let Some(b) = change.bundles.iter().find(|&&b| b as usize >= new.bundles.len()) {
            return Err(GpuError::Mismatch(format!("changed bundle {b} of {}", new.bundles.len())));
        }
        // Runs of neighbouring texels in one row: (x, y, length).
        let width = nt.layout.width;
        let mut runs: Vec<(u32, u32, u32)> = Vec::new();
        let mut sorted = change.texels.clone();
        sorted.sort_unstable();
        sorted.dedup();
        for &t in &sorted {
            let (x, y) = (t % width, t / width);
            match runs.last_mut() {
                Some((rx, ry, n)) if *ry == y && *rx + *n == x => *n += 1,
                _ => runs.push((x, y, 1)),
            }
        }
        let half = self.precision == TexturePrecision::F16;
        let mut report = HairUpdate {
            texel_columns: sorted.len() as u64,
            regions: runs.len() as u64,
            ..Default::default()
        };
        // One staging buffer: each texture's regions, then the bundle entries.
        let mut data = Vec::new();
        let mut image_copies: [Vec<vk::BufferImageCopy>; 3] = Default::default();
        // The hair mesh, û with w in its alpha (as at upload) and v̂; the uv texture holds the
        // rest pose's root uvs, which edits keep.
        let texel = |image: usize, x: u32, y: u32, z: u32| -> [f64; 4] {
            let four = |s: &[f64]| std::array::from_fn(|i| s.get(i).copied().unwrap_or(0.0));
            match image {
                0 => four(nt.hair_mesh.texel(x, y, z)),
                1 => u_w_texel(&nt.u, &nt.w, x, y, z),
                _ => four(nt.v.texel(x, y, z)),
            }
        };
        let depths = [nt.hair_mesh.depth, nt.u.depth, nt.v.depth];
        for (image, copies) in image_copies.iter_mut().enumerate() {
            let depth = depths[image];
            for &(x0, y, n) in &runs {
                // Copy offsets must be multiples of the texel size (and of 4).
                while data.len() % 16 != 0 {
                    data.push(0);
                }
                copies.push(
                    vk::BufferImageCopy::default()
                        .buffer_offset(data.len() as u64)
                        .image_subresource(self.hair_mesh.layers())
                        .image_offset(vk::Offset3D { x: x0 as i32, y: y as i32, z: 0 })
                        .image_extent(vk::Extent3D { width: n, height: 1, depth }),
                );
                for z in 0..depth {
                    for x in x0..x0 + n {
                        push_texel(&mut data, &texel(image, x, y, z), 4, half);
                    }
                }
            }
        }
        report.bytes += data.len() as u64;
        let mut bundle_copies = Vec::new();
        for &b in &change.bundles {
            while data.len() % 16 != 0 {
                data.push(0);
            }
            let entry = gpu_bundle(new, b as usize);
            bundle_copies.push(vk::BufferCopy {
                src_offset: data.len() as u64,
                dst_offset: u64::from(b) * size_of::<GpuBundle>() as u64,
                size: size_of::<GpuBundle>() as u64,
            });
            data.extend_from_slice(bytemuck::bytes_of(&entry));
            report.bundles += 1;
            report.bytes += size_of::<GpuBundle>() as u64;
        }
        let staging = ctx.upload_staging("hair update", &data)?;
        self.asset = asset.clone();
        Ok(StagedHairUpdate { staging, image_copies, bundle_copies, report, revision: asset.revision() })
    }

    /// Records a staged update's copies ([`Self::stage_update`]): each texture goes to
    /// TRANSFER_DST and back to SHADER_READ_ONLY around its copies, the bundle table gets its
    /// entries; everything recorded after sees the new values.
    pub fn record_update(&self, rec: &crate::Recorder<'_>, staged: &StagedHairUpdate) {
        let images = [&self.hair_mesh, &self.u, &self.v];
        for (image, copies) in images.into_iter().zip(&staged.image_copies) {
            rec.update_sampled_image(&staged.staging, image, copies);
        }
        rec.copy_buffer_regions(&staged.staging, &self.bundles, &staged.bundle_copies);
    }

    /// The revision of the asset this copy holds ([`HairAsset::revision`]): what caches built
    /// from it (shadow maps, volumes) are keyed by.
    pub fn revision(&self) -> u64 {
        self.asset.revision()
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
