//! Planning a frame for a view: its graph from the scene's effects, the resources' names, the
//! batches of characters (one submission each) and whether the shadow maps are reused.

use super::*;

impl SceneRenderer {
    pub(super) fn view(&self) -> FrameView {
        let c = &self.scene.scene.camera;
        self.view_from(Vec3::from_array(c.eye), Vec3::from_array(c.target))
    }

    /// The scene's view (its output size, field of view and LOD settings) with the camera at
    /// `eye` looking at `target`: what [`Self::render_camera`] draws. Change its size (at most
    /// the scene's output) or LOD and pass it to [`Self::render_view`], e.g. for an editor's
    /// quick previews.
    pub fn frame_view(&self, eye: Vec3, target: Vec3) -> FrameView {
        self.view_from(eye, target)
    }

    pub(crate) fn view_from(&self, eye: Vec3, target: Vec3) -> FrameView {
        let s = &self.scene.scene;
        FrameView {
            camera: Camera { eye, target, fov_y: s.camera.fov_y_degrees.to_radians() },
            width: s.output.width,
            height: s.output.height,
            path: self.path,
            lod: s.lod.params(),
        }
    }

    /// The graph the next frame from the scene's camera runs (passes whose results are cached
    /// are marked so).
    pub fn graph(&self) -> FrameGraph<()> {
        self.plan(self.view()).graph.outline()
    }

    /// Whether a frame planned with `lod` reuses the cached shadow maps.
    pub(super) fn shadows_cached(&self, lod: &LodParams) -> bool {
        let cache = self.shadow_cache.lock().unwrap_or_else(|e| e.into_inner());
        let stale_ok = self.stale_shadows_ok.load(std::sync::atomic::Ordering::Relaxed);
        cache.as_ref().is_some_and(|(version, made_with, _)| {
            stale_ok || (*version == self.content_version() && made_with == lod)
        })
    }

    /// Plans a frame seen through `view`: the passes the scene's effects ask for, in order,
    /// with what each reads and writes.
    pub fn plan(&self, view: FrameView) -> FramePlan {
        let mut g: FrameGraph<ScenePass> = FrameGraph::default();
        let effects = self.effects;
        let msaa = self.oit.is_none() && effects.msaa > 1;
        let (color, depth) = if msaa {
            (g.image(format!("colour ×{}", effects.msaa)), g.image(format!("depth ×{}", effects.msaa)))
        } else {
            (g.image("colour"), g.image("depth"))
        };
        let resolve = msaa.then(|| (g.image("colour (resolved)"), g.image("depth (resolved)")));
        // What outlives the frame: the image the host reads, what the host writes before it, uploads
        // and the caches later frames read.
        let readback = g.external_buffer("image");
        let lights = g.external_buffer("lights");
        let oit_lists = g.buffer("OIT lists");
        let occluder_meshes = g.external_buffer("occluder meshes");
        let visibility = g.buffer("visibility + coverage");
        let scene_depth = g.buffer("occluder depth (copy)");
        let raster_frame = g.external_buffer("raster camera + materials");
        let shaded = g.buffer("shaded hair");
        let raster_tiles = g.buffer("occlusion tiles");
        let slot_orders = g.buffer("strand slot orders");
        let strand_marks = g.external_buffer("strand marks");
        let final_depth = g.external_buffer("hair depth (last frame)");
        let hair: Vec<Res> = (0..self.hairs.len()).map(|h| g.external_buffer(format!("hair {h}"))).collect();
        let character_hair: Vec<Res> = self.characters.iter().map(|c| hair[c.hair]).collect();
        let lod = (0..self.characters.len()).map(|i| g.buffer(format!("lod {i}"))).collect();
        let strands = (0..self.characters.len()).map(|i| g.buffer(format!("strands {i}"))).collect();
        let stored: Vec<Res> = (0..self.stored_characters.len())
            .map(|i| g.external_buffer(format!("stored strands {i}")))
            .collect();
        let shadow_cached = self.shadows_cached(&view.lod);
        let shadow = self
            .shadow
            .as_ref()
            .map(|_| crate::passes::shadow::declare(self, &mut g, &character_hair, &stored));
        let (volumes, volume_characters) = self.plan_volumes(&mut g, &view);
        let inputs: Vec<FrameInputs> = self
            .characters
            .iter()
            .map(|c| {
                let character = Character { hair: c.hair, transform: c.transform };
                character_inputs(&view.camera, &character, view.width, view.height, view.lod)
            })
            .collect();
        let second_front = self
            .characters
            .iter()
            .zip(&inputs)
            .map(|(c, inputs)| crate::raster::second_front_pays(&self.hairs[c.hair].asset, inputs))
            .collect();
        let ids = FrameIds {
            color,
            depth,
            resolve,
            readback,
            lights,
            oit_lists,
            occluder_meshes,
            visibility,
            scene_depth,
            raster_frame,
            shaded,
            raster_tiles,
            slot_orders,
            strand_marks,
            final_depth,
            hair: character_hair,
            lod,
            strands,
            stored,
            shadow,
            hair_uploads: hair,
            second_front,
            volumes,
        };
        // Staged uploads go first in the frame's first submission: the shadow maps' when they
        // are made this frame (they read the new texels), else the first batch's.
        let first_batch_submission = usize::from(ids.shadow.is_some());
        let upload_submission =
            if ids.shadow.is_some() && !shadow_cached { 0 } else { first_batch_submission };
        crate::passes::upload::plan(self, &mut g, &ids, upload_submission);
        if let Some(s) = &ids.shadow {
            crate::passes::shadow::plan(self, &mut g, &ids, s, shadow_cached);
        }
        let volume_only: Vec<usize> = ids
            .volumes
            .as_ref()
            .map(|v| v.marched.iter().copied().filter(|&i| v.fractions[i] >= 1.0).collect())
            .unwrap_or_default();
        let batches = self.batches(&inputs, &volume_only);
        for (k, batch) in batches.iter().enumerate() {
            let submission = first_batch_submission + k;
            crate::passes::frame_batch(self, &mut g, &ids, batch, submission, k == 0, k + 1 == batches.len());
        }
        // A pass nothing reads from is shown in the graph and not run.
        g.cull();
        FramePlan {
            graph: g,
            ids,
            batches,
            first_batch_submission,
            view,
            inputs,
            shadow_cached,
            volume_characters,
        }
    }

    /// Characters in batches whose strand buffers fit `batch_bytes`, so a crowd never holds
    /// every character's strands at once (at least one character per batch; one empty batch
    /// when there are none).
    pub(super) fn batches(&self, inputs: &[FrameInputs], volume_characters: &[usize]) -> Vec<Vec<usize>> {
        let mut batches: Vec<Vec<usize>> = vec![Vec::new()];
        let mut batch_bytes = 0;
        for (i, (c, inputs)) in self.characters.iter().zip(inputs).enumerate() {
            if volume_characters.contains(&i) {
                continue;
            }
            // Fused generation holds no strand buffer.
            let bytes = if self.compute_raster.is_some() {
                0
            } else {
                Generator::frame_bytes(&self.hairs[c.hair], inputs)
            };
            if batch_bytes + bytes > self.batch_bytes && batches.last().is_some_and(|b| !b.is_empty()) {
                batches.push(Vec::new());
                batch_bytes = 0;
            }
            batch_bytes += bytes;
            if let Some(b) = batches.last_mut() {
                b.push(i);
            }
        }
        batches
    }

    /// Whether one of `c`'s strands can be a pixel wide in `view`: its widest strand at the
    /// nearest point of its bounds (conservative; strand LOD widening does not count, as the
    /// prepass tests each real strand's coverage). Blended mode's depth prepass draws only
    /// such characters — in a crowd, the far ones have no fragment that could write depth.
    pub(crate) fn may_cover_pixels(&self, c: &SceneCharacter, view: &FrameView) -> bool {
        let asset = &self.hairs[c.hair].asset;
        let (lo, hi) = asset.bounds();
        let (wlo, whi) = transformed_box(c.transform, (lo.as_vec3(), hi.as_vec3()));
        let eye = view.camera.eye;
        let distance = eye.distance(eye.clamp(wlo, whi));
        let scale = (0..3).map(|i| c.transform.col(i).truncate().length()).fold(0.0f32, f32::max);
        let style = &asset.style;
        let width = (style.width * style.tip_width.max(1.0)) as f32 * scale;
        let pixels = width * view.height as f32 / (2.0 * distance * (0.5 * view.camera.fov_y).tan());
        // Half a pixel of margin for the strip's own projection (it is measured per vertex); a
        // NaN (eye on the bounds) keeps the draw.
        pixels.is_nan() || pixels >= 0.5
    }
}
