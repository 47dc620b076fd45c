//! Scene instances: a scene's settings with its characters' data in memory, apart from files.
//!
//! Rendering a scene takes three steps, each its own: **load** ([`SceneInstance::load`] reads
//! every asset, strand file and occluder mesh a scene file names, and is the only step that
//! touches the disk), **set up** ([`crate::frame::SceneRenderer::from_instance`] uploads them)
//! and **record** (`render_camera`, per frame). An application that makes its hair in memory —
//! an editor, a simulation — builds a [`SceneInstance`] directly with [`SceneInstance::new`]
//! and skips the first step.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use render::instance::{CharacterInstance, SceneInstance};
//! # let ctx: gen_gpu::Context = todo!();
//! # let asset: hairmesh::asset::HairAsset = todo!();
//! let settings = render::scene::load_scene(std::path::Path::new("assets/scenes/one_character.json"))?;
//! let mut instance = SceneInstance::new(settings);
//! instance.characters.push(CharacterInstance::generated("my hair", asset));
//! let renderer = render::frame::SceneRenderer::from_instance(&ctx, &instance, gen_gpu::GenerationPath::Compute)?;
//! let frame = renderer.render(&ctx)?;
//! # Ok(()) }
//! ```

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use glam::Mat4;
use hairmesh::asset::HairAsset;
use hairmesh::strands::StrandSet;

use crate::RenderError;
use crate::occluder::OccluderGeometry;
use crate::scene::{LoadedScene, merged_style};

/// A character's hair: generated from a hair asset, or explicit strands.
#[derive(Clone, Debug)]
pub enum CharacterHair {
    /// A hair asset (its style already merged with the scene's overrides).
    Generated(Arc<HairAsset>),
    /// Explicit strands (TressFX, `.hair`) and their width in world units.
    Stored { strands: Arc<StrandSet>, width: f32 },
}

/// An occluder mesh placed under a character.
#[derive(Clone, Debug)]
pub struct OccluderInstance {
    /// Characters whose occluders share a key share one upload.
    pub key: String,
    pub geometry: Arc<OccluderGeometry>,
    /// Object → world (the character's transform times the occluder's own).
    pub transform: Mat4,
    pub color: [f32; 3],
}

/// One character of a scene instance.
#[derive(Clone, Debug)]
pub struct CharacterInstance {
    /// Characters with the same key share one GPU upload of their hair (same asset and style).
    pub key: String,
    pub hair: CharacterHair,
    /// Object → world.
    pub transform: Mat4,
    /// Linear RGB hair colour and its per-strand variation.
    pub color: [f32; 3],
    pub color_variation: f32,
    pub occluder: Option<OccluderInstance>,
}

impl CharacterInstance {
    /// A character with generated hair at the origin, in the scene's default colour.
    pub fn generated(key: impl Into<String>, asset: HairAsset) -> Self {
        Self {
            key: key.into(),
            hair: CharacterHair::Generated(Arc::new(asset)),
            transform: Mat4::IDENTITY,
            color: crate::scene::DEFAULT_HAIR_COLOR,
            color_variation: crate::scene::DEFAULT_COLOR_VARIATION,
            occluder: None,
        }
    }
}

/// A scene's settings (output, camera, lights, effects, LOD: the scene file's fields, and its
/// path for error messages) with the characters in memory.
#[derive(Clone, Debug)]
pub struct SceneInstance {
    pub settings: LoadedScene,
    pub characters: Vec<CharacterInstance>,
}

impl SceneInstance {
    /// Settings without characters (add them to [`Self::characters`]); the settings' own
    /// character list is not read.
    pub fn new(settings: LoadedScene) -> Self {
        Self { settings, characters: Vec::new() }
    }

    /// Reads every file the scene names: hair assets (with the scene's style overrides),
    /// strand files and occluder meshes, each once however many characters share it.
    pub fn load(scene: &LoadedScene) -> Result<Self, RenderError> {
        let mut assets: HashMap<(PathBuf, String), Arc<HairAsset>> = HashMap::new();
        let mut strand_files: HashMap<PathBuf, Arc<StrandSet>> = HashMap::new();
        let mut meshes: HashMap<PathBuf, Arc<OccluderGeometry>> = HashMap::new();
        let mut characters = Vec::with_capacity(scene.scene.characters.len());
        for (i, c) in scene.scene.characters.iter().enumerate() {
            let occluder = match &c.occluder {
                Some(o) => {
                    let mesh_path = scene.resolve(&o.mesh);
                    let geometry = match meshes.get(&mesh_path) {
                        Some(g) => g.clone(),
                        None => {
                            let g = Arc::new(OccluderGeometry::load(&mesh_path)?);
                            meshes.insert(mesh_path.clone(), g.clone());
                            g
                        }
                    };
                    Some(OccluderInstance {
                        key: mesh_path.display().to_string(),
                        geometry,
                        transform: c.transform.matrix() * o.transform.matrix(),
                        color: o.color,
                    })
                }
                None => None,
            };
            let path = scene.hair_path(c);
            let (key, hair) = if matches!(path.extension().and_then(|e| e.to_str()), Some("tfx" | "hair")) {
                let set = match strand_files.get(&path) {
                    Some(s) => s.clone(),
                    None => {
                        let set = hairmesh::strands::load_strands(&path)
                            .map_err(|source| RenderError::Asset { path: path.clone(), source })?;
                        let set = Arc::new(set);
                        strand_files.insert(path.clone(), set.clone());
                        set
                    }
                };
                let (lo, hi) = set.bounds().unwrap_or_default();
                let width = c.strand_width.unwrap_or((hi - lo).length() / 2000.0);
                // Stored strands are uploaded per character (their width is the character's).
                (format!("{} #{i}", path.display()), CharacterHair::Stored { strands: set, width })
            } else {
                let style_key = c.style.as_ref().map(|s| s.to_string()).unwrap_or_default();
                let key = (path.clone(), style_key);
                let asset = match assets.get(&key) {
                    Some(a) => a.clone(),
                    None => {
                        let (mut asset, _) = hairmesh::asset_io::read_asset(&path)
                            .map_err(|source| RenderError::Asset { path: path.clone(), source })?;
                        // Through set_style: the bundle bounds grow with the style's reach.
                        if c.style.is_some() {
                            asset.set_style(merged_style(&scene.path, i, &asset.style, c.style.as_ref())?);
                        }
                        let asset = Arc::new(asset);
                        assets.insert(key.clone(), asset.clone());
                        asset
                    }
                };
                (format!("{} {}", key.0.display(), key.1), CharacterHair::Generated(asset))
            };
            characters.push(CharacterInstance {
                key,
                hair,
                transform: c.transform.matrix(),
                color: c.color,
                color_variation: c.color_variation,
                occluder,
            });
        }
        Ok(Self { settings: scene.clone(), characters })
    }
}
