//! Rendering a scene: the frame graph built from the scene's effects, hair uploaded once per
//! asset and style, strands generated on the fly every frame, shaded by `hair.frag` into a
//! linear RGBA16F target (MSAA in opaque mode when asked), occluder meshes drawn first.

use std::collections::HashMap;
use std::fmt;

use gen_gpu::{
    Binding, Buffer, BufferDesc, Context, DrawExtras, FragmentStage, FrameTimings, GenerationPath,
    GenerationStats, Generator, GeneratorOptions, GpuHair, GraphicsPipelineDesc, GraphicsStages, Pipeline,
    TexturePrecision, vk,
};
use glam::{Mat4, Vec3, Vec4};
use hairmesh::reference::LodParams;

use crate::RgbaImage;
use crate::crowd::{Camera, Character, CrowdView, character_inputs};
use crate::occluder::{LIGHTING_BINDINGS, OccluderMesh, OccluderPipelines, occluder_push};
use crate::scene::{Light, LoadedScene, SceneError, Transparency, merged_style};
use crate::shadow::{LightView, ShadowAtlas, ShadowLight, ShadowPipelines};
use crate::target::{LinearFrame, SCENE_COLOR_FORMAT, SceneTarget};

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
    #[error("{path}: lights[{light}]: {message}")]
    Light { path: std::path::PathBuf, light: usize, message: String },
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
    model: [f32; 16],
    eye: [f32; 4],
    hair_color: [f32; 4],
    specular_shift: [f32; 4],
    specular_strength: [f32; 4],
    hair_opacity: [f32; 4],
}

/// `SceneLight` of `lighting.glsl` (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuLight {
    vector: [f32; 4],
    color: [f32; 4],
    view_proj: [f32; 16],
    layer_ends: [f32; 4],
    map: [f32; 4],
    depth: [f32; 4],
}

/// Bindings of the OIT buffers (`oit.glsl`) and the lighting (`lighting.glsl`).
const OIT_FILL_BINDINGS: [u32; 7] = [12, 13, 14, 15, 16, 17, 18];
const OIT_BINDINGS: [u32; 3] = [12, 13, 14];
const OIT_NODE_BYTES: u64 = 16;
/// Strand-buffer bytes one submission of a frame may hold (characters beyond it go to the next
/// batch): a 100-character crowd with LOD off needs gigabytes otherwise.
pub const BATCH_BYTES: u64 = 1 << 30;

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

/// An occluder mesh placed in the world.
struct SceneOccluder {
    mesh: usize,
    transform: Mat4,
    color: [f32; 3],
}

/// Everything a scene needs on the GPU, built once and rendered many times.
pub struct SceneRenderer {
    generator: Generator,
    /// Blended mode: the solid-fragment depth prepass (`hair_depth.frag`).
    depth_prepass: Option<Generator>,
    oit: Option<Oit>,
    /// Shadow pipelines and the maps of the first frame (the scene is static).
    shadow: Option<(ShadowPipelines, std::sync::Mutex<Option<ShadowAtlas>>)>,
    /// Bound at 15, 16 and 18 when the scene has no shadows (never read then).
    no_shadow: [Buffer; 3],
    /// Occluder pipelines (only when some character has an occluder), meshes and placements.
    occluder_pipes: Option<OccluderPipelines>,
    meshes: Vec<OccluderMesh>,
    occluders: Vec<SceneOccluder>,
    hairs: Vec<GpuHair>,
    /// Characters whose hair is generated.
    characters: Vec<SceneCharacter>,
    /// Explicit strands uploaded once, and the characters drawing them.
    stored: Vec<gen_gpu::StoredStrands>,
    stored_characters: Vec<SceneCharacter>,
    scene: LoadedScene,
    path: GenerationPath,
    /// See [`BATCH_BYTES`].
    batch_bytes: u64,
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
    /// 8-bit sRGB (what PNG output writes).
    pub image: RgbaImage,
    /// Linear colour, coverage and depth (what EXR output writes).
    pub linear: LinearFrame,
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
        let effects = scene.scene.effects;
        let generator = Generator::with_options(
            ctx,
            GeneratorOptions {
                fragment: Some(FragmentStage {
                    shader: &shaders::HAIR_FRAG,
                    push_constant_bytes: size_of::<Shading>() as u32,
                    blend: gen_gpu::Blend::Over,
                    // Blended mode: only the depth prepass writes hair depth; this pass shades
                    // what lies in front of (or is) the nearest solid fragment.
                    depth_write: effects.transparency != Transparency::Blended,
                    depth_compare: if effects.transparency == Transparency::Blended {
                        vk::CompareOp::LESS_OR_EQUAL
                    } else {
                        vk::CompareOp::LESS
                    },
                    color_write: true,
                    extra_bindings: &LIGHTING_BINDINGS,
                }),
                color_format: Some(SCENE_COLOR_FORMAT),
                samples: effects.msaa,
                ..GeneratorOptions::default()
            },
        )?;
        // Blended mode's depth prepass: fragments a strand covers fully write depth, thinner
        // ones do not, so a sub-pixel strand (alpha = coverage) never hides the strands behind it.
        let depth_prepass = if effects.transparency != Transparency::Blended {
            None
        } else {
            Some(Generator::with_options(
                ctx,
                GeneratorOptions {
                    fragment: Some(FragmentStage {
                        shader: &shaders::HAIR_DEPTH_FRAG,
                        push_constant_bytes: size_of::<Shading>() as u32,
                        blend: gen_gpu::Blend::Replace,
                        depth_write: true,
                        depth_compare: vk::CompareOp::LESS,
                        color_write: false,
                        extra_bindings: &[],
                    }),
                    color_format: Some(SCENE_COLOR_FORMAT),
                    samples: effects.msaa,
                    ..GeneratorOptions::default()
                },
            )?)
        };
        let oit = if effects.transparency == Transparency::Oit {
            let fill = Generator::with_options(
                ctx,
                GeneratorOptions {
                    fragment: Some(FragmentStage {
                        shader: &shaders::HAIR_OIT_FRAG,
                        push_constant_bytes: size_of::<Shading>() as u32,
                        blend: gen_gpu::Blend::Replace,
                        depth_write: false,
                        depth_compare: vk::CompareOp::LESS,
                        color_write: false,
                        extra_bindings: &OIT_FILL_BINDINGS,
                    }),
                    color_format: Some(SCENE_COLOR_FORMAT),
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
                    color_format: SCENE_COLOR_FORMAT,
                    // The nearest hair's depth is written (gl_FragDepth) for depth output.
                    depth_format: Some(gen_gpu::DEPTH_FORMAT),
                    blend: gen_gpu::Blend::Over,
                    depth_write: true,
                    color_write: true,
                    samples: 1,
                    depth_compare: vk::CompareOp::LESS,
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
        let mut mesh_keys: HashMap<std::path::PathBuf, usize> = HashMap::new();
        let mut meshes = Vec::new();
        let mut occluders = Vec::new();
        for (i, c) in scene.scene.characters.iter().enumerate() {
            if let Some(o) = &c.occluder {
                let mesh_path = scene.resolve(&o.mesh);
                let mesh = match mesh_keys.get(&mesh_path) {
                    Some(&m) => m,
                    None => {
                        meshes.push(OccluderMesh::load(ctx, &mesh_path)?);
                        mesh_keys.insert(mesh_path, meshes.len() - 1);
                        meshes.len() - 1
                    }
                };
                occluders.push(SceneOccluder {
                    mesh,
                    transform: c.transform.matrix() * o.transform.matrix(),
                    color: o.color,
                });
            }
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
        let shadow = if scene.shadow_lights().is_empty() {
            None
        } else {
            Some((ShadowPipelines::new(ctx)?, std::sync::Mutex::new(None)))
        };
        let no_shadow = [
            Buffer::new(ctx, "no shadow depth", BufferDesc::storage(16))?,
            Buffer::new(ctx, "no shadow opacity", BufferDesc::storage(16))?,
            Buffer::new(ctx, "no occluder depth", BufferDesc::storage(16))?,
        ];
        let occluder_pipes = if meshes.is_empty() {
            None
        } else {
            Some(OccluderPipelines::new(ctx, SCENE_COLOR_FORMAT, effects.msaa)?)
        };
        Ok(Self {
            generator,
            depth_prepass,
            oit,
            shadow,
            no_shadow,
            occluder_pipes,
            meshes,
            occluders,
            hairs,
            characters,
            stored,
            stored_characters,
            scene: scene.clone(),
            path,
            batch_bytes: BATCH_BYTES,
        })
    }

    fn view(&self) -> CrowdView {
        let c = &self.scene.scene.camera;
        self.view_from(Vec3::from_array(c.eye), Vec3::from_array(c.target))
    }

    fn view_from(&self, eye: Vec3, target: Vec3) -> CrowdView {
        let s = &self.scene.scene;
        CrowdView {
            camera: Camera { eye, target, fov_y: s.camera.fov_y_degrees.to_radians() },
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

    /// Caps the strand-buffer bytes of one submission (default [`BATCH_BYTES`]); at least one
    /// character goes into each batch.
    pub fn with_batch_bytes(mut self, bytes: u64) -> Self {
        self.batch_bytes = bytes;
        self
    }

    /// The passes this scene's frame runs (built from its effects).
    pub fn graph(&self) -> FrameGraph {
        let mut passes = Vec::new();
        if self.shadow.is_some() {
            let has_occluders = !self.occluders.is_empty();
            let mut casters: Vec<String> =
                self.characters.iter().map(|c| format!("hair {}", c.hair)).collect();
            casters.extend((0..self.stored_characters.len()).map(|i| format!("stored strands {i}")));
            for (i, light) in self.scene.shadow_lights().into_iter().enumerate() {
                let names = crate::shadow::light_pass_names(i, has_occluders);
                let mut names = names.into_iter();
                let mut node = |reads: Vec<String>, writes: Vec<String>| PassNode {
                    name: names.next().unwrap_or_default(),
                    reads,
                    writes,
                };
                let strands = format!("light {light} strands");
                passes.push(node(casters.clone(), vec![strands.clone()]));
                if has_occluders {
                    passes
                        .push(node(vec!["occluder meshes".into()], vec![format!("occluder depth map {i}")]));
                }
                passes.push(node(vec![strands.clone()], vec![format!("hair depth map {i}")]));
                passes.push(node(
                    vec![strands, format!("hair depth map {i}")],
                    vec![format!("deep opacity map {i} (cached after the first frame)")],
                ));
            }
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
        if self.shadow.is_some() {
            reads.push("shadow maps".into());
        }
        let target = |msaa: bool| {
            if msaa {
                vec![format!("colour ×{}", self.scene.scene.effects.msaa), "depth".into()]
            } else {
                vec!["colour".into(), "depth".into()]
            }
        };
        let msaa = self.scene.scene.effects.msaa > 1;
        if self.oit.is_some() {
            passes.push(PassNode {
                name: "clear OIT lists".into(),
                reads: vec![],
                writes: vec!["OIT lists".into()],
            });
        }
        if !self.occluders.is_empty() {
            let mut occluder_reads = vec!["occluder meshes".to_owned(), "lights".into()];
            if self.shadow.is_some() {
                occluder_reads.push("shadow maps".into());
            }
            passes.push(PassNode { name: "occluders".into(), reads: occluder_reads, writes: target(msaa) });
        }
        if self.oit.is_some() {
            reads.push("depth".into());
            passes.push(PassNode {
                name: format!("raster hair ({}, OIT fill)", self.path),
                reads,
                writes: vec!["OIT lists".into()],
            });
            passes.push(PassNode {
                name: "OIT resolve".into(),
                reads: vec!["OIT lists".into()],
                writes: target(false),
            });
        } else {
            if self.depth_prepass.is_some() {
                passes.push(PassNode {
                    name: format!("hair depth prepass ({}, solid fragments)", self.path),
                    reads: reads.clone(),
                    writes: vec!["depth".into()],
                });
                reads.push("depth".into());
            }
            passes.push(PassNode { name: self.raster_pass_name(), reads, writes: target(msaa) });
        }
        passes.push(PassNode {
            name: "copy out".into(),
            reads: if msaa {
                vec!["colour (resolved)".into(), "depth (resolved)".into()]
            } else {
                target(false)
            },
            writes: vec!["image".into()],
        });
        FrameGraph { passes }
    }

    fn shading(&self, c: &SceneCharacter, eye: Vec3) -> Shading {
        Shading {
            model: c.transform.to_cols_array(),
            eye: eye.extend(self.scene.lights().len() as f32).to_array(),
            hair_color: Vec4::new(c.color[0], c.color[1], c.color[2], c.variation).to_array(),
            specular_shift: [-0.08, 0.12, 80.0, 12.0],
            specular_strength: [0.25, 0.35, 0.2, 0.6],
            // Opaque mode draws strands solid (coverage aside); OIT lets a strand transmit.
            hair_opacity: [if self.oit.is_some() { 0.7 } else { 1.0 }, 0.0, 0.0, 0.0],
        }
    }

    /// The lights buffer of `lighting.glsl`: every light, with its shadow maps' place.
    fn light_data(&self, atlas: Option<&ShadowAtlas>) -> Vec<GpuLight> {
        let shadow_lights = self.scene.shadow_lights();
        self.scene
            .lights()
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let vector = match *l {
                    Light::Directional { direction, .. } => {
                        Vec3::from_array(direction).normalize().extend(0.0)
                    }
                    Light::Point { position, .. } => Vec3::from_array(position).extend(1.0),
                };
                let shadow = atlas.and_then(|a| {
                    shadow_lights.iter().position(|&s| s == i).and_then(|k| a.lights.get(k)).map(|ls| (a, ls))
                });
                let (view_proj, layer_ends, map, depth) = match shadow {
                    Some((a, ls)) => (
                        ls.light_view_proj,
                        [ls.layer_ends[0], ls.layer_ends[1], ls.layer_ends[2], 0.0],
                        [a.size as f32, ls.first_texel as f32, ls.occluder_bias, 0.0],
                        ls.depth_params,
                    ),
                    None => (Mat4::IDENTITY, [0.0; 4], [0.0; 4], [0.0; 4]),
                };
                let [r, g, b] = l.color();
                GpuLight {
                    vector: vector.to_array(),
                    color: [r, g, b, 0.0],
                    view_proj: view_proj.to_cols_array(),
                    layer_ends,
                    map,
                    depth,
                }
            })
            .collect()
    }

    /// Deep opacity maps of every shadow-casting light over the world bounds of every
    /// character and occluder.
    fn render_shadow_maps(&self, ctx: &Context, pipes: &ShadowPipelines) -> Result<ShadowAtlas, RenderError> {
        let s = &self.scene.scene;
        let lights = self.scene.lights();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let mut add_box = |m: Mat4, bounds: (Vec3, Vec3)| {
            let (a, b) = transformed_box(m, bounds);
            lo = lo.min(a);
            hi = hi.max(b);
        };
        for c in &self.characters {
            for b in &self.hairs[c.hair].asset.bundles {
                add_box(c.transform, (b.bounds_min.as_vec3(), b.bounds_max.as_vec3()));
            }
        }
        for c in &self.stored_characters {
            add_box(c.transform, self.stored[c.hair].bounds);
        }
        for o in &self.occluders {
            add_box(o.transform, self.meshes[o.mesh].bounds);
        }
        let generated: Vec<(usize, Mat4)> = self.characters.iter().map(|c| (c.hair, c.transform)).collect();
        let stored: Vec<(usize, Mat4)> =
            self.stored_characters.iter().map(|c| (c.hair, c.transform)).collect();
        let occluders: Vec<(usize, Mat4)> = self.occluders.iter().map(|o| (o.mesh, o.transform)).collect();
        let casters = crate::shadow::ShadowCasters {
            hairs: &self.hairs,
            generated: &generated,
            stored: &self.stored,
            stored_characters: &stored,
            meshes: &self.meshes,
            occluders: &occluders,
            occluder_pipelines: self.occluder_pipes.as_ref(),
        };
        let settings = crate::shadow::ShadowSettings {
            size: s.effects.shadow_map_size,
            layer_fractions: s.effects.shadow_layers,
            lod: self.view().lod,
        };
        let shadow_lights = self
            .scene
            .shadow_lights()
            .into_iter()
            .map(|i| {
                let light = match lights[i] {
                    Light::Directional { direction, .. } => {
                        ShadowLight::Directional(Vec3::from_array(direction))
                    }
                    Light::Point { position, .. } => ShadowLight::Point(Vec3::from_array(position)),
                };
                let view = LightView::new(light, (lo, hi)).map_err(|message| RenderError::Light {
                    path: self.scene.path.clone(),
                    light: i,
                    message,
                })?;
                Ok((light, view))
            })
            .collect::<Result<Vec<_>, RenderError>>()?;
        Ok(crate::shadow::render_shadow_maps(ctx, pipes, &casters, &shadow_lights, settings)?)
    }

    /// `raster hair (compute, opaque)` / `(…, blended)`.
    fn raster_pass_name(&self) -> String {
        let mode = if self.depth_prepass.is_some() { "blended" } else { "opaque" };
        format!("raster hair ({}, {mode})", self.path)
    }

    /// Whether one of `c`'s strands can be a pixel wide in `view`: its widest strand at the
    /// nearest point of its bounds (conservative; strand LOD widening does not count, as the
    /// prepass tests each real strand's coverage). Blended mode's depth prepass draws only
    /// such characters — in a crowd, the far ones have no fragment that could write depth.
    fn may_cover_pixels(&self, c: &SceneCharacter, view: &CrowdView) -> bool {
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

    /// Draws `batch`'s generated characters, then the stored ones, with `generator`'s fragment
    /// stage.
    fn draw_characters<'b>(
        &self,
        rec: &mut gen_gpu::Recorder<'_>,
        generator: &Generator,
        batch: impl IntoIterator<Item = &'b (usize, gen_gpu::FrameBuffers)>,
        stored_params: &[Buffer],
        extra: &[(u32, &Buffer)],
        eye: Vec3,
    ) -> gen_gpu::Result<()> {
        for (i, frame) in batch {
            let c = &self.characters[*i];
            let shading = self.shading(c, eye);
            let extras = DrawExtras { fragment_constants: bytemuck::bytes_of(&shading), buffers: extra };
            generator.record_draw_with(rec, &self.hairs[c.hair], frame, self.path, false, extras)?;
        }
        self.draw_stored(rec, generator, stored_params, extra, eye);
        Ok(())
    }

    /// Draws the explicit-strand characters with `generator`'s fragment stage.
    fn draw_stored(
        &self,
        rec: &mut gen_gpu::Recorder<'_>,
        generator: &Generator,
        params: &[Buffer],
        extra: &[(u32, &Buffer)],
        eye: Vec3,
    ) {
        for (c, params) in self.stored_characters.iter().zip(params) {
            let shading = self.shading(c, eye);
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
        self.render_camera(ctx, eye, Vec3::from_array(self.scene.scene.camera.target))
    }

    /// Renders one frame from a camera at `eye` looking at `target` (e.g. a point of the
    /// scene's camera path, [`LoadedScene::camera_at`]).
    pub fn render_camera(
        &self,
        ctx: &Context,
        eye: Vec3,
        target: Vec3,
    ) -> Result<RenderedFrame, RenderError> {
        let view = self.view_from(eye, target);
        let graph = self.graph();
        let mut recorded = Vec::new();
        // Shadow maps: computed on the first frame, then reused (static characters and lights).
        let mut shadow_cached = false;
        let mut shadow_ms = None;
        let shadow_guard = match &self.shadow {
            Some((pipes, cache)) => {
                let mut guard = cache.lock().unwrap_or_else(|e| e.into_inner());
                if guard.is_some() {
                    shadow_cached = true;
                } else {
                    let atlas = self.render_shadow_maps(ctx, pipes)?;
                    // The submission is the root scope; its children are the passes.
                    shadow_ms = atlas.timings.pass_ms("shadow maps");
                    recorded
                        .extend(atlas.timings.passes.iter().filter(|p| p.depth == 1).map(|p| p.name.clone()));
                    *guard = Some(atlas);
                }
                Some(guard)
            }
            None => None,
        };
        let atlas = shadow_guard.as_ref().and_then(|g| g.as_ref());
        let light_data = self.light_data(atlas);
        let light_bytes: &[u8] = bytemuck::cast_slice(&light_data);
        let lights = ctx.create_buffer_with_data(
            "scene lights",
            BufferDesc::storage(light_bytes.len() as u64),
            light_bytes,
        )?;
        let lighting: [(u32, &Buffer); 4] = match atlas {
            Some(a) => [(15, &a.depth), (16, &a.opacity), (17, &lights), (18, &a.occluder_depth)],
            None => {
                [(15, &self.no_shadow[0]), (16, &self.no_shadow[1]), (17, &lights), (18, &self.no_shadow[2])]
            }
        };
        let characters: Vec<Character> =
            self.characters.iter().map(|c| Character { hair: c.hair, transform: c.transform }).collect();
        let inputs: Vec<gen_gpu::FrameInputs> = characters
            .iter()
            .map(|c| character_inputs(&view.camera, c, view.width, view.height, view.lod))
            .collect();
        // Characters are generated and drawn in batches whose strand buffers fit
        // `BATCH_BYTES`, so a crowd never holds every character's strands at once.
        let mut batches: Vec<Vec<usize>> = vec![Vec::new()];
        let mut batch_bytes = 0;
        for (i, (c, inputs)) in characters.iter().zip(&inputs).enumerate() {
            let bytes = Generator::frame_bytes(&self.hairs[c.hair], inputs);
            if batch_bytes + bytes > self.batch_bytes && batches.last().is_some_and(|b| !b.is_empty()) {
                batches.push(Vec::new());
                batch_bytes = 0;
            }
            batch_bytes += bytes;
            if let Some(b) = batches.last_mut() {
                b.push(i);
            }
        }
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
        let samples = if self.oit.is_some() { 1 } else { self.scene.scene.effects.msaa };
        let target = SceneTarget::new(ctx, view.width, view.height, samples)?;
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
        let view_proj = crate::crowd::view_proj(&view.camera, view.width, view.height);
        let background = self.scene.scene.output.background;
        let mut timings = FrameTimings::default();
        let mut stats = GenerationStats::default();
        stats.strands += self.stored_characters.iter().map(|c| self.stored[c.hair].strands).sum::<u64>();
        let batch_count = batches.len();
        for (k, batch) in batches.iter().enumerate() {
            let (first, last) = (k == 0, k + 1 == batch_count);
            let frames = batch
                .iter()
                .map(|&i| Ok((i, self.generator.prepare(ctx, &self.hairs[characters[i].hair], &inputs[i])?)))
                .collect::<gen_gpu::Result<Vec<_>>>()?;
            let no_stored: &[Buffer] = &[];
            // Explicit strands are drawn with the last batch.
            let stored = if last { &stored_params[..] } else { no_stored };
            let ((), batch_timings) = ctx.submit("scene frame", |rec| {
                for (i, frame) in &frames {
                    let hair = &self.hairs[characters[*i].hair];
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
                if let (true, Some((heads, _, counters, pool))) = (first, &oit_buffers) {
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
                }
                if first {
                    target.begin(rec, background);
                } else {
                    target.begin_load(rec);
                }
                if let (true, Some(pipes)) = (first, &self.occluder_pipes) {
                    rec.pass("occluders", |rec| {
                        let light_count = self.scene.lights().len();
                        for o in &self.occluders {
                            let push =
                                occluder_push(o.transform, view_proj, view.camera.eye, light_count, o.color);
                            self.meshes[o.mesh].record_draw(rec, &pipes.shade, &push, &lighting);
                        }
                    });
                    recorded.push("occluders".to_owned());
                }
                let drawn = match (&self.oit, &oit_buffers) {
                    (Some(oit), Some((heads, nodes, counters, _))) => {
                        let fill = format!("raster hair ({}, OIT fill)", self.path);
                        let extra = [
                            (12, heads),
                            (13, nodes),
                            (14, counters),
                            lighting[0],
                            lighting[1],
                            lighting[2],
                            lighting[3],
                        ];
                        let drawn = rec.pass(&fill, |rec| {
                            let eye = view.camera.eye;
                            self.draw_characters(rec, &oit.fill, &frames, stored, &extra, eye)
                        });
                        recorded.push(fill);
                        rec.end_rendering();
                        if last {
                            rec.memory_barrier(
                                (
                                    vk::PipelineStageFlags2::FRAGMENT_SHADER,
                                    vk::AccessFlags2::SHADER_STORAGE_WRITE,
                                ),
                                (
                                    vk::PipelineStageFlags2::FRAGMENT_SHADER,
                                    vk::AccessFlags2::SHADER_STORAGE_READ,
                                ),
                            );
                            rec.pass("OIT resolve", |rec| {
                                target.begin_load(rec);
                                rec.bind_pipeline(&oit.resolve);
                                rec.push_storage_buffers(&oit.resolve, &extra[..3]);
                                rec.push_constants(&oit.resolve, &oit.k);
                                rec.draw(3, 1);
                                rec.end_rendering();
                            });
                            recorded.push("OIT resolve".to_owned());
                        }
                        drawn
                    }
                    _ => {
                        let prepass = match &self.depth_prepass {
                            Some(generator) => {
                                let name = format!("hair depth prepass ({}, solid fragments)", self.path);
                                let drawn = rec.pass(&name, |rec| {
                                    let eye = view.camera.eye;
                                    let solid = frames
                                        .iter()
                                        .filter(|(i, _)| self.may_cover_pixels(&self.characters[*i], &view));
                                    self.draw_characters(rec, generator, solid, stored, &[], eye)
                                });
                                recorded.push(name);
                                drawn
                            }
                            None => Ok(()),
                        };
                        let raster = self.raster_pass_name();
                        let drawn = rec.pass(&raster, |rec| {
                            self.draw_characters(
                                rec,
                                &self.generator,
                                &frames,
                                stored,
                                &lighting,
                                view.camera.eye,
                            )
                        });
                        recorded.push(raster);
                        rec.end_rendering();
                        prepass.and(drawn)
                    }
                };
                if last {
                    rec.pass("copy out", |rec| target.copy_out(rec));
                    recorded.push("copy out".into());
                }
                drawn
            })?;
            timings.passes.extend(batch_timings.passes);
            timings.cpu_wait_ms += batch_timings.cpu_wait_ms;
            for (i, frame) in &frames {
                stats += self.generator.stats(ctx, &self.hairs[characters[*i].hair], frame)?;
            }
        }
        if !shadow_cached && batch_count == 1 {
            debug_assert_eq!(recorded, graph.passes.iter().map(|p| p.name.clone()).collect::<Vec<_>>());
        }
        let (oit_overflow, oit_pool) = match &oit_buffers {
            Some((_, _, counters, pool)) => {
                let c: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(counters, 16)?);
                (Some(u64::from(c[2])), Some(*pool))
            }
            None => (None, None),
        };
        let linear = target.read(ctx)?;
        Ok(RenderedFrame {
            image: linear.to_srgb8(),
            linear,
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

/// The axis-aligned box around `bounds` (a box) transformed by `m`.
fn transformed_box(m: Mat4, (a, b): (Vec3, Vec3)) -> (Vec3, Vec3) {
    (0..8).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), k| {
        let corner = Vec3::new(
            if k & 1 == 0 { a.x } else { b.x },
            if k & 2 == 0 { a.y } else { b.y },
            if k & 4 == 0 { a.z } else { b.z },
        );
        let p = m.transform_point3(corner);
        (lo.min(p), hi.max(p))
    })
}
