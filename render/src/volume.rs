//! Hair volumes: each hair's density and mean tangent on a voxel grid, filled straight from the
//! on-the-fly generator, for the volume LOD path (far characters raymarched instead of
//! rasterized strand by strand) and for ambient occlusion (after Jansson et al. 2019, "Real-Time
//! Hybrid Hair Rendering", the vkhr renderer, and Kanzler et al. 2018).
//!
//! Per hair and resolution (cached while its asset does not change; `docs/architecture.md`):
//! 1. **voxelize** (`hair_voxelize.comp`): one invocation per strand generates it (gen-gpu's
//!    strand-coherent evaluation, no culling, every vertex; strand LOD as a camera seeing a voxel
//!    per pixel would apply it at α [`VOXELIZE_STRAND_ALPHA`]: a bundle covering few voxels
//!    keeps fewer strands, widened to keep its projected area — a tenth of the strands of the
//!    example hair at 64³ for 1.001 of the area) and samples each
//!    segment once per voxel of its length (a strand's consecutive samples in one voxel summed
//!    before its atomics); each sample adds its share of the strand's projected
//!    area (length × width, in voxel units) and that area times the segment direction to its
//!    voxel with 64-bit fixed-point atomics. Sampling at the voxel frequency leaves no gaps
//!    (vkhr splats vertices only and mends the gaps with a filter).
//! 2. **resolve** (`volume_resolve.comp`): per voxel the area density `σ` (projected area per
//!    voxel volume, in voxel units: the optical depth a ray gathers per voxel it travels
//!    across strands perpendicular to it, before their opacity) and the mean direction (length
//!    1 where the strands agree, shorter where they cross, 0 in empty voxels).
//! 3. **ambient occlusion** (`volume_ao.comp`, with `"ao"`): per voxel the transmittance of
//!    the hair inside a sphere of radius R (`ao_radius`), averaged over the 26 neighbour
//!    directions: along each, `exp(−τ)` with τ the σ of the voxels at steps 1..R times the strand
//!    opacity `a` and π/4 (the mean `|sin|` between a strand and a random direction). Averaging
//!    transmittances rather than densities keeps a point on the hair's surface half lit.
//!
//! 4. **bricks** (`volume_bricks.comp`): per brick of [`BRICK`]³ voxels, whether a trilinear
//!    sample inside it can see hair.
//!
//! The volume path (`volume_march.comp`) marches a ray through a character's grid one voxel per
//! step with trilinear samples, jumping over empty bricks, accumulating optical depth
//! `σ · a · |sin(T, ray)|` (the mean `|sin|` where the tangents disagree), stops at occluders
//! and writes one fragment per pixel into the compute rasterizer's visibility buffer: at the
//! depth where the light it returns is expected to come from (the transmittance-weighted mean
//! along the ray), with the ray's opacity and the mean tangent there. It is then shaded,
//! composited and depth-tested with the strands, by the same passes.
//!
//! The CPU port ([`cpu`]) follows each kernel; the tests compare the GPU volumes to it.

use gen_gpu::{Buffer, BufferDesc, ComputePipelineDesc, Context, Pipeline, vk};
use glam::{Mat4, Vec3};

/// Smallest volume resolution (voxels along the hair's longest side).
pub const MIN_RESOLUTION: u32 = 16;
/// Largest volume resolution a scene may ask for (lowered when the volumes of its hairs would
/// not fit one storage buffer).
pub const MAX_RESOLUTION: u32 = 256;
/// AO without the volume path voxelizes at this resolution (or the scene's maximum if lower).
pub const AO_RESOLUTION: u32 = 64;
/// Fixed-point units per voxel-area unit in the voxelization sums (`AREA_SCALE` in
/// `hair_voxelize.comp`): a half-voxel sample of a strand a hundredth of a voxel wide still
/// adds about 5,000 units, and 64 bits never overflow.
pub const AREA_SCALE: f64 = 1_048_576.0;
/// Bytes per voxel of the resolved volume (mean tangent, σ) and of the AO volume.
pub const VOLUME_VOXEL_BYTES: u64 = 16;
pub const AO_VOXEL_BYTES: u64 = 4;
/// Bytes per voxel of the voxelization sums (area, then area × direction; 64 bits each).
pub const SUM_VOXEL_BYTES: u64 = 32;
/// Side of the bricks (in voxels) whose occupancy lets the raymarch skip empty space.
pub const BRICK: u32 = 4;
/// Mean of `|sin|` between a fixed direction and a uniformly random one.
pub const MEAN_SIN: f64 = std::f64::consts::FRAC_PI_4;

/// A hair's voxel grid, in its object space: cubic voxels of side `voxel`, `dims` of them per
/// axis from `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeGrid {
    pub origin: Vec3,
    pub voxel: f32,
    pub dims: [u32; 3],
    /// The resolution it was made for (voxels along the longest side, padding included).
    pub resolution: u32,
}

impl VolumeGrid {
    /// The grid of `resolution` voxels along the longest side of the box `lo`–`hi`, with one
    /// voxel of empty padding all round (so trilinear samples fade to zero at the border).
    /// Degenerate boxes (a point, a line, a plane) get a grid all the same: a flat hair is one
    /// voxel thick. `None` when the box is not finite.
    pub fn around(lo: Vec3, hi: Vec3, resolution: u32) -> Option<Self> {
        if !(lo.is_finite() && hi.is_finite()) || lo.cmpgt(hi).any() {
            return None;
        }
        let resolution = resolution.clamp(4, MAX_RESOLUTION);
        let extent = hi - lo;
        let longest = extent.max_element().max(1e-6 * lo.abs().max(hi.abs()).max_element()).max(1e-9);
        let voxel = longest / (resolution - 2) as f32;
        let inner = (extent / voxel).ceil().max(Vec3::ONE);
        let dims = (inner + 2.0).min(Vec3::splat(resolution as f32));
        let origin = 0.5 * (lo + hi) - 0.5 * dims * voxel;
        Some(Self { origin, voxel, dims: [dims.x as u32, dims.y as u32, dims.z as u32], resolution })
    }

    pub fn voxels(&self) -> u64 {
        self.dims.iter().map(|&d| u64::from(d)).product()
    }

    /// Bricks of [`BRICK`]³ voxels per axis.
    pub fn brick_dims(&self) -> [u32; 3] {
        self.dims.map(|d| d.div_ceil(BRICK))
    }

    pub fn bricks(&self) -> u64 {
        self.brick_dims().iter().map(|&d| u64::from(d)).product()
    }

    /// Object space → voxel coordinates (voxel `i` spans `[i, i + 1)`).
    pub fn object_to_voxel(&self) -> Mat4 {
        Mat4::from_scale(Vec3::splat(1.0 / self.voxel)) * Mat4::from_translation(-self.origin)
    }

    /// World space → voxel coordinates for a character placed by `model`.
    pub fn world_to_voxel(&self, model: Mat4) -> Mat4 {
        self.object_to_voxel() * model.inverse()
    }

    /// The voxel index of voxel coordinates `(x, y, z)` (x fastest).
    pub fn index(&self, x: u32, y: u32, z: u32) -> usize {
        ((z as usize * self.dims[1] as usize) + y as usize) * self.dims[0] as usize + x as usize
    }
}

/// Strand LOD α of a voxelization, at a camera that sees the hair a voxel per pixel
/// ([`voxelization_inputs`]).
pub const VOXELIZE_STRAND_ALPHA: f64 = 16.0;

/// The LOD inputs of a hair's voxelization at `resolution`: a camera that sees the hair's
/// longest side about `resolution` pixels tall (a voxel per pixel), strand LOD at
/// [`VOXELIZE_STRAND_ALPHA`] there — a bundle covering few voxels keeps fewer strands, widened
/// to keep its projected area (the LOD's width compensation) — every vertex (no vertex LOD, so
/// no morphing), no culling.
pub fn voxelization_inputs(asset: &hairmesh::asset::HairAsset, resolution: u32) -> gen_gpu::FrameInputs {
    let (lo, hi) = asset.bounds();
    let (lo, hi) = (lo.as_vec3(), hi.as_vec3());
    let centre = 0.5 * (lo + hi);
    let extent = (hi - lo).max_element().max(1e-9);
    // FrameInputs::looking_at's 45° field of view, filled by the box's near face.
    let distance = 0.5 * extent / (22.5f32.to_radians()).tan() + 0.5 * extent;
    let size = resolution.max(1);
    let mut inputs =
        gen_gpu::FrameInputs::looking_at(asset, centre + Vec3::new(0.0, 0.0, distance), size, size);
    inputs.lod = hairmesh::reference::LodParams {
        enabled: true,
        strand_alpha: VOXELIZE_STRAND_ALPHA,
        vertex_alpha: 1e-9,
        ..hairmesh::reference::LodParams::default()
    };
    inputs.cull = false;
    inputs
}

/// The resolution a character `pixels` tall on screen wants: a voxel per pixel or so, as a
/// power of two in `[MIN_RESOLUTION, max]`.
pub fn resolution_for_pixels(pixels: f32, max: u32) -> u32 {
    let want = if pixels.is_finite() { pixels.max(1.0).ceil() as u32 } else { max };
    want.checked_next_power_of_two().unwrap_or(max).clamp(MIN_RESOLUTION, max.max(MIN_RESOLUTION))
}

/// The sphere radius of AO in voxels for a grid (`ao_radius` is a fraction of the longest side),
/// at least one voxel and at most four (the AO pass reads every voxel of the sphere).
pub fn ao_radius_voxels(grid: &VolumeGrid, ao_radius: f32) -> u32 {
    let longest = grid.dims.iter().copied().max().unwrap_or(1).saturating_sub(2).max(1);
    ((ao_radius * longest as f32).round() as u32).clamp(1, 4)
}

/// The pixels (x0, y0, x1, y1; exclusive ends) a character's volume can cover seen through
/// `view_proj` in a `width × height` frame: its projected grid box plus a pixel; empty when the
/// box lies wholly behind the camera, the whole frame when it reaches behind it.
pub fn march_rect(view_proj: Mat4, width: u32, height: u32, model: Mat4, grid: &VolumeGrid) -> [u32; 4] {
    let extent = Vec3::new(grid.dims[0] as f32, grid.dims[1] as f32, grid.dims[2] as f32) * grid.voxel;
    let size = glam::Vec2::new(width as f32, height as f32);
    match crate::camera::project_box(view_proj * model, grid.origin, grid.origin + extent, width, height) {
        crate::camera::BoxOnScreen::Behind => [0, 0, 0, 0],
        crate::camera::BoxOnScreen::InFront { lo, hi } => {
            let lo = (lo - 1.0).floor().clamp(glam::Vec2::ZERO, size);
            let hi = (hi + 1.0).ceil().clamp(glam::Vec2::ZERO, size);
            [lo.x as u32, lo.y as u32, hi.x as u32, hi.y as u32]
        }
        crate::camera::BoxOnScreen::Straddling => [0, 0, width, height],
    }
}

/// `VoxelizeParams` push constants of `hair_voxelize.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct VoxelizePush {
    pub(crate) object_to_voxel: [f32; 16],
    pub(crate) dims: [u32; 4],
}

/// `VolumeParams` push constants of `volume_resolve.comp` and `volume_ao.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct VolumePassPush {
    /// xyz: dims, w: the region's first voxel in the scene's volume buffers.
    pub(crate) dims: [u32; 4],
    /// x: AO sphere radius (voxels), y: strand opacity.
    pub(crate) ao: [f32; 4],
    /// x: the region's first brick.
    pub(crate) bricks: [u32; 4],
}

/// `MarchParams` push constants of `volume_march.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct MarchPush {
    pub(crate) world_to_voxel: [f32; 16],
    /// xyz: dims, w: first voxel.
    pub(crate) dims: [u32; 4],
    /// The pixel rectangle (x0, y0, x1, y1; exclusive ends).
    pub(crate) rect: [u32; 4],
    /// x: material, y: visibility slots K, z: flags (bit 0: occluder depth), w: strand opacity
    /// (as bits).
    pub(crate) info: [u32; 4],
    /// x: the region's first brick, y: the transition band's volume fraction (float bits).
    pub(crate) extra: [u32; 4],
}

/// Projected sizes from `volume_lod_pixels` to this many times it are the transition band: the
/// character is drawn by both its strands and its volume, each on its share of the pixels
/// (a screen-space dither), the volume's share falling linearly from 1 to 0 across the band.
pub const TRANSITION_BAND: f32 = 1.5;

/// The share of a character's pixels its volume draws at projected size `pixels` with the
/// threshold `volume_lod_pixels`: 1 at or below it, 0 from [`TRANSITION_BAND`] times it.
pub fn volume_fraction(pixels: f32, volume_lod_pixels: f32) -> f32 {
    let hi = volume_lod_pixels * TRANSITION_BAND;
    if pixels <= volume_lod_pixels {
        1.0
    } else if pixels >= hi || pixels.is_nan() {
        0.0
    } else {
        (hi - pixels) / (hi - volume_lod_pixels)
    }
}

/// The volume pipelines.
#[derive(Debug)]
pub struct VolumePipelines {
    pub(crate) voxelize: Pipeline,
    pub(crate) voxelize_stored: Pipeline,
    pub(crate) resolve: Pipeline,
    pub(crate) bricks: Pipeline,
    pub(crate) ao: Pipeline,
    pub(crate) march: Pipeline,
}

impl VolumePipelines {
    pub fn new(ctx: &Context) -> gen_gpu::Result<Self> {
        use crate::contract::{
            MARCH_BINDINGS, VOLUME_AO_BINDINGS, VOLUME_BRICK_BINDINGS, VOLUME_RESOLVE_BINDINGS,
            VOXELIZE_BINDINGS,
        };
        use crate::shaders;
        let compute = |name, shader, bindings: &[gen_gpu::Binding], push| {
            Pipeline::compute(ctx, &ComputePipelineDesc::new(name, shader, bindings, push))
        };
        let stage = vk::ShaderStageFlags::COMPUTE;
        let voxelize = compute(
            "voxelize (fused generation)",
            &shaders::HAIR_VOXELIZE_COMP,
            &gen_gpu::strand_bindings(&VOXELIZE_BINDINGS),
            size_of::<VoxelizePush>() as u32,
        )?;
        let voxelize_stored = compute(
            "voxelize (stored strands)",
            &shaders::HAIR_VOXELIZE_STORED_COMP,
            &gen_gpu::strand_bindings(&VOXELIZE_BINDINGS),
            size_of::<VoxelizePush>() as u32,
        )?;
        let pass = size_of::<VolumePassPush>() as u32;
        let resolve = compute(
            "volume resolve",
            &shaders::VOLUME_RESOLVE_COMP,
            &gen_gpu::Binding::storage_buffers(&VOLUME_RESOLVE_BINDINGS, stage),
            pass,
        )?;
        let bricks = compute(
            "volume bricks",
            &shaders::VOLUME_BRICKS_COMP,
            &gen_gpu::Binding::storage_buffers(&VOLUME_BRICK_BINDINGS, stage),
            pass,
        )?;
        let ao = compute(
            "volume AO",
            &shaders::VOLUME_AO_COMP,
            &gen_gpu::Binding::storage_buffers(&VOLUME_AO_BINDINGS, stage),
            pass,
        )?;
        let march = compute(
            "volume raymarch",
            &shaders::VOLUME_MARCH_COMP,
            &gen_gpu::Binding::storage_buffers(&MARCH_BINDINGS, stage),
            size_of::<MarchPush>() as u32,
        )?;
        Ok(Self { voxelize, voxelize_stored, resolve, bricks, ao, march })
    }
}

/// The scene's volume buffers: every hair's region (sized for its largest grid) side by side.
#[derive(Debug)]
pub(crate) struct VolumeStore {
    /// Per voxel: mean direction (xyz) and σ (w).
    pub(crate) volume: Buffer,
    /// Per voxel: ambient occlusion (1 = none).
    pub(crate) ao: Buffer,
    /// Per brick: 1 when it holds hair (or a neighbouring voxel does).
    pub(crate) bricks: Buffer,
    /// Per hair: its region's first voxel and capacity.
    pub(crate) regions: Vec<(u64, u64)>,
    /// Per hair: its region's first brick and capacity.
    pub(crate) brick_regions: Vec<(u64, u64)>,
    /// Largest resolution any volume of the scene gets.
    pub(crate) max_resolution: u32,
}

/// Where the shaders find a volume: its grid's voxels per axis and first voxel (`uvec4 dims` /
/// `volume` in the GLSL), and its first brick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct VolumeAddress {
    pub(crate) dims: [u32; 4],
    pub(crate) first_brick: u32,
}

impl VolumeStore {
    /// Volume source `v`'s region holding `grid`, as the shaders address it.
    pub(crate) fn address(&self, v: usize, grid: &VolumeGrid) -> VolumeAddress {
        let [x, y, z] = grid.dims;
        VolumeAddress {
            dims: [x, y, z, self.regions[v].0 as u32],
            first_brick: self.brick_regions[v].0 as u32,
        }
    }

    /// Buffers for `bounds` (each hair's object box) at resolutions up to `max_resolution`,
    /// lowered by halves until they fit one storage buffer.
    pub(crate) fn new(ctx: &Context, bounds: &[(Vec3, Vec3)], max_resolution: u32) -> gen_gpu::Result<Self> {
        let range = u64::from(ctx.capabilities().max_storage_buffer_range);
        let mut resolution = max_resolution;
        loop {
            let grids: Vec<Option<VolumeGrid>> =
                bounds.iter().map(|&(lo, hi)| VolumeGrid::around(lo, hi, resolution)).collect();
            let capacities: Vec<u64> = grids.iter().map(|g| g.map_or(1, |g| g.voxels())).collect();
            let brick_capacities: Vec<u64> = grids.iter().map(|g| g.map_or(1, |g| g.bricks())).collect();
            let total: u64 = capacities.iter().sum();
            let fits = total * VOLUME_VOXEL_BYTES <= range
                && capacities.iter().all(|&c| c * SUM_VOXEL_BYTES <= range);
            if fits || resolution <= MIN_RESOLUTION {
                let side_by_side = |capacities: &[u64]| -> Vec<(u64, u64)> {
                    let mut first = 0;
                    capacities
                        .iter()
                        .map(|&c| {
                            let r = (first, c);
                            first += c;
                            r
                        })
                        .collect()
                };
                let regions = side_by_side(&capacities);
                let brick_regions = side_by_side(&brick_capacities);
                let total_bricks: u64 = brick_capacities.iter().sum();
                let volume = Buffer::new(
                    ctx,
                    "hair volumes",
                    BufferDesc::storage(total.max(1) * VOLUME_VOXEL_BYTES)
                        .usage(vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST),
                )?;
                let ao = Buffer::new(
                    ctx,
                    "hair volumes: AO",
                    BufferDesc::storage(total.max(1) * AO_VOXEL_BYTES)
                        .usage(vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST),
                )?;
                let bricks = Buffer::new(
                    ctx,
                    "hair volumes: bricks",
                    BufferDesc::storage(total_bricks.max(1) * 4)
                        .usage(vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST),
                )?;
                return Ok(Self { volume, ao, bricks, regions, brick_regions, max_resolution: resolution });
            }
            resolution /= 2;
        }
    }
}

/// A hair's volume as read back from the GPU ([`crate::frame::SceneRenderer::read_volume`]).
#[derive(Clone, Debug)]
pub struct VolumeReadback {
    pub grid: VolumeGrid,
    /// Per voxel (x fastest): mean direction and σ.
    pub volume: Vec<[f32; 4]>,
    /// Per voxel: AO (all ones without `"ao"`).
    pub ao: Vec<f32>,
    /// Per brick (x fastest): 1 where the raymarch samples, 0 where it skips.
    pub bricks: Vec<u32>,
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec3};

    use super::*;
    use crate::cpu::volume as cpu;

    #[test]
    fn grids_pad_and_fit_the_resolution() {
        let g = VolumeGrid::around(Vec3::ZERO, Vec3::new(2.0, 1.0, 0.0), 64).expect("a finite box");
        assert_eq!(g.dims[0], 64);
        assert!(g.dims[1] >= 33 && g.dims[1] <= 34, "{:?}", g.dims);
        assert_eq!(g.dims[2], 3, "a flat box is one voxel thick plus padding");
        assert!(VolumeGrid::around(Vec3::ZERO, Vec3::splat(f32::NAN), 64).is_none());
        let point = VolumeGrid::around(Vec3::ONE, Vec3::ONE, 16).expect("a finite box");
        assert!(point.voxel > 0.0 && point.dims == [3, 3, 3]);
    }

    #[test]
    fn resolutions_are_bounded_powers_of_two() {
        assert_eq!(resolution_for_pixels(0.0, 128), MIN_RESOLUTION);
        assert_eq!(resolution_for_pixels(40.0, 128), 64);
        assert_eq!(resolution_for_pixels(1e9, 128), 128);
        assert_eq!(resolution_for_pixels(f32::NAN, 128), 128);
    }

    #[test]
    fn voxelization_conserves_projected_area() {
        let g = VolumeGrid::around(Vec3::ZERO, Vec3::ONE, 32).expect("a finite box");
        let points: Vec<DVec3> =
            (0..=20).map(|k| DVec3::new(0.05 * k as f64, 0.5, 0.3 + 0.01 * k as f64)).collect();
        let widths = vec![0.002; points.len()];
        let sums = cpu::voxelize(&g, [(points.as_slice(), widths.as_slice())]);
        let length: f64 = points.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        let expected = length * 0.002 / f64::from(g.voxel).powi(2);
        let total: f64 = sums.area.iter().sum();
        assert!((total - expected).abs() < 1e-9 * expected, "{total} vs {expected}");
        for v in cpu::resolve(&sums) {
            let l = DVec3::new(v[0], v[1], v[2]).length();
            assert!(l < 1e-12 || (l - 1.0).abs() < 1e-9, "one straight strand: unit directions, got {l}");
        }
    }

    #[test]
    fn ao_is_one_in_empty_space_and_darker_inside_hair() {
        let g = VolumeGrid::around(Vec3::ZERO, Vec3::ONE, 16).expect("a finite box");
        let mut sigma = vec![0.0; g.voxels() as usize];
        let centre = g.index(8, 8, 8);
        let ao = cpu::ambient_occlusion(&g, &sigma, 2, 1.0);
        assert!(ao.iter().all(|&a| a == 1.0));
        sigma[centre] = 5.0;
        let ao = cpu::ambient_occlusion(&g, &sigma, 2, 1.0);
        // A voxel does not occlude itself; its neighbours within the radius see it.
        assert!(ao[centre] == 1.0 && ao[g.index(8, 8, 9)] < 1.0 && ao[g.index(8, 9, 9)] < 1.0);
        assert!(ao[g.index(1, 1, 1)] == 1.0);
        // One of 26 directions blocked: at least 25/26 of the light.
        assert!(ao[g.index(8, 8, 9)] > 25.0 / 26.0 - 1e-12);
    }
}
