//! Rendering a scene: the frame graph built from the scene's effects, hair uploaded once per
//! asset and style, strands generated on the fly every frame, shaded by `hair.frag`.

use std::collections::HashMap;
use std::fmt;

use gen_gpu::diagnostics::RenderTarget;
use gen_gpu::{
    Binding, Buffer, BufferDesc, Context, DrawExtras, FragmentStage, FrameTimings, GenerationPath,
    GenerationStats, Generator, GeneratorOptions, GpuHair, GraphicsPipelineDesc, GraphicsStages, Pipeline,
    TexturePrecision, vk,
};
use glam::{Mat4, Vec3, Vec4};
use hairmesh::reference::LodParams;

use crate::RgbaImage;
use crate::crowd::{Camera, Character, CrowdView, character_inputs};
use crate::scene::{Light, LoadedScene, SceneError, Transparency, merged_style};

/// The SPIR-V of this crate's shaders.
pub mod shaders {
    pub use shader_build::{ShaderSpirv, ShaderStage};
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("{path}: {source}")]
    Asset {
        path: std::path::PathBuf,
        #[source]
        source: hairmesh::HairMeshError,
    },
    #[error(transparent)]
    Gpu(#[from] gen_gpu::GpuError),
}

/// One pass of the frame graph.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PassNode {
    pub name: String,
    /// What it reads and writes, for `--print-graph`.
    pub reads: Vec<String>,
    pub writes: Vec<String>,
}

/// The passes a scene needs, in order: only what its effects ask for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameGraph {
    pub passes: Vec<PassNode>,
}

impl fmt::Display for FrameGraph {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, p) in self.passes.iter().enumerate() {
            writeln!(
                f,
                "{i:>2}. {:<32} reads [{}] writes [{}]",
                p.name,
                p.reads.join(", "),
                p.writes.join(", ")
            )?;
        }
        Ok(())
    }
}

/// `Shading` push constants of `hair.frag` (after the 16 pre-raster bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Shading {
    eye: [f32; 4],
    light_vector: [[f32; 4]; 2],
    light_color: [[f32; 4]; 2],
    hair_color: [f32; 4],
    specular_shift: [f32; 4],
    specular_strength: [f32; 4],
    hair_opacity: [f32; 4],
    light_view_proj: [f32; 16],
    shadow: [f32; 4],
}

/// Bindings of the OIT buffers (`oit.glsl`).
const OIT_BINDINGS: [u32; 5] = [12, 13, 14, 15, 16];
/// Bindings of the shadow maps (`hair_shading.glsl`).
const SHADOW_BINDINGS: [u32; 2] = [15, 16];
const OIT_NODE_BYTES: u64 = 16;

/// Order-independent transparency: the fill generator (hair_oit.frag) and the resolve pass.
struct Oit {
    fill: Generator,
    resolve: Pipeline,
    k: u32,
    nodes_per_pixel: f32,
}

struct SceneCharacter {
    hair: usize,
    transform: Mat4,
    color: [f32; 3],
    variation: f32,
}

/// Everything a scene needs on the GPU, built once and rendered many times.
pub struct SceneRenderer {
    generator: Generator,
    oit: Option<Oit>,
    /// Shadow pipelines and the maps of the first frame (the scene is static).
    shadow: Option<(crate::shadow::ShadowPipelines, std::sync::Mutex<Option<crate::shadow::ShadowMaps>>)>,
    /// Bound at 15 and 16 when the scene has no shadows.
    no_shadow: (Buffer, Buffer),
    hairs: Vec<GpuHair>,
    /// Characters whose hair is generated.
    characters: Vec<SceneCharacter>,
    /// Explicit strands uploaded once, and the characters drawing them.
    stored: Vec<gen_gpu::StoredStrands>,
    stored_characters: Vec<SceneCharacter>,
    scene: LoadedScene,
    path: GenerationPath,
}

impl fmt::Debug for SceneRenderer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SceneRenderer")
            .field("scene", &self.scene.path)
            .field("hairs", &self.hairs.len())
            .finish()
    }
}

/// A rendered frame.
#[derive(Debug)]
pub struct RenderedFrame {
    pub image: RgbaImage,
    pub timings: FrameTimings,
    pub stats: GenerationStats,
    /// The passes recorded, by name, in order.
    pub passes: Vec<String>,
    /// OIT: fragments dropped because the node pool was full (`None` in opaque mode).
    pub oit_overflow: Option<u64>,
    /// OIT: nodes in the pool.
    pub oit_pool: Option<u64>,
    /// Shadow maps were reused from an earlier frame.
    pub shadow_cached: bool,
    /// GPU time of the shadow maps when this frame computed them.
    pub shadow_ms: Option<f64>,
}

impl SceneRenderer {
    pub fn new(ctx: &Context, scene: &LoadedScene, path: GenerationPath) -> Result<Self, RenderError> {
        let generator = Generator::with_options(
            ctx,
            GeneratorOptions {
                fragment: Some(FragmentStage {
                    shader: &shaders::HAIR_FRAG,
                    push_constant_bytes: size_of::<Shading>() as u32,
                    blend: gen_gpu::Blend::Over,
                    depth_write: true,
                    color_write: true,
                    extra_bindings: &SHADOW_BINDINGS,
                }),
                ..GeneratorOptions::default()
            },
        )?;
        let effects = scene.scene.effects;
        let oit = if effects.transparency == Transparency::Oit {
            let fill = Generator::with_options(
                ctx,
                GeneratorOptions {
                    fragment: Some(FragmentStage {
                        shader: &shaders::HAIR_OIT_FRAG,
                        push_constant_bytes: size_of::<Shading>() as u32,
                        blend: gen_gpu::Blend::Replace,
                        depth_write: false,
                        color_write: false,
                        extra_bindings: &OIT_BINDINGS,
                    }),
                    ..GeneratorOptions::default()
                },
            )?;
            let bindings: Vec<Binding> = OIT_BINDINGS
                .iter()
                .map(|&b| Binding::storage_buffer(b, vk::ShaderStageFlags::FRAGMENT))
                .collect();
            let resolve = Pipeline::graphics(
                ctx,
                &GraphicsPipelineDesc {
                    name: "OIT resolve",
                    stages: GraphicsStages::Vertex(&shaders::FULLSCREEN_VERT),
                    fragment: &shaders::OIT_RESOLVE_FRAG,
                    bindings: &bindings,
                    push_constant_size: 4,
                    specialization: &[],
                    color_format: gen_gpu::COLOR_FORMAT,
                    depth_format: None,
                    blend: gen_gpu::Blend::Over,
                    depth_write: false,
                    color_write: true,
                },
            )?;
            Some(Oit { fill, resolve, k: effects.oit_k, nodes_per_pixel: effects.oit_nodes_per_pixel })
        } else {
            None
        };
        // One upload per (asset, style): characters sharing both share the GPU hair.
        let mut keys: HashMap<(std::path::PathBuf, String), usize> = HashMap::new();
        let mut hairs = Vec::new();
        let mut characters = Vec::new();
        let mut stored = Vec::new();
        let mut stored_characters = Vec::new();
        for (i, c) in scene.scene.characters.iter().enumerate() {
            let path = scene.hair_path(c);
            if matches!(path.extension().and_then(|e| e.to_str()), Some("tfx" | "hair")) {
                let set = hairmesh::strands::load_strands(&path)
                    .map_err(|source| RenderError::Asset { path: path.clone(), source })?;
                let (lo, hi) = set.bounds().unwrap_or_default();
                let width = c.strand_width.unwrap_or((hi - lo).length() / 2000.0);
                stored.push(gen_gpu::StoredStrands::upload(
                    ctx,
                    &set.points,
                    &set.strand_points,
                    width,
                    0.3,
                )?);
                stored_characters.push(SceneCharacter {
                    hair: stored.len() - 1,
                    transform: c.transform.matrix(),
                    color: c.color,
                    variation: c.color_variation,
                });
                continue;
            }
            let key = (path.clone(), c.style.as_ref().map(|s| s.to_string()).unwrap_or_default());
            let hair = match keys.get(&key) {
                Some(&h) => h,
                None => {
                    let (mut asset, _) = hairmesh::asset_io::read_asset(&path)
                        .map_err(|source| RenderError::Asset { path: path.clone(), source })?;
                    asset.style = merged_style(&scene.path, i, &asset.style, c.style.as_ref())?;
                    hairs.push(GpuHair::upload(ctx, &asset, TexturePrecision::Auto)?);
                    keys.insert(key, hairs.len() - 1);
                    hairs.len() - 1
                }
            };
            characters.push(SceneCharacter {
                hair,
                transform: c.transform.matrix(),
                color: c.color,
                variation: c.color_variation,
            });
        }
        let shadow = if effects.shadows {
            Some((crate::shadow::ShadowPipelines::new(ctx)?, std::sync::Mutex::new(None)))
        } else {
            None
        };
        let no_shadow = (
            Buffer::new(ctx, "no shadow depth", BufferDesc::storage(16))?,
            Buffer::new(ctx, "no shadow opacity", BufferDesc::storage(16))?,
        );
        Ok(Self {
            generator,
            oit,
            shadow,
            no_shadow,
            hairs,
            characters,
            stored,
            stored_characters,
            scene: scene.clone(),
            path,
        })
    }

    fn view(&self) -> CrowdView {
        self.view_from(Vec3::from_array(self.scene.scene.camera.eye))
    }

    fn view_from(&self, eye: Vec3) -> CrowdView {
        let s = &self.scene.scene;
        CrowdView {
            camera: Camera {
                eye,
                target: Vec3::from_array(s.camera.target),
                fov_y: s.camera.fov_y_degrees.to_radians(),
            },
            width: s.output.width,
            height: s.output.height,
            path: self.path,
            lod: LodParams {
                enabled: s.lod.enabled,
                strand_alpha: s.lod.strand_alpha,
                vertex_alpha: s.lod.vertex_alpha,
                ..LodParams::default()
            },
        }
    }

    /// The passes this scene's frame runs (built from its effects).
    pub fn graph(&self) -> FrameGraph {
        let mut passes = Vec::new();
        if self.shadow.is_some() {
            let casters: Vec<String> =
                (0..self.characters.len()).map(|i| format!("hair {}", self.characters[i].hair)).collect();
            passes.push(PassNode {
                name: "shadow: generate in the light's view".into(),
                reads: casters,
                writes: vec!["light-view strands".into()],
            });
            passes.push(PassNode {
                name: "shadow depth".into(),
                reads: vec!["light-view strands".into()],
                writes: vec!["shadow depth map".into()],
            });
            passes.push(PassNode {
                name: "shadow opacity".into(),
                reads: vec!["light-view strands".into(), "shadow depth map".into()],
                writes: vec!["deep opacity map (cached after the first frame)".into()],
            });
        }
        for (i, c) in self.characters.iter().enumerate() {
            passes.push(PassNode {
                name: format!("lod+cull character {i}"),
                reads: vec![format!("hair {}", c.hair), "camera".into()],
                writes: vec![format!("lod {i}")],
            });
            if self.path == GenerationPath::Compute {
                passes.push(PassNode {
                    name: format!("generate character {i}"),
                    reads: vec![format!("hair {}", c.hair), format!("lod {i}")],
                    writes: vec![format!("strands {i}")],
                });
            }
        }
        let mut reads: Vec<String> = (0..self.characters.len())
            .map(|i| {
                if self.path == GenerationPath::Compute { format!("strands {i}") } else { format!("lod {i}") }
            })
            .collect();
        reads.extend((0..self.stored_characters.len()).map(|i| format!("stored strands {i}")));
        reads.push("lights".into());
        if self.oit.is_some() {
            let lists = || vec!["OIT lists".to_owned()];
            passes.push(PassNode { name: "clear OIT lists".into(), reads: vec![], writes: lists() });
            passes.push(PassNode {
                name: format!("raster hair ({}, OIT fill)", self.path),
                reads,
                writes: lists(),
            });
            passes.push(PassNode {
                name: "OIT resolve".into(),
                reads: lists(),
                writes: vec!["colour".into()],
            });
        } else {
            passes.push(PassNode {
                name: format!("raster hair ({}, opaque)", self.path),
                reads,
                writes: vec!["colour".into(), "depth".into()],
            });
        }
        passes.push(PassNode {
            name: "copy out".into(),
            reads: vec!["colour".into()],
            writes: vec!["image".into()],
        });
        FrameGraph { passes }
    }

    fn shading(
        &self,
        c: &SceneCharacter,
        maps: Option<&crate::shadow::ShadowMaps>,
        world_eye: Vec3,
    ) -> Shading {
        let s = &self.scene.scene;
        let to_object = c.transform.inverse();
        let eye = to_object.transform_point3(world_eye);
        let default_light = [Light::Directional { direction: [0.4, 0.8, 0.5], color: [1.0, 1.0, 1.0] }];
        let lights: &[Light] = if s.lights.is_empty() { &default_light } else { &s.lights };
        let mut light_vector = [[0.0; 4]; 2];
        let mut light_color = [[0.0; 4]; 2];
        for (i, l) in lights.iter().take(2).enumerate() {
            let (v, color) = match *l {
                Light::Directional { direction, color } => {
                    (to_object.transform_vector3(Vec3::from_array(direction)).normalize().extend(0.0), color)
                }
                Light::Point { position, color } => {
                    (to_object.transform_point3(Vec3::from_array(position)).extend(1.0), color)
                }
            };
            light_vector[i] = v.to_array();
            light_color[i] = Vec3::from_array(color).extend(0.0).to_array();
        }
        Shading {
            eye: eye.extend(lights.len().min(2) as f32).to_array(),
            light_vector,
            light_color,
            hair_color: Vec4::new(c.color[0], c.color[1], c.color[2], c.variation).to_array(),
            specular_shift: [-0.08, 0.12, 80.0, 12.0],
            specular_strength: [0.25, 0.35, 0.2, 0.6],
            // Opaque mode draws strands solid (coverage aside); OIT lets a strand transmit.
            hair_opacity: [if self.oit.is_some() { 0.7 } else { 1.0 }, 0.0, 0.0, 0.0],
            light_view_proj: maps.map_or(Mat4::IDENTITY, |m| m.light_view_proj * c.transform).to_cols_array(),
            shadow: maps
                .map_or([0.0; 4], |m| [m.layer_ends[0], m.layer_ends[1], m.layer_ends[2], m.size as f32]),
        }
    }

    /// Deep opacity maps of the first light over every character's world bounds.
    fn render_shadow_maps(
        &self,
        ctx: &Context,
        pipes: &crate::shadow::ShadowPipelines,
    ) -> Result<crate::shadow::ShadowMaps, RenderError> {
        let s = &self.scene.scene;
        let toward_light = match s.lights.first() {
            Some(Light::Directional { direction, .. }) => Vec3::from_array(*direction),
            _ => Vec3::new(0.4, 0.8, 0.5),
        };
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let mut add_box = |m: Mat4, (a, b): (Vec3, Vec3)| {
            for k in 0..8 {
                let p = Vec3::new(
                    if k & 1 == 0 { a.x } else { b.x },
                    if k & 2 == 0 { a.y } else { b.y },
                    if k & 4 == 0 { a.z } else { b.z },
                );
                let w = m.transform_point3(p);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        };
        for c in &self.characters {
            for b in &self.hairs[c.hair].asset.bundles {
                add_box(c.transform, (b.bounds_min.as_vec3(), b.bounds_max.as_vec3()));
            }
        }
        for c in &self.stored_characters {
            add_box(c.transform, self.stored[c.hair].bounds);
        }
        let generated: Vec<(usize, Mat4)> = self.characters.iter().map(|c| (c.hair, c.transform)).collect();
        let stored: Vec<(usize, Mat4)> =
            self.stored_characters.iter().map(|c| (c.hair, c.transform)).collect();
        let casters = crate::shadow::ShadowCasters {
            hairs: &self.hairs,
            generated: &generated,
            stored: &self.stored,
            stored_characters: &stored,
        };
        let settings = crate::shadow::ShadowSettings {
            size: s.effects.shadow_map_size,
            layer_fractions: s.effects.shadow_layers,
            lod: self.view().lod,
        };
        Ok(crate::shadow::render_shadow_maps(ctx, pipes, &casters, toward_light, (lo, hi), settings)?)
    }

    /// Draws every character (generated, then stored) with `generator`'s fragment stage.
    #[expect(
        clippy::too_many_arguments,
        reason = "one frame's per-draw inputs; bundling them adds a type used once"
    )]
    fn draw_characters(
        &self,
        rec: &mut gen_gpu::Recorder<'_>,
        generator: &Generator,
        frames: &[gen_gpu::FrameBuffers],
        stored_params: &[Buffer],
        extra: &[(u32, &Buffer)],
        maps: Option<&crate::shadow::ShadowMaps>,
        eye: Vec3,
    ) -> gen_gpu::Result<()> {
        for (c, frame) in self.characters.iter().zip(frames) {
            let shading = self.shading(c, maps, eye);
            let extras = DrawExtras { fragment_constants: bytemuck::bytes_of(&shading), buffers: extra };
            generator.record_draw_with(rec, &self.hairs[c.hair], frame, self.path, false, extras)?;
        }
        self.draw_stored(rec, generator, stored_params, extra, maps, eye);
        Ok(())
    }

    /// Draws the explicit-strand characters with `generator`'s fragment stage.
    fn draw_stored(
        &self,
        rec: &mut gen_gpu::Recorder<'_>,
        generator: &Generator,
        params: &[Buffer],
        extra: &[(u32, &Buffer)],
        maps: Option<&crate::shadow::ShadowMaps>,
        eye: Vec3,
    ) {
        for (c, params) in self.stored_characters.iter().zip(params) {
            let shading = self.shading(c, maps, eye);
            let extras = DrawExtras { fragment_constants: bytemuck::bytes_of(&shading), buffers: extra };
            generator.record_draw_stored(rec, &self.stored[c.hair], params, extras);
        }
    }

    /// Renders one frame.
    pub fn render(&self, ctx: &Context) -> Result<RenderedFrame, RenderError> {
        self.render_from(ctx, Vec3::from_array(self.scene.scene.camera.eye))
    }

    /// Renders one frame with the camera at `eye` (looking at the scene's target). Shadow maps
    /// do not depend on the camera and stay cached.
    pub fn render_from(&self, ctx: &Context, eye: Vec3) -> Result<RenderedFrame, RenderError> {
        let view = self.view_from(eye);
        let graph = self.graph();
        let mut recorded = Vec::new();
        // Shadow maps: computed on the first frame, then reused (static characters and light).
        let mut shadow_cached = false;
        let mut shadow_ms = None;
        let mut shadow_guard = match &self.shadow {
            Some((pipes, cache)) => {
                let mut guard = cache.lock().unwrap_or_else(|e| e.into_inner());
                if guard.is_some() {
                    shadow_cached = true;
                } else {
                    let maps = self.render_shadow_maps(ctx, pipes)?;
                    shadow_ms = maps.timings.pass_ms("shadow maps");
                    *guard = Some(maps);
                    recorded.extend(
                        ["shadow: generate in the light's view", "shadow depth", "shadow opacity"]
                            .map(String::from),
                    );
                }
                Some(guard)
            }
            None => None,
        };
        let maps = shadow_guard.as_mut().and_then(|g| g.as_ref());
        let shadow_extra: [(u32, &Buffer); 2] = match maps {
            Some(m) => [(15, &m.depth), (16, &m.opacity)],
            None => [(15, &self.no_shadow.0), (16, &self.no_shadow.1)],
        };
        let characters: Vec<Character> =
            self.characters.iter().map(|c| Character { hair: c.hair, transform: c.transform }).collect();
        let frames = characters
            .iter()
            .map(|c| {
                self.generator.prepare(
                    ctx,
                    &self.hairs[c.hair],
                    &character_inputs(&view.camera, c, view.width, view.height, view.lod),
                )
            })
            .collect::<gen_gpu::Result<Vec<_>>>()?;
        let stored_params = self
            .stored_characters
            .iter()
            .map(|c| {
                let character = Character { hair: c.hair, transform: c.transform };
                let inputs = character_inputs(&view.camera, &character, view.width, view.height, view.lod);
                // The fill and the opaque generators share the parameter layout.
                self.generator.stored_params(ctx, &self.stored[c.hair], &inputs)
            })
            .collect::<gen_gpu::Result<Vec<_>>>()?;
        let target = RenderTarget::new(ctx, view.width, view.height)?;
        // The OIT node pool is bounded by the output size and the storage-buffer range.
        let oit_buffers = match &self.oit {
            Some(oit) => {
                let pixels = u64::from(view.width) * u64::from(view.height);
                let range = u64::from(ctx.capabilities().max_storage_buffer_range) / OIT_NODE_BYTES;
                let pool = ((pixels as f64 * f64::from(oit.nodes_per_pixel)) as u64)
                    .clamp(1, range.min(u64::from(u32::MAX - 1)));
                Some((
                    Buffer::new(ctx, "OIT heads", BufferDesc::storage(pixels * 4))?,
                    Buffer::new(ctx, "OIT nodes", BufferDesc::storage(pool * OIT_NODE_BYTES))?,
                    Buffer::new(ctx, "OIT counters", BufferDesc::storage(16))?,
                    pool,
                ))
            }
            None => None,
        };
        let ((), timings) = ctx.submit("scene frame", |rec| {
            for (i, (c, frame)) in characters.iter().zip(&frames).enumerate() {
                let hair = &self.hairs[c.hair];
                rec.pass(&format!("lod+cull character {i}"), |rec| {
                    self.generator.record_lod(rec, hair, frame);
                });
                recorded.push(format!("lod+cull character {i}"));
                if self.path == GenerationPath::Compute {
                    rec.pass(&format!("generate character {i}"), |rec| {
                        self.generator.record_generate(rec, hair, frame);
                    });
                    recorded.push(format!("generate character {i}"));
                }
            }
            let drawn = match (&self.oit, &oit_buffers) {
                (Some(oit), Some((heads, nodes, counters, pool))) => {
                    rec.pass("clear OIT lists", |rec| {
                        rec.fill_buffer(heads, u32::MAX);
                        let init = [0u32, *pool as u32, 0, view.width];
                        rec.update_buffer(counters, 0, bytemuck::cast_slice(&init));
                    });
                    recorded.push("clear OIT lists".to_owned());
                    rec.memory_barrier(
                        (
                            vk::PipelineStageFlags2::CLEAR | vk::PipelineStageFlags2::COPY,
                            vk::AccessFlags2::TRANSFER_WRITE,
                        ),
                        (
                            vk::PipelineStageFlags2::FRAGMENT_SHADER,
                            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
                        ),
                    );
                    target.begin(rec);
                    let fill = format!("raster hair ({}, OIT fill)", self.path);
                    let extra = [(12, heads), (13, nodes), (14, counters), shadow_extra[0], shadow_extra[1]];
                    let drawn = rec.pass(&fill, |rec| {
                        self.draw_characters(
                            rec,
                            &oit.fill,
                            &frames,
                            &stored_params,
                            &extra,
                            maps,
                            view.camera.eye,
                        )
                    });
                    recorded.push(fill);
                    rec.end_rendering();
                    rec.memory_barrier(
                        (vk::PipelineStageFlags2::FRAGMENT_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                        (vk::PipelineStageFlags2::FRAGMENT_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
                    );
                    rec.pass("OIT resolve", |rec| {
                        rec.begin_rendering_load(&target.color);
                        rec.bind_pipeline(&oit.resolve);
                        rec.push_storage_buffers(&oit.resolve, &extra);
                        rec.push_constants(&oit.resolve, &oit.k);
                        rec.draw(3, 1);
                        rec.end_rendering();
                    });
                    recorded.push("OIT resolve".to_owned());
                    drawn
                }
                _ => {
                    target.begin(rec);
                    let raster = format!("raster hair ({}, opaque)", self.path);
                    let drawn = rec.pass(&raster, |rec| {
                        self.draw_characters(
                            rec,
                            &self.generator,
                            &frames,
                            &stored_params,
                            &shadow_extra,
                            maps,
                            view.camera.eye,
                        )
                    });
                    recorded.push(raster);
                    rec.end_rendering();
                    drawn
                }
            };
            rec.pass("copy out", |rec| target.copy_out(rec));
            recorded.push("copy out".into());
            drawn
        })?;
        if !shadow_cached {
            debug_assert_eq!(recorded, graph.passes.iter().map(|p| p.name.clone()).collect::<Vec<_>>());
        }
        let mut stats = GenerationStats::default();
        stats.strands += self.stored_characters.iter().map(|c| self.stored[c.hair].strands).sum::<u64>();
        for (c, frame) in characters.iter().zip(&frames) {
            let s = self.generator.stats(ctx, &self.hairs[c.hair], frame)?;
            stats += s;
        }
        let (oit_overflow, oit_pool) = match &oit_buffers {
            Some((_, _, counters, pool)) => {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(counters, 16)?);
                (Some(u64::from(c[2])), Some(*pool))
            }
            None => (None, None),
        };
        Ok(RenderedFrame {
            image: target.read(ctx)?,
            timings,
            stats,
            passes: recorded,
            oit_overflow,
            oit_pool,
            shadow_cached,
            shadow_ms,
        })
    }
}
