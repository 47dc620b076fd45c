//! Hair volumes in a frame: which hairs are voxelized or reused, which characters are raymarched
//! (the volume LOD path), their shading inputs, and reading a volume back.

use super::*;

/// The hair volumes of a scene with `"ao"`, `"volume_shadows"` or `"volume_lod"` ([`crate::volume`]).
pub(crate) struct SceneVolumes {
    pub(crate) pipelines: VolumePipelines,
    pub(crate) store: VolumeStore,
    /// Per hair: the grid its region holds and the hair revision it was voxelized from.
    pub(super) cache: Mutex<Vec<Option<(VolumeGrid, u64)>>>,
    /// Strand opacity of the scene's hair (the AO's and the raymarch's).
    pub(crate) opacity: f32,
}

/// A hair's volume in a frame: its grid, and whether its region already holds it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct HairVolumePlan {
    pub(crate) grid: VolumeGrid,
    pub(crate) cached: bool,
}

/// The graph's names of the volume resources, and each hair's volume this frame.
#[derive(Clone, Debug)]
pub(crate) struct VolumeIds {
    pub(crate) volume: Res,
    pub(crate) ao: Res,
    pub(crate) bricks: Res,
    pub(crate) lod: Vec<Res>,
    pub(crate) sums: Vec<Res>,
    pub(crate) hairs: Vec<Option<HairVolumePlan>>,
    /// Characters raymarched this frame ([`SceneRenderer::volume_character`]'s numbers).
    pub(crate) marched: Vec<usize>,
    /// Per character (the same numbers): the share of its pixels its volume draws (1: all, in
    /// no strand batch; between 0 and 1: the transition band, drawn by both).
    pub(crate) fractions: Vec<f32>,
}

/// A voxelization recorded this frame.
pub(crate) struct HairVolumeFrame {
    pub(crate) grid: VolumeGrid,
    pub(crate) address: crate::volume::VolumeAddress,
    pub(crate) source: VoxelSource,
    pub(crate) sums: Buffer,
}

/// Where a voxelization's strands come from.
pub(crate) enum VoxelSource {
    /// A generated hair: its LOD pass's buffers (`volume::voxelization_inputs`).
    Generated(Box<FrameBuffers>),
    /// Stored strands `s`: their parameters.
    Stored(usize, Buffer),
}

/// A character raymarched this frame.
pub(crate) struct MarchJob {
    pub(crate) character: usize,
    pub(crate) push: crate::volume::MarchPush,
}

/// The volume work of one frame.
#[derive(Default)]
pub(crate) struct VolumeFrame {
    pub(crate) hairs: Vec<Option<HairVolumeFrame>>,
    pub(crate) marches: Vec<MarchJob>,
}

impl SceneRenderer {
    /// Hair volumes a scene can have: one per uploaded hair, then one per stored-strand set
    /// (the index [`Self::read_volume`] takes).
    pub fn volume_sources(&self) -> usize {
        self.hairs.len() + self.stored.len()
    }

    /// The object-space bounds of volume source `v`.
    pub(crate) fn volume_bounds(&self, v: usize) -> (Vec3, Vec3) {
        match v.checked_sub(self.hairs.len()) {
            None => {
                let (lo, hi) = self.hairs[v].asset.bounds();
                (lo.as_vec3(), hi.as_vec3())
            }
            Some(s) => self.stored[s].bounds,
        }
    }

    /// What volume source `v`'s volume is made from (stored strands never change).
    pub(super) fn volume_revision(&self, v: usize) -> u64 {
        self.hairs.get(v).map_or(0, GpuHair::revision)
    }

    /// Characters the volume planning numbers: the generated ones, then the stored ones (the
    /// order of the compute rasterizer's materials).
    pub(crate) fn volume_character_count(&self) -> usize {
        self.characters.len() + self.stored_characters.len()
    }

    /// Character `i` in that order, with its volume source ([`Self::volume_sources`]: stored
    /// sets follow the uploaded hairs).
    pub(crate) fn volume_character(&self, i: usize) -> Option<(&SceneCharacter, usize)> {
        match i.checked_sub(self.characters.len()) {
            None => self.characters.get(i).map(|c| (c, c.hair)),
            Some(j) => self.stored_characters.get(j).map(|c| (c, self.hairs.len() + c.hair)),
        }
    }

    /// Every character in that order ([`Self::volume_character`]).
    pub(crate) fn volume_characters(&self) -> impl Iterator<Item = (&SceneCharacter, usize)> {
        (0..self.volume_character_count()).filter_map(|i| self.volume_character(i))
    }

    /// The projected size in pixels in `view` of a character placed at `transform` with volume
    /// source `v`'s hair: the larger side of the screen rectangle of its bounds' corners
    /// (unclipped; infinite when a corner lies behind the near plane, the eye inside the bounds
    /// included).
    pub(crate) fn projected_pixels(&self, transform: Mat4, v: usize, view: &FrameView) -> f32 {
        let (lo, hi) = self.volume_bounds(v);
        let m = crate::camera::view_proj(&view.camera, view.width, view.height) * transform;
        match crate::camera::project_box(m, lo, hi, view.width, view.height) {
            crate::camera::BoxOnScreen::InFront { lo, hi } => (hi - lo).max_element(),
            // Unbounded (or invisible behind the camera): never small enough for a volume.
            crate::camera::BoxOnScreen::Straddling | crate::camera::BoxOnScreen::Behind => f32::INFINITY,
        }
    }

    /// Which characters the frame raymarches (`"volume_lod"`: at most `volume_lod_pixels` on
    /// screen; generated and stored alike, numbered as [`Self::volume_character`]) and each
    /// volume source's volume: the resolution its raymarched characters' sizes
    /// ask for, at least [`crate::volume::AO_RESOLUTION`] with AO or volume shadows; cached when
    /// its region holds a grid at least that fine of the source's current revision.
    pub(super) fn plan_volumes(
        &self,
        g: &mut FrameGraph<ScenePass>,
        view: &FrameView,
    ) -> (Option<VolumeIds>, Vec<usize>) {
        let Some(volumes) = &self.volumes else { return (None, Vec::new()) };
        let effects = self.effects;
        let max = volumes.store.max_resolution;
        let placed: Vec<(Mat4, usize)> = self.volume_characters().map(|(c, v)| (c.transform, v)).collect();
        let pixels: Vec<f32> = placed.iter().map(|&(t, v)| self.projected_pixels(t, v, view)).collect();
        // A volume is drawn only where its voxels are at most about two pixels: never beyond
        // twice the resolution the scene's volumes get (lowered when many hairs share the
        // buffers).
        let threshold = effects.volume_lod_pixels.min(2.0 * max as f32);
        let mut fractions: Vec<f32> = pixels
            .iter()
            .map(|&p| match (effects.volume_lod, self.volumes_everywhere) {
                (false, _) => 0.0,
                (true, true) => 1.0,
                (true, false) => crate::volume::volume_fraction(p, threshold),
            })
            .collect();
        let marched: Vec<usize> = (0..placed.len()).filter(|&i| fractions[i] > 0.0).collect();
        let cache = volumes.cache.lock().unwrap_or_else(|e| e.into_inner());
        let cache_plan = |v: usize, want: Option<u32>| -> Option<HairVolumePlan> {
            let want = want?;
            let revision = self.volume_revision(v);
            // A cached grid at least this fine serves (a character moving away does not
            // re-voxelize its hair; one coming closer does, once per octave).
            if let Some((grid, r)) = cache[v]
                && r == revision
                && grid.resolution >= want
            {
                return Some(HairVolumePlan { grid, cached: true });
            }
            let (lo, hi) = self.volume_bounds(v);
            let grid = VolumeGrid::around(lo, hi, want)?;
            // A grid beyond its region (never, for a resolution within the store's) is skipped.
            if grid.voxels() > volumes.store.regions[v].1 {
                return None;
            }
            Some(HairVolumePlan { grid, cached: false })
        };
        let hairs = (0..self.volume_sources())
            .map(|v| {
                let mut want: Option<u32> = None;
                for (i, _) in placed.iter().enumerate().filter(|(_, p)| p.1 == v) {
                    if marched.contains(&i) {
                        let r = crate::volume::resolution_for_pixels(pixels[i], max);
                        want = Some(want.map_or(r, |w| w.max(r)));
                    }
                    if effects.ao || effects.volume_shadows {
                        let r = crate::volume::AO_RESOLUTION.min(max);
                        want = Some(want.map_or(r, |w| w.max(r)));
                    }
                }
                cache_plan(v, want)
            })
            .collect::<Vec<_>>();
        // Characters whose hair got no volume (an unfinite box) keep their strands.
        let marched: Vec<usize> = marched.into_iter().filter(|&i| hairs[placed[i].1].is_some()).collect();
        for (i, f) in fractions.iter_mut().enumerate() {
            if !marched.contains(&i) {
                *f = 0.0;
            }
        }
        let ids = VolumeIds {
            marched: marched.clone(),
            fractions,
            volume: g.external_buffer("hair volumes"),
            ao: g.external_buffer("hair volumes: AO"),
            bricks: g.external_buffer("hair volumes: bricks"),
            lod: (0..self.hairs.len()).map(|h| g.buffer(format!("voxelize lod {h}"))).collect(),
            sums: (0..self.volume_sources()).map(|v| g.buffer(format!("voxel sums {v}"))).collect(),
            hairs,
        };
        (Some(ids), marched)
    }

    /// The triangle raster's part of AO and volume shadows: volume source `v`'s volume this
    /// frame into a character's shading constants.
    pub(crate) fn volume_shading(&self, plan: &FramePlan, v: usize, s: &mut Shading) {
        let flags = self.effects.volume_flags();
        let (Some(volumes), Some(ids)) = (&self.volumes, &plan.ids.volumes) else { return };
        if let (Some(Some(p)), true) = (ids.hairs.get(v), flags != 0) {
            let address = volumes.store.address(v, &p.grid);
            s.volume_box = p.grid.origin.extend(1.0 / p.grid.voxel).to_array();
            s.volume_grid = address.dims;
            s.volume_info = [address.first_brick, flags, 0, 0];
        }
    }

    /// The frame's voxelizations (LOD and generation inputs: `volume::voxelization_inputs`, no
    /// culling; a sums buffer each) and raymarches.
    pub(super) fn volume_frame(
        &self,
        ctx: &Context,
        pool: &mut TransientPool,
        plan: &FramePlan,
        raster: Option<&RasterBuffers>,
    ) -> Result<Option<VolumeFrame>, RenderError> {
        let (Some(volumes), Some(ids)) = (&self.volumes, &plan.ids.volumes) else {
            return Ok(None);
        };
        let view = &plan.view;
        let mut frame = VolumeFrame::default();
        for (h, p) in ids.hairs.iter().enumerate() {
            let voxelize = match p {
                Some(p) if !p.cached => {
                    let source = match h.checked_sub(self.hairs.len()) {
                        None => {
                            let hair = &self.hairs[h];
                            let inputs = crate::volume::voxelization_inputs(&hair.asset, p.grid.resolution);
                            VoxelSource::Generated(Box::new(
                                self.generator.prepare_fused(ctx, hair, &inputs)?,
                            ))
                        }
                        Some(s) => {
                            // Stored strands have no LOD: the parameters only place the camera.
                            let character = Character { hair: s, transform: Mat4::IDENTITY };
                            let inputs =
                                character_inputs(&view.camera, &character, view.width, view.height, view.lod);
                            VoxelSource::Stored(s, self.stored[s].frame_params(ctx, &inputs)?)
                        }
                    };
                    let sums = pool.buffer(
                        ctx,
                        "voxel sums",
                        BufferDesc::storage(p.grid.voxels() * crate::volume::SUM_VOXEL_BYTES)
                            .usage(vk::BufferUsageFlags::TRANSFER_DST),
                    )?;
                    Some(HairVolumeFrame {
                        grid: p.grid,
                        address: volumes.store.address(h, &p.grid),
                        source,
                        sums,
                    })
                }
                _ => None,
            };
            frame.hairs.push(voxelize);
        }
        // The raymarches write into the compute rasterizer's visibility buffer.
        let Some(raster) = raster else { return Ok(Some(frame)) };
        let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
        for &i in &plan.volume_characters {
            let Some((c, v)) = self.volume_character(i) else { continue };
            let Some(Some(p)) = ids.hairs.get(v) else { continue };
            let address = volumes.store.address(v, &p.grid);
            let material = self.character_materials.get(i).copied().unwrap_or(0);
            let flags = u32::from(!self.occluders.is_empty());
            frame.marches.push(MarchJob {
                character: i,
                push: crate::volume::MarchPush {
                    world_to_voxel: p.grid.world_to_voxel(c.transform).to_cols_array(),
                    dims: address.dims,
                    rect: crate::volume::march_rect(view_proj, view.width, view.height, c.transform, &p.grid),
                    info: [material, raster.k, flags, volumes.opacity.to_bits()],
                    extra: [address.first_brick, plan.volume_fraction(i).to_bits(), 0, 0],
                },
            });
        }
        Ok(Some(frame))
    }

    /// Reads hair `hair`'s volume back (`None` before a frame voxelized it): for tests and
    /// inspection.
    pub fn read_volume(
        &self,
        ctx: &Context,
        hair: usize,
    ) -> Result<Option<crate::volume::VolumeReadback>, RenderError> {
        let Some(volumes) = &self.volumes else { return Ok(None) };
        let cached = volumes.cache.lock().unwrap_or_else(|e| e.into_inner()).get(hair).copied().flatten();
        let Some((grid, _)) = cached else { return Ok(None) };
        let (first, _) = volumes.store.regions[hair];
        let end = first + grid.voxels();
        let all: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(
            &ctx.read_buffer(&volumes.store.volume, end * crate::volume::VOLUME_VOXEL_BYTES)?,
        );
        let ao: Vec<f32> = bytemuck::pod_collect_to_vec(
            &ctx.read_buffer(&volumes.store.ao, end * crate::volume::AO_VOXEL_BYTES)?,
        );
        let (first_brick, _) = volumes.store.brick_regions[hair];
        let brick_end = first_brick + grid.bricks();
        let bricks: Vec<u32> =
            bytemuck::pod_collect_to_vec(&ctx.read_buffer(&volumes.store.bricks, brick_end * 4)?);
        Ok(Some(crate::volume::VolumeReadback {
            grid,
            volume: all[first as usize..end as usize].to_vec(),
            ao: ao[first as usize..end as usize].to_vec(),
            bricks: bricks[first_brick as usize..brick_end as usize].to_vec(),
        }))
    }
}
