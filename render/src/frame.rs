//! Rendering a scene: the frame graph built from the scene's effects, hair uploaded once per
//! asset and style, strands generated on the fly every frame, shaded by `hair.frag`.

use std::collections::HashMap;
use std::fmt;

use gen_gpu::diagnostics::RenderTarget;
use gen_gpu::{
    Context, FragmentStage, FrameTimings, GenerationPath, GenerationStats, Generator, GeneratorOptions,
    GpuHair, TexturePrecision,
};
use glam::{Mat4, Vec3, Vec4};
use hairmesh::reference::LodParams;

use crate::RgbaImage;
use crate::crowd::{Camera, Character, CrowdView, character_inputs};
use crate::scene::{Light, LoadedScene, SceneError, merged_style};

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
    hairs: Vec<GpuHair>,
    characters: Vec<SceneCharacter>,
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
}

impl SceneRenderer {
    pub fn new(ctx: &Context, scene: &LoadedScene, path: GenerationPath) -> Result<Self, RenderError> {
        let generator = Generator::with_options(
            ctx,
            GeneratorOptions {
                fragment: Some(FragmentStage {
                    shader: &shaders::HAIR_FRAG,
                    push_constant_bytes: size_of::<Shading>() as u32,
                    blend: true,
                }),
                ..GeneratorOptions::default()
            },
        )?;
        // One upload per (asset, style): characters sharing both share the GPU hair.
        let mut keys: HashMap<(std::path::PathBuf, String), usize> = HashMap::new();
        let mut hairs = Vec::new();
        let mut characters = Vec::new();
        for (i, c) in scene.scene.characters.iter().enumerate() {
            let path = scene.hair_path(c);
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
        Ok(Self { generator, hairs, characters, scene: scene.clone(), path })
    }

    fn view(&self) -> CrowdView {
        let s = &self.scene.scene;
        CrowdView {
            camera: Camera {
                eye: Vec3::from_array(s.camera.eye),
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
        reads.push("lights".into());
        passes.push(PassNode {
            name: format!("raster hair ({}, opaque)", self.path),
            reads,
            writes: vec!["colour".into(), "depth".into()],
        });
        passes.push(PassNode {
            name: "copy out".into(),
            reads: vec!["colour".into()],
            writes: vec!["image".into()],
        });
        FrameGraph { passes }
    }

    fn shading(&self, c: &SceneCharacter) -> Shading {
        let s = &self.scene.scene;
        let to_object = c.transform.inverse();
        let eye = to_object.transform_point3(Vec3::from_array(s.camera.eye));
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
        }
    }

    /// Renders one frame.
    pub fn render(&self, ctx: &Context) -> Result<RenderedFrame, RenderError> {
        let view = self.view();
        let graph = self.graph();
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
        let target = RenderTarget::new(ctx, view.width, view.height)?;
        let mut recorded = Vec::new();
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
            target.begin(rec);
            let raster = format!("raster hair ({}, opaque)", self.path);
            let drawn = rec.pass(&raster, |rec| {
                self.characters.iter().zip(&frames).try_for_each(|(c, frame)| {
                    let shading = self.shading(c);
                    self.generator.record_draw_with(
                        rec,
                        &self.hairs[c.hair],
                        frame,
                        self.path,
                        false,
                        bytemuck::bytes_of(&shading),
                    )
                })
            });
            recorded.push(raster);
            rec.end_rendering();
            rec.pass("copy out", |rec| target.copy_out(rec));
            recorded.push("copy out".into());
            drawn
        })?;
        debug_assert_eq!(recorded, graph.passes.iter().map(|p| p.name.clone()).collect::<Vec<_>>());
        let mut stats = GenerationStats::default();
        for (c, frame) in characters.iter().zip(&frames) {
            let s = self.generator.stats(ctx, &self.hairs[c.hair], frame)?;
            stats.bundles += s.bundles;
            stats.bundles_culled += s.bundles_culled;
            stats.strands += s.strands;
            stats.vertices += s.vertices;
        }
        Ok(RenderedFrame { image: target.read(ctx)?, timings, stats, passes: recorded })
    }
}
