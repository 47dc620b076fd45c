//! Animated scenes: head motion, hair-mesh dynamics and simulation caches.
//!
//! A scene with `"animation": {"frames": N, "fps": R}` has frames `0..N` at times `f / R`.
//! Characters with a `motion` move their head (hair, roots and occluder together); characters
//! with a `dynamics` block have their hair mesh simulated ([`hairmesh::dynamics`]), its
//! textures re-baked and the changed texels uploaded every frame
//! ([`crate::frame::SceneRenderer::update_hair`], the graph's `update hair` passes). Everything
//! else costs nothing: a character without motion is never touched, a scene without dynamics
//! simulates nothing and uploads nothing, so its shadow maps and volumes stay cached.
//!
//! **Frame ranges.** A frame depends only on the scene, its assets and the simulated hair-mesh
//! positions of that frame. Simulation is sequential (frame `f` needs `0..f`), so it runs once
//! into a simulation cache ([`crate::sim_cache`], written and read a frame at a time) — every dynamic character's object-space hair-mesh positions per frame,
//! f32, keyed on everything the simulation reads — and any process rendering any range reads
//! the positions of its frames from it. A process without a cache simulates from frame 0 in
//! memory; positions come out bit for bit the same either way (same f32 operations in the same
//! order), so its images are identical too.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use render::animation::Animation;
//! let scene = render::scene::load_scene(std::path::Path::new("scene.json"))?;
//! let mut instance = render::instance::SceneInstance::load(&scene)?;
//! let animation = Animation::new(&mut instance)?; // before the renderer: dynamic hair gets its own upload
//! let path = std::path::Path::new("scene.sim");
//! render::sim_cache::write_sim_cache(&animation, animation.frames(), path, &|_| {})?;
//! let cache = render::sim_cache::SimCache::open(path, &animation)?;
//! let last = cache.positions(animation.frames() - 1)?;
//! # Ok(()) }
//! ```

use std::sync::Arc;
use std::time::Instant;

use glam::{Affine3A, Mat4, Vec3};
use hairmesh::asset::{HairAsset, VertexMove};
use hairmesh::dynamics::{Collider, HairSim, fit_sphere};
use rayon::prelude::*;

use crate::RenderError;
use crate::frame::SceneRenderer;
use crate::instance::{CharacterHair, SceneInstance};
use crate::scene::MotionDesc;

/// A scene's animation: its characters' motion and the simulations of its dynamic characters.
#[derive(Debug)]
pub struct Animation {
    path: std::path::PathBuf,
    fps: f32,
    frames: u32,
    characters: Vec<AnimatedCharacter>,
    dynamic: Vec<DynamicCharacter>,
    key: u64,
}

#[derive(Debug)]
struct AnimatedCharacter {
    /// The scene's transform (object → world) without motion.
    base: Mat4,
    motion: Option<MotionDesc>,
}

#[derive(Debug)]
struct DynamicCharacter {
    /// Index among the scene's characters.
    character: usize,
    /// The upload key the renderer knows this character's hair by (unique to it).
    key: String,
    rest: Arc<HairAsset>,
    /// The simulation at frame 0.
    start: HairSim,
}

/// Object → world of a character at time `t`.
fn placement(c: &AnimatedCharacter, t: f64) -> Mat4 {
    match &c.motion {
        Some(m) => c.base * m.at(t),
        None => c.base,
    }
}

/// FNV-1a (64 bit): a stable hash for cache keys (std's hasher may change between releases).
#[derive(Clone, Copy, Debug)]
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn bytes(mut self, data: &[u8]) -> Self {
        for &b in data {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        self
    }
}

impl Animation {
    /// The animation of a loaded scene instance (its characters in the scene file's order).
    /// Dynamic characters get upload keys of their own in `instance` (each is simulated
    /// independently), so call this before setting up the renderer.
    pub fn new(instance: &mut SceneInstance) -> Result<Self, RenderError> {
        let SceneInstance { settings, characters: instances } = instance;
        let scene = &settings.scene;
        let path = settings.path.clone();
        let error = |message: String| RenderError::Animation { path: path.clone(), message };
        let (fps, frames) = scene.animation.map_or((24.0, 1), |a| (a.fps, a.frames));
        if instances.len() != scene.characters.len() {
            return Err(error(format!(
                "the instance has {} characters and the scene {}: an animation needs the scene's own",
                instances.len(),
                scene.characters.len()
            )));
        }
        let mut characters = Vec::new();
        let mut dynamic = Vec::new();
        let mut key = Fnv::new().bytes(b"hairkit-sim 1").bytes(&fps.to_le_bytes());
        for (i, (desc, c)) in scene.characters.iter().zip(instances.iter_mut()).enumerate() {
            let animated = AnimatedCharacter { base: c.transform, motion: desc.motion.clone() };
            let Some(params) = &desc.dynamics else {
                characters.push(animated);
                continue;
            };
            let CharacterHair::Generated(asset) = &c.hair else {
                return Err(error(format!("characters[{i}].dynamics: the hair is explicit strands")));
            };
            let mut extra: Vec<Collider> = Vec::new();
            if params.collide_with_occluder {
                let Some(o) = &c.occluder else {
                    return Err(error(format!(
                        "characters[{i}].dynamics.collide_with_occluder: the character has no occluder"
                    )));
                };
                let to_object = c.transform.inverse() * o.transform;
                let points: Vec<Vec3> = o
                    .geometry
                    .positions
                    .iter()
                    .map(|p| to_object.transform_point3(Vec3::new(p[0], p[1], p[2])))
                    .collect();
                extra.push(fit_sphere(&points).ok_or_else(|| {
                    error(format!("characters[{i}].dynamics: no sphere fits the occluder mesh (too few or coplanar points)"))
                })?);
            }
            let at = |t: f64| Affine3A::from_mat4(placement(&animated, t));
            let start = HairSim::new(asset.mesh(), params, &extra, &at)
                .map_err(|e| error(format!("characters[{i}].dynamics: {e}")))?;
            // Everything the simulation reads goes into the cache key.
            let json = serde_json::to_string(&(params, &desc.motion, &extra)).unwrap_or_default();
            key = key.bytes(&(i as u64).to_le_bytes()).bytes(json.as_bytes());
            key = key.bytes(bytemuck::cast_slice(&c.transform.to_cols_array()));
            for layer in &asset.mesh().layers {
                for p in layer {
                    key = key.bytes(bytemuck::cast_slice(&p.to_array()));
                }
            }
            c.key = format!("{} #dynamics {i}", c.key);
            dynamic.push(DynamicCharacter { character: i, key: c.key.clone(), rest: asset.clone(), start });
            characters.push(animated);
        }
        Ok(Self { path, fps, frames, characters, dynamic, key: key.0 })
    }

    /// Frames of the animation (1 without an `animation` block).
    pub fn frames(&self) -> u32 {
        self.frames
    }

    pub fn fps(&self) -> f32 {
        self.fps
    }

    /// Characters whose hair is simulated.
    pub fn dynamic_characters(&self) -> usize {
        self.dynamic.len()
    }

    /// Hair-mesh vertices of each dynamic character.
    pub fn vertex_counts(&self) -> Vec<u32> {
        self.dynamic.iter().map(|d| d.start.vertex_count() as u32).collect()
    }

    /// Whether any character moves (motion or dynamics).
    pub fn moves(&self) -> bool {
        !self.dynamic.is_empty() || self.characters.iter().any(|c| c.motion.is_some())
    }

    /// What a [`SimCache`](crate::sim_cache::SimCache) of this animation must have been made from.
    pub fn cache_key(&self) -> u64 {
        self.key
    }

    /// Time of frame `frame` (seconds).
    pub fn time(&self, frame: u32) -> f64 {
        f64::from(frame) / f64::from(self.fps)
    }

    /// Object → world of scene character `character` at frame `frame`.
    pub fn placement(&self, character: usize, frame: u32) -> Mat4 {
        placement(&self.characters[character], self.time(frame))
    }

    /// The simulations at frame 0, stepped in memory ([`Simulation::advance`]).
    pub fn start(&self) -> Simulation<'_> {
        Simulation { animation: self, sims: self.dynamic.iter().map(|d| d.start.clone()).collect(), frame: 0 }
    }
}

/// The dynamic characters' simulations at one frame.
#[derive(Debug)]
pub struct Simulation<'a> {
    animation: &'a Animation,
    sims: Vec<HairSim>,
    frame: u32,
}

impl Simulation<'_> {
    /// The frame the simulations are at.
    pub fn frame(&self) -> u32 {
        self.frame
    }

    /// Steps every dynamic character one frame (in parallel across characters; each one's
    /// result does not depend on the others or on the thread count).
    pub fn advance(&mut self) {
        let a = self.animation;
        let dt = 1.0 / a.fps;
        self.sims.par_iter_mut().zip(&a.dynamic).for_each(|(sim, d)| {
            let c = &a.characters[d.character];
            sim.step(dt, &|t: f64| Affine3A::from_mat4(placement(c, t)));
        });
        self.frame += 1;
    }

    /// Each dynamic character's hair-mesh positions in object space at this frame, layer-major
    /// (what [`SimCache`](crate::sim_cache::SimCache) stores).
    pub fn positions(&self) -> Vec<Vec<Vec3>> {
        let a = self.animation;
        self.sims
            .par_iter()
            .zip(&a.dynamic)
            .map(|(sim, d)| sim.object_positions(Affine3A::from_mat4(a.placement(d.character, self.frame))))
            .collect()
    }
}

/// What bringing a renderer to a frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameUpdate {
    /// Characters moved (motion).
    pub moved: usize,
    /// Characters whose hair was re-baked (dynamics).
    pub rebaked: usize,
    /// CPU time re-baking the textures.
    pub rebake_ms: f64,
    /// Bytes staged for upload.
    pub upload_bytes: u64,
}

/// Brings a [`SceneRenderer`] to the frames of an [`Animation`]: sets the moving characters'
/// placements and re-bakes the dynamic characters' textures from their simulated positions.
#[derive(Debug)]
pub struct Player {
    /// Per dynamic character: its asset as the renderer holds it.
    assets: Vec<HairAsset>,
}

impl Player {
    pub fn new(animation: &Animation) -> Self {
        Self { assets: animation.dynamic.iter().map(|d| (*d.rest).clone()).collect() }
    }

    /// Puts frame `frame` into `renderer`: `positions` are the dynamic characters' (from a
    /// [`SimCache`](crate::sim_cache::SimCache) or a [`Simulation`] at that frame). Every simulated vertex is re-baked, so
    /// the textures depend on this frame's positions only, not on the frames shown before.
    pub fn show(
        &mut self,
        animation: &Animation,
        renderer: &mut SceneRenderer,
        ctx: &gen_gpu::Context,
        frame: u32,
        positions: &[Vec<Vec3>],
    ) -> Result<FrameUpdate, RenderError> {
        let error = |message: String| RenderError::Animation { path: animation.path.clone(), message };
        if positions.len() != animation.dynamic.len() {
            return Err(error(format!(
                "{} characters' positions for {} dynamic characters",
                positions.len(),
                animation.dynamic.len()
            )));
        }
        let mut update = FrameUpdate::default();
        for (i, c) in animation.characters.iter().enumerate() {
            if c.motion.is_some() {
                renderer.set_character_transform(i, animation.placement(i, frame))?;
                update.moved += 1;
            }
        }
        let started = Instant::now();
        // Re-bake in parallel (characters are independent), then stage in order.
        let changes: Vec<Result<hairmesh::asset::AssetChange, RenderError>> = animation
            .dynamic
            .par_iter()
            .zip(self.assets.par_iter_mut())
            .zip(positions.par_iter())
            .map(|((d, asset), p)| {
                let per_layer = asset.mesh().vertex_count();
                let total = asset.mesh().layers.len() * per_layer;
                if p.len() != total {
                    return Err(error(format!(
                        "characters[{}]: {} positions for a hair mesh of {total} vertices",
                        d.character,
                        p.len()
                    )));
                }
                let moves = VertexMove::above_roots(p, per_layer);
                asset
                    .move_vertices(&moves)
                    .map_err(|e| error(format!("characters[{}]: re-baking: {e}", d.character)))
            })
            .collect();
        for ((d, asset), change) in animation.dynamic.iter().zip(&self.assets).zip(changes) {
            let sent = renderer.update_hair(ctx, &d.key, asset, &change?)?;
            update.rebaked += 1;
            update.upload_bytes += sent.bytes;
        }
        update.rebake_ms = started.elapsed().as_secs_f64() * 1e3;
        Ok(update)
    }
}
