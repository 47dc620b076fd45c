//! Scene files (JSON): camera, lights, characters, output, and the effects to compute.
//!
//! ```json
//! {
//!   "output": { "width": 640, "height": 360 },
//!   "camera": { "eye": [0, 1.8, 1.2], "target": [0, 1.55, 0], "fov_y_degrees": 45 },
//!   "lights": [ { "directional": { "direction": [0.4, 0.8, 0.5], "color": [1, 1, 1] } } ],
//!   "characters": [ { "hair": "hair/head_cap_long", "transform": { "translation": [0, 0, 0] },
//!                     "color": [0.073, 0.027, 0.01], "style": { "curl": { "radius": 0.003 } } } ],
//!   "effects": { "transparency": "opaque", "shadows": false },
//!   "lod": "auto"
//! }
//! ```
//!
//! Unknown fields are errors, reported with line and column. Paths are relative to the scene
//! file. Every number is checked (finite, in range) and errors name the file and the field.
//! `effects.transparency` is `"opaque"` (coverage-scaled strands blended in draw order, every
//! fragment writing depth), `"blended"` (only strands at least a pixel wide write depth, in a
//! depth prepass; thinner ones blend without hiding what is behind them: for crowds and distant
//! hair) or `"oit"` (per-pixel linked lists with a k-buffer resolve, `oit_k` sorted, pool of
//! `oit_nodes_per_pixel` nodes per pixel on average); opaque and blended modes may add MSAA
//! (`msaa`: 2, 4, 8).
//! `effects.raster` picks the rasterizer: `"auto"` (default: the compute rasterizer on CPU
//! devices when it can draw the scene's effects, else triangles), `"triangles"` (camera-facing
//! strips through the triangle pipeline; every effect) or `"compute"` (`render::raster`:
//! opaque and blended transparency without MSAA so far; other combinations are refused).
//! `shadows` adds deep opacity maps and occluder depth maps for every light with `cast_shadows`
//! (default true; orthographic for directional lights, perspective for point lights, which must
//! lie outside the casters; `shadow_map_size`, `shadow_layers`). A character may carry an
//! `occluder` mesh (its scalp or body, `{"mesh": "head.obj", "color": [..]}`), drawn opaque with
//! Lambert shading, casting and receiving shadows. Colours are linear; `output.background` is
//! the clear colour. `ao` darkens hair by the hair around it (`ao_radius`, a fraction of the
//! hair's size); `volume_shadows` shadows it by its own density volume; `volume_lod`
//! raymarches characters at most `volume_lod_pixels` on screen through their density volume
//! instead of drawing their strands (needs the compute rasterizer); `volume_resolution` bounds
//! the volumes (`render::volume`). `dynamics` simulates the hair meshes of the characters with
//! a `dynamics` block (`crate::animation`; needs `"animation": {"frames": N, "fps": R}`), and a
//! character's `motion` moves its head (keys and swings about a pivot). `lod` is `"auto"` or
//! explicit α ([`LodDesc`]). Effects that are not
//! built yet (shadows from a point light inside the casters) are refused with a clear "not
//! supported yet".
//!
//! The schema's parts: `effects` (what the renderer computes), `lod`, `motion` (animation and
//! head motion), `validate` (the checks after parsing); the rest, and loading, is here.

mod effects;
mod lod;
mod motion;
mod validate;

use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

pub use effects::{Effects, Raster, Transparency};
pub use lod::{AUTO_LOD_FLIP, AUTO_VOLUME_PIXELS, LodDesc};
pub use motion::{AnimationDesc, MAX_FRAMES, MotionDesc, MotionKey, Swing};
use validate::{validate, validate_with};

/// Largest output side accepted (the GPU's 2D image limit is checked too).
pub const MAX_OUTPUT_SIDE: u32 = 8192;
/// Most characters in one scene.
pub const MAX_CHARACTERS: usize = 4096;
/// Most lights in one scene.
pub const MAX_LIGHTS: usize = crate::contract::MAX_LIGHTS as usize;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    /// `message` starts with the line and column ([`hairmesh::input::json_error`]).
    #[error("{path}: {message}")]
    Syntax { path: PathBuf, line: usize, column: usize, message: String },
    #[error("{path}: {field}: {message}")]
    Invalid { path: PathBuf, field: String, message: String },
    #[error("{path}: {field}: {effect} is not supported yet")]
    NotSupportedYet { path: PathBuf, field: String, effect: String },
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Output {
    pub width: u32,
    pub height: u32,
    /// Background colour (linear RGB); the written alpha is 0 there (EXR keeps it).
    #[serde(default = "default_background")]
    pub background: [f32; 3],
}

fn default_background() -> [f32; 3] {
    [0.004, 0.005, 0.008]
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "default_fov")]
    pub fov_y_degrees: f32,
}

fn default_fov() -> f32 {
    45.0
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum Light {
    Directional {
        /// Toward the light.
        direction: [f32; 3],
        #[serde(default = "white")]
        color: [f32; 3],
        /// With `effects.shadows`: this light gets deep opacity maps [default: true].
        #[serde(default = "yes")]
        cast_shadows: bool,
    },
    Point {
        position: [f32; 3],
        #[serde(default = "white")]
        color: [f32; 3],
        /// With `effects.shadows`: this light gets deep opacity maps, seen in perspective from
        /// the light, which must then lie outside the casters' bounds [default: true].
        #[serde(default = "yes")]
        cast_shadows: bool,
    },
}

fn yes() -> bool {
    true
}

impl Light {
    /// The light shading uses when a scene lists none.
    pub const DEFAULT: Light =
        Light::Directional { direction: [0.4, 0.8, 0.5], color: [1.0, 1.0, 1.0], cast_shadows: true };

    pub fn color(&self) -> [f32; 3] {
        match *self {
            Light::Directional { color, .. } | Light::Point { color, .. } => color,
        }
    }
}

fn white() -> [f32; 3] {
    [1.0, 1.0, 1.0]
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct TransformDesc {
    pub translation: [f32; 3],
    pub rotation_y_degrees: f32,
    pub scale: Option<f32>,
}

impl TransformDesc {
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(
            Vec3::splat(self.scale.unwrap_or(1.0)),
            Quat::from_rotation_y(self.rotation_y_degrees.to_radians()),
            Vec3::from_array(self.translation),
        )
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CharacterDesc {
    /// A hair asset folder (or its hair.json), or an explicit strand file (`.tfx` TressFX 3/4,
    /// `.hair`), relative to the scene file.
    pub hair: PathBuf,
    #[serde(default)]
    pub transform: TransformDesc,
    /// Base hair colour (linear RGB).
    #[serde(default = "brown")]
    pub color: [f32; 3],
    /// Per-strand colour variation (0 = none).
    #[serde(default = "default_variation")]
    pub color_variation: f32,
    /// Fields of `hairmesh::style::Style` that replace the asset's (hair assets only).
    #[serde(default)]
    pub style: Option<serde_json::Value>,
    /// Root width of explicit strands (`.tfx`, `.hair`) in the file's units [default: 1/2000
    /// of the strands' bounding-box diagonal].
    #[serde(default)]
    pub strand_width: Option<f32>,
    /// A mesh drawn opaque with the hair (the scalp or the body), in the hair's object space.
    #[serde(default)]
    pub occluder: Option<OccluderDesc>,
    /// The head's motion over the animation ([`MotionDesc`]): the hair, its roots and the
    /// occluder move with it; without `dynamics` the hair moves rigidly.
    #[serde(default)]
    pub motion: Option<MotionDesc>,
    /// Simulates this character's hair mesh (needs `effects.dynamics` and an `animation`):
    /// parameters of `hairmesh::dynamics::DynamicsParams`, `{}` for the defaults.
    #[serde(default)]
    pub dynamics: Option<hairmesh::dynamics::DynamicsParams>,
}

/// A character's occluder mesh: glTF/GLB or OBJ, every face, relative to the scene file.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OccluderDesc {
    pub mesh: PathBuf,
    /// Places the mesh in the character's object space (then the character's transform
    /// applies), for meshes modelled in other units or frames than the hair.
    #[serde(default)]
    pub transform: TransformDesc,
    /// Albedo (linear RGB).
    #[serde(default = "skin")]
    pub color: [f32; 3],
}

fn skin() -> [f32; 3] {
    [0.3, 0.19, 0.14]
}

/// A character's hair colour when the scene names none (linear RGB, a mid brown).
pub const DEFAULT_HAIR_COLOR: [f32; 3] = [0.073, 0.024, 0.007];
/// Per-strand colour variation when the scene names none.
pub const DEFAULT_COLOR_VARIATION: f32 = 0.3;

fn brown() -> [f32; 3] {
    DEFAULT_HAIR_COLOR
}

fn default_variation() -> f32 {
    DEFAULT_COLOR_VARIATION
}

/// One key of a camera path.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraKey {
    pub eye: [f32; 3],
    pub target: [f32; 3],
}

/// A scene as written in its file.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub output: Output,
    pub camera: CameraDesc,
    /// Keys a camera moves through (Catmull-Rom), for `hair-render --frames N` and the crowd
    /// benchmarks; the `camera` field's field of view applies.
    #[serde(default)]
    pub camera_path: Vec<CameraKey>,
    #[serde(default)]
    pub lights: Vec<Light>,
    pub characters: Vec<CharacterDesc>,
    #[serde(default)]
    pub effects: Effects,
    #[serde(default)]
    pub lod: LodDesc,
    /// The animation's length and rate: needed for head motion, dynamics and frame ranges.
    #[serde(default)]
    pub animation: Option<AnimationDesc>,
}

/// A scene with its file's folder, for resolving paths.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    pub path: PathBuf,
    pub scene: Scene,
}

impl LoadedScene {
    /// A character's hair path, resolved against the scene file's folder.
    pub fn hair_path(&self, character: &CharacterDesc) -> PathBuf {
        self.resolve(&character.hair)
    }

    /// A path of the scene file, resolved against its folder.
    pub fn resolve(&self, path: &Path) -> PathBuf {
        self.path.parent().unwrap_or(Path::new(".")).join(path)
    }

    /// The scene file and every file or folder it refers to: what an output must never replace.
    pub fn input_files(&self) -> Vec<PathBuf> {
        let characters = self.scene.characters.iter();
        std::iter::once(self.path.clone())
            .chain(characters.clone().map(|c| self.hair_path(c)))
            .chain(characters.filter_map(|c| c.occluder.as_ref()).map(|o| self.resolve(&o.mesh)))
            .collect()
    }

    /// The camera at `t` ∈ [0, 1] along the camera path (Catmull-Rom through the keys, uniform
    /// in key index); the scene's camera without a path.
    pub fn camera_at(&self, t: f32) -> (Vec3, Vec3) {
        let keys = &self.scene.camera_path;
        let c = &self.scene.camera;
        if keys.len() < 2 {
            return (Vec3::from_array(c.eye), Vec3::from_array(c.target));
        }
        let segments = (keys.len() - 1) as f32;
        let x = t.clamp(0.0, 1.0) * segments;
        let i = (x.floor() as usize).min(keys.len() - 2);
        let f = x - i as f32;
        let key = |k: isize| keys[k.clamp(0, keys.len() as isize - 1) as usize];
        let spline = |get: fn(&CameraKey) -> [f32; 3]| {
            let [p0, p1, p2, p3] = [-1, 0, 1, 2].map(|o| Vec3::from_array(get(&key(i as isize + o))));
            // Uniform Catmull-Rom: passes through every key.
            0.5 * ((2.0 * p1)
                + (p2 - p0) * f
                + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * f * f
                + (3.0 * p1 - p0 - 3.0 * p2 + p3) * f * f * f)
        };
        (spline(|k| k.eye), spline(|k| k.target))
    }

    /// The camera of frame `frame` of an animation `length` frames long: along the camera path
    /// (its start at frame 0, its end at the last frame); without a path, the scene's camera,
    /// orbiting its target once over the length when the scene has no `animation` (the
    /// turntable of `hair-render --frames N`) and fixed when it has one.
    pub fn frame_camera(&self, frame: u32, length: u32) -> (Vec3, Vec3) {
        let c = &self.scene.camera;
        let (eye, target) = (Vec3::from_array(c.eye), Vec3::from_array(c.target));
        if !self.scene.camera_path.is_empty() {
            return self.camera_at(frame as f32 / (length.max(2) - 1) as f32);
        }
        if self.scene.animation.is_some() {
            return (eye, target);
        }
        let angle = std::f32::consts::TAU * frame as f32 / length.max(1) as f32;
        (target + Quat::from_rotation_y(angle) * (eye - target), target)
    }

    /// The lights shading uses (the default one when the scene lists none).
    pub fn lights(&self) -> &[Light] {
        const DEFAULT_LIGHTS: &[Light] = &[Light::DEFAULT];
        if self.scene.lights.is_empty() { DEFAULT_LIGHTS } else { &self.scene.lights }
    }

    /// Indices into [`Self::lights`] of the lights that get shadow maps (none without
    /// `effects.shadows`).
    pub fn shadow_lights(&self) -> Vec<usize> {
        if !self.scene.effects.shadows {
            return Vec::new();
        }
        self.lights()
            .iter()
            .enumerate()
            .filter(|(_, l)| {
                matches!(
                    l,
                    Light::Directional { cast_shadows: true, .. } | Light::Point { cast_shadows: true, .. }
                )
            })
            .map(|(i, _)| i)
            .collect()
    }
}

impl LoadedScene {
    /// Checks every field (what [`load_scene`] does): for scenes changed in memory, e.g. by a
    /// command's `--raster` override.
    pub fn validate(&self) -> Result<(), SceneError> {
        validate(self)
    }

    /// Checks every field but the character list (output, camera, lights, LOD, effects): for
    /// the settings of a [`crate::instance::SceneInstance`] whose characters are in memory.
    pub fn validate_settings(&self) -> Result<(), SceneError> {
        validate_with(self, false)
    }
}

/// How an earlier scene file is recognized before one is written over it
/// ([`hairmesh::output`]).
pub const SCENE_FILE: hairmesh::output::FileKind = hairmesh::output::FileKind::Json {
    what: "hairkit scene file",
    keys: &["output", "camera", "characters"],
};

/// Largest scene file read.
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// Reads, parses and validates a scene file.
pub fn load_scene(path: &Path) -> Result<LoadedScene, SceneError> {
    let io = |e: std::io::Error| SceneError::Io { path: path.to_owned(), message: e.to_string() };
    let bytes = hairmesh::input::read_regular(path, MAX_SCENE_BYTES).map_err(io)?;
    let scene: Scene = serde_json::from_slice(&bytes).map_err(|e| SceneError::Syntax {
        path: path.to_owned(),
        line: e.line(),
        column: e.column(),
        message: hairmesh::input::json_error(&e),
    })?;
    let loaded = LoadedScene { path: path.to_owned(), scene };
    validate(&loaded)?;
    Ok(loaded)
}

/// The asset's style with the character's overrides applied (unknown fields are errors).
pub fn merged_style(
    scene_path: &Path,
    index: usize,
    base: &hairmesh::style::Style,
    overrides: Option<&serde_json::Value>,
) -> Result<hairmesh::style::Style, SceneError> {
    let Some(overrides) = overrides else { return Ok(*base) };
    let invalid = |message: String| SceneError::Invalid {
        path: scene_path.to_owned(),
        field: format!("characters[{index}].style"),
        message,
    };
    let mut value = serde_json::to_value(base).map_err(|e| invalid(e.to_string()))?;
    merge(&mut value, overrides);
    let style: hairmesh::style::Style = serde_json::from_value(value).map_err(|e| invalid(e.to_string()))?;
    style.validate().map_err(invalid)?;
    Ok(style)
}

fn merge(base: &mut serde_json::Value, overrides: &serde_json::Value) {
    match (base, overrides) {
        (serde_json::Value::Object(b), serde_json::Value::Object(o)) => {
            for (k, v) in o {
                match b.get_mut(k) {
                    Some(existing) => merge(existing, v),
                    None => {
                        b.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (b, o) => *b = o.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::LodDesc;

    #[test]
    fn lod_reads_auto_or_explicit_settings_and_writes_them_back() {
        let auto: LodDesc = serde_json::from_str("\"auto\"").expect("auto");
        assert_eq!(auto, LodDesc::AUTO);
        assert_eq!(serde_json::to_string(&auto).expect("write"), "\"auto\"");
        let explicit: LodDesc = serde_json::from_str(r#"{"strand_alpha": 4}"#).expect("explicit");
        assert_eq!(explicit, LodDesc { strand_alpha: 4.0, ..LodDesc::default() });
        assert!(!explicit.auto);
        let again: LodDesc =
            serde_json::from_str(&serde_json::to_string(&explicit).expect("write")).expect("read");
        assert_eq!(again, explicit);
        // The automatic values written out explicitly are explicit settings (no volumes).
        let spelled = LodDesc { auto: false, ..LodDesc::AUTO };
        let read: LodDesc =
            serde_json::from_str(&serde_json::to_string(&spelled).expect("write")).expect("read");
        assert_eq!(read, spelled);
        for (bad, says) in [
            ("\"fast\"", "expected \"auto\" or an object"),
            (r#"{"strand_alfa": 2}"#, "unknown field `strand_alfa`"),
            ("3", "expected \"auto\" or an object"),
        ] {
            let e = serde_json::from_str::<LodDesc>(bad).expect_err(bad).to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }
}
