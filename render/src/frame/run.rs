//! Running a planned frame: transient resources from the pool, the shadow submission, the batch
//! submissions, readback and the caches kept for the next frame.

use super::*;

impl SceneRenderer {
    /// Renders one frame.
    pub fn render(&self, ctx: &Context) -> Result<RenderedFrame, RenderError> {
        self.render_from(ctx, Vec3::from_array(self.scene.scene.camera.eye))
    }

    /// Renders one frame with the camera at `eye` (looking at the scene's target). Shadow maps
    /// do not depend on the camera and stay cached.
    pub fn render_from(&self, ctx: &Context, eye: Vec3) -> Result<RenderedFrame, RenderError> {
        self.render_camera(ctx, eye, Vec3::from_array(self.scene.scene.camera.target))
    }

    /// Renders one frame from a camera at `eye` looking at `target` (e.g. a point of the
    /// scene's camera path, [`LoadedScene::camera_at`]): plans its graph and runs it.
    pub fn render_camera(
        &self,
        ctx: &Context,
        eye: Vec3,
        target: Vec3,
    ) -> Result<RenderedFrame, RenderError> {
        self.render_view(ctx, self.view_from(eye, target))
    }

    /// Renders one frame seen through `view` ([`Self::frame_view`]): plans its graph and runs it.
    /// A view larger than the scene's output is refused (the renderer's per-pixel buffers and
    /// rasterizer choice were sized for the output).
    pub fn render_view(&self, ctx: &Context, view: FrameView) -> Result<RenderedFrame, RenderError> {
        let output = self.scene.scene.output;
        if view.width == 0 || view.height == 0 || view.width > output.width || view.height > output.height {
            return Err(RenderError::InvalidView {
                why: format!(
                    "{}×{} is empty or larger than the scene's {}×{} output",
                    view.width, view.height, output.width, output.height
                ),
            });
        }
        let plan = self.plan(view);
        plan.graph.check()?;
        let mut pool = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        let mut run = GraphRun::new(&plan.graph);
        let mut timings = FrameTimings::default();
        // Shadow maps: rendered by their own submission on the first frame, then reused.
        let mut shadow_cache = self.shadow_cache.lock().unwrap_or_else(|e| e.into_inner());
        let mut shadow_ms = None;
        if let (Some(ids), false) = (&plan.ids.shadow, plan.shadow_cached) {
            let shadow = crate::passes::shadow::prepare(self, ctx, &plan)?;
            let images = shadow.images(ids);
            let ((), t) = ctx.submit("shadow maps", |rec| {
                run.record_submission(rec, 0, &|r| images.get(&r).copied(), |rec, pass, run| {
                    match pass.payload {
                        ScenePass::UpdateHair(k) => crate::passes::upload::record(self, rec, k),
                        _ => crate::passes::shadow::record(self, rec, pass, &shadow, run),
                    }
                })
            })?;
            shadow_ms = t.pass_ms("shadow maps");
            timings.passes.extend(t.passes);
            timings.cpu_wait_ms += t.cpu_wait_ms;
            *shadow_cache = Some((self.content_version(), plan.view.lod, shadow.into_atlas()));
        }
        let atlas = shadow_cache.as_ref().map(|(_, _, atlas)| atlas);
        let view = plan.view;
        let light_data = self.light_data(atlas);
        let light_bytes: &[u8] = bytemuck::cast_slice(&light_data);
        let mut lights = pool.buffer(
            ctx,
            "scene lights",
            BufferDesc::storage(light_bytes.len().max(16) as u64).location(MemoryLocation::CpuToGpu),
        )?;
        match lights.mapped_mut() {
            Some(m) => m[..light_bytes.len()].copy_from_slice(light_bytes),
            None => {
                lights = ctx.create_buffer_with_data(
                    "scene lights",
                    BufferDesc::storage(light_bytes.len() as u64),
                    light_bytes,
                )?;
            }
        }
        let lighting: [(u32, &Buffer); 4] = match atlas {
            Some(a) => [
                (binding::SHADOW_DEPTH, &a.depth),
                (binding::SHADOW_OPACITY, &a.opacity),
                (binding::LIGHTS, &lights),
                (binding::OCCLUDER_DEPTH, &a.occluder_depth),
            ],
            None => [
                (binding::SHADOW_DEPTH, &self.no_shadow[0]),
                (binding::SHADOW_OPACITY, &self.no_shadow[1]),
                (binding::LIGHTS, &lights),
                (binding::OCCLUDER_DEPTH, &self.no_shadow[2]),
            ],
        };
        let stored_params = self
            .stored_characters
            .iter()
            .map(|c| {
                let character = Character { hair: c.hair, transform: c.transform };
                let inputs = character_inputs(&view.camera, &character, view.width, view.height, view.lod);
                // Every hair generator shares the parameter layout.
                self.stored[c.hair].frame_params(ctx, &inputs)
            })
            .collect::<gen_gpu::Result<Vec<_>>>()?;
        let samples = if self.oit.is_some() || self.compute_raster.is_some() { 1 } else { self.effects.msaa };
        let scene_target = SceneTarget::new(ctx, &mut pool, view.width, view.height, samples)?;
        // The OIT node pool is bounded by the output size (`oit_nodes_per_pixel`) and by the
        // storage-buffer range, or where the device has buffer device addresses (the kernels
        // then reach the pool through one) by OIT_POOL_BYTES.
        // (The compute rasterizer keeps its own K nearest fragments per pixel.)
        let oit_buffers = match (&self.oit, &self.compute_raster) {
            (Some(oit), None) => {
                let pixels = u64::from(view.width) * u64::from(view.height);
                let referenced = self.buffer_references && ctx.capabilities().buffer_device_address;
                let pool_bytes = if referenced {
                    OIT_POOL_BYTES
                } else {
                    u64::from(ctx.capabilities().max_storage_buffer_range)
                };
                let pool_nodes = ((pixels as f64 * f64::from(oit.nodes_per_pixel)) as u64)
                    .clamp(1, (pool_bytes / OIT_NODE_BYTES).min(u64::from(u32::MAX - 1)));
                // The overflow tail when its words fit one storage buffer (not at 4K on lavapipe's
                // 128 MiB: there a full pool drops fragments, counted).
                let fits =
                    pixels * 4 * OIT_PIXEL_WORDS <= u64::from(ctx.capabilities().max_storage_buffer_range);
                let pixel_words = if fits { OIT_PIXEL_WORDS } else { 1 };
                let nodes =
                    pool.buffer(ctx, "OIT nodes", BufferDesc::storage(pool_nodes * OIT_NODE_BYTES))?;
                Some(OitBuffers {
                    heads: pool.buffer(ctx, "OIT heads", BufferDesc::storage(pixels * 4 * pixel_words))?,
                    nodes_address: self.load_address(&nodes),
                    nodes,
                    counters: pool.buffer(ctx, "OIT counters", BufferDesc::storage(32))?,
                    pool: pool_nodes,
                    pixel_words: pixel_words as u32,
                })
            }
            _ => None,
        };
        let raster_buffers = match &self.compute_raster {
            Some(cr) => {
                let boxes = self
                    .characters
                    .iter()
                    .map(|c| {
                        let (lo, hi) = self.hairs[c.hair].asset.bounds();
                        (c.transform, (lo.as_vec3(), hi.as_vec3()))
                    })
                    .chain(self.stored_characters.iter().map(|c| (c.transform, self.stored[c.hair].bounds)));
                let view_proj = crate::camera::view_proj(&view.camera, view.width, view.height);
                let rect = crate::raster::screen_rect(view_proj, view.width, view.height, boxes);
                let materials = self.frame_materials(&plan);
                let desc = crate::raster::RasterFrameDesc {
                    view: &view,
                    materials: &materials,
                    light_count: self.scene.lights().len(),
                    occluders: !self.occluders.is_empty(),
                    rect,
                    // What the kernels were specialized for (ComputeRaster::new): one storage
                    // buffer holds that many at the output size, so at any view's.
                    k: cr.slots().unwrap_or_else(|| self.frame_slots(ctx)),
                };
                let buffers = RasterBuffers::new(ctx, &mut pool, &desc)?;
                if let Some(expected) = cr.slots().filter(|&k| k != buffers.k) {
                    let k = buffers.k;
                    buffers.give_back(&mut pool);
                    return Err(RenderError::InvalidView {
                        why: format!(
                            "its pixel buffers hold {k} slots, not the {expected} the kernels expect"
                        ),
                    });
                }
                Some(buffers)
            }
            None => None,
        };
        let volume_frame = self.volume_frame(ctx, &mut pool, &plan, raster_buffers.as_ref())?;
        let stand_in = &self.no_shadow[0];
        let volume_buffers = match &self.volumes {
            Some(v) => [
                (binding::VOLUME, &v.store.volume),
                (binding::VOLUME_AO, &v.store.ao),
                (binding::VOLUME_BRICKS, &v.store.bricks),
            ],
            None => [
                (binding::VOLUME, stand_in),
                (binding::VOLUME_AO, stand_in),
                (binding::VOLUME_BRICKS, stand_in),
            ],
        };
        let mut images: HashMap<Res, &Image> = HashMap::new();
        images.insert(plan.ids.color, &scene_target.color);
        images.insert(plan.ids.depth, &scene_target.depth);
        if let (Some((c, d)), Some((ci, di))) = (plan.ids.resolve, &scene_target.resolve) {
            images.insert(c, ci);
            images.insert(d, di);
        }
        let mut stats = GenerationStats::default();
        // Stored characters drawn by their volume alone rasterize no strand.
        let n = self.characters.len();
        stats.strands += (self.stored_characters.iter().enumerate())
            .filter(|&(j, _)| plan.volume_fraction(n + j) < 1.0)
            .map(|(_, c)| self.stored[c.hair].strands)
            .sum::<u64>();
        // The compute rasterizer's history: the last frame's depths, each character's marks.
        let mut slot_history = self.slot_history.lock().unwrap_or_else(|e| e.into_inner());
        let ordered = self.raster_slot_order();
        if ordered {
            let capacities: Vec<u64> =
                self.characters.iter().map(|c| self.hairs[c.hair].total_strands().max(1)).collect();
            slot_history.prepare(ctx, view.width, view.height, &capacities)?;
        }
        let marking = ordered && slot_history.marking();
        let mut drawn = vec![false; self.characters.len()];
        let batch_count = plan.batches.len();
        for (k, batch) in plan.batches.iter().enumerate() {
            let frames = batch
                .iter()
                .map(|&i| {
                    let hair = &self.hairs[self.characters[i].hair];
                    let frame = if self.compute_raster.is_some() {
                        self.generator.prepare_fused(ctx, hair, &plan.inputs[i])?
                    } else {
                        self.generator.prepare(ctx, hair, &plan.inputs[i])?
                    };
                    Ok((i, frame))
                })
                .collect::<gen_gpu::Result<Vec<_>>>()?;
            let last = k + 1 == batch_count;
            for (i, _) in &frames {
                drawn[*i] = true;
            }
            let state = FrameState {
                plan: &plan,
                target: &scene_target,
                lighting,
                oit: oit_buffers.as_ref(),
                raster: raster_buffers.as_ref(),
                materials: &self.character_materials,
                frames: &frames,
                slot_history: self.compute_raster.as_ref().map(|_| &*slot_history),
                stored_params: if last { &stored_params } else { &[] },
                volumes: if k == 0 { volume_frame.as_ref() } else { None },
                volume_buffers,
            };
            let submission = plan.first_batch_submission + k;
            let ((), t) = ctx.submit("scene frame", |rec| {
                run.record_submission(rec, submission, &|r| images.get(&r).copied(), |rec, pass, run| {
                    crate::passes::record(self, rec, pass, &state, run)
                })
            })?;
            timings.passes.extend(t.passes);
            timings.cpu_wait_ms += t.cpu_wait_ms;
            for (i, frame) in &frames {
                stats += self.generator.stats(ctx, &self.hairs[self.characters[*i].hair], frame)?;
            }
        }
        // What the next frame orders by: this frame's depths (the shade pass wrote them), and
        // the marks of the characters this frame drew with marking on.
        if ordered && raster_buffers.is_some() {
            if let Some((_, _, _, written)) = &mut slot_history.final_depth {
                *written = true;
            }
            for (character, &drawn) in slot_history.characters.iter_mut().zip(&drawn) {
                if let Some(c) = character {
                    c.history = drawn && marking;
                }
            }
        }
        drop(slot_history);
        // Every submission has completed: the staged updates are in the textures.
        self.staged.lock().unwrap_or_else(|e| e.into_inner()).clear();
        let (oit_overflow, oit_pool) = match &oit_buffers {
            Some(b) => {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&b.counters, 16)?);
                (Some(u64::from(c[2])), Some(b.pool))
            }
            None => (None, None),
        };
        let (raster_overflow, raster_slots) = match &raster_buffers {
            Some(b) => {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&b.counters, 16)?);
                (Some(u64::from(c[0])), Some(b.k))
            }
            None => (None, None),
        };
        // Without occluders the compute rasterizer's resolve writes only the hair's rectangle
        // (passes/compute_raster.rs record_resolve).
        let only = match &raster_buffers {
            Some(b) if !crate::passes::compute_raster::resolves_over_occluders(self) => {
                Some((b.rect, self.scene.scene.output.background))
            }
            _ => None,
        };
        let linear = scene_target.read(ctx, only)?;
        let passes = run.ran;
        // Every submission has waited for its fence: the transient resources can be reused.
        scene_target.give_back(&mut pool);
        if let Some(b) = oit_buffers {
            pool.give_back_buffer(b.heads);
            pool.give_back_buffer(b.nodes);
            pool.give_back_buffer(b.counters);
        }
        if lights.mapped().is_some() {
            pool.give_back_buffer(lights);
        }
        if let Some(b) = raster_buffers {
            b.give_back(&mut pool);
        }
        let mut volumes_voxelized = 0;
        if let (Some(volumes), Some(vf)) = (&self.volumes, volume_frame) {
            let mut cache = volumes.cache.lock().unwrap_or_else(|e| e.into_inner());
            for (h, hv) in vf.hairs.into_iter().enumerate() {
                if let Some(hv) = hv {
                    cache[h] = Some((hv.grid, self.volume_revision(h)));
                    pool.give_back_buffer(hv.sums);
                    volumes_voxelized += 1;
                }
            }
        }
        Ok(RenderedFrame {
            image: linear.to_srgb8(),
            linear,
            timings,
            stats,
            passes,
            graph: plan.graph.outline(),
            oit_overflow,
            oit_pool,
            raster_overflow,
            raster_slots,
            volume_characters: plan.volume_characters.len(),
            volume_fractions: (0..self.volume_character_count()).map(|i| plan.volume_fraction(i)).collect(),
            volumes_voxelized,
            shadow_cached: plan.shadow_cached,
            shadow_ms,
        })
    }

    /// Resources the pool has created so far (a steady scene stops creating after its first
    /// frame).
    pub fn transient_resources_created(&self) -> usize {
        self.pool.lock().unwrap_or_else(|e| e.into_inner()).created
    }
}
