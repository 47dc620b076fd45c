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

use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

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

/// `"animation"`: how many frames the scene's animation has and how fast they play. Frame `f`
/// is time `f / fps`; camera paths and orbits span the whole animation, so any frame range
/// renders the frames a full run would.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AnimationDesc {
    pub frames: u32,
    #[serde(default = "default_fps")]
    pub fps: f32,
}

fn default_fps() -> f32 {
    24.0
}

/// Most frames an animation may have.
pub const MAX_FRAMES: u32 = 1_000_000;

/// A head's motion in the character's object space: keyframes and/or periodic swings, rotating
/// about `pivot` (the neck). The character is drawn at `transform × motion(t)`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotionDesc {
    /// The point the head turns about, in the character's object space.
    pub pivot: [f32; 3],
    /// Poses at times (seconds, increasing), interpolated by Catmull-Rom splines; held before
    /// the first and after the last.
    #[serde(default)]
    pub keys: Vec<MotionKey>,
    /// About the vertical (y) axis: looking left and right.
    #[serde(default)]
    pub turn: Option<Swing>,
    /// About the x axis: looking up and down.
    #[serde(default)]
    pub nod: Option<Swing>,
    /// About the z axis: head to the shoulder.
    #[serde(default)]
    pub tilt: Option<Swing>,
}

/// One pose of a [`MotionDesc`].
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotionKey {
    pub time: f32,
    /// Nod (x), turn (y) and tilt (z) in degrees, applied turn × nod × tilt.
    #[serde(default)]
    pub rotation_degrees: [f32; 3],
    #[serde(default)]
    pub translation: [f32; 3],
}

/// A periodic swing: `degrees · sin(2π (t / period + phase))`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Swing {
    pub degrees: f32,
    /// Seconds per full swing.
    pub period: f32,
    /// Fraction of a period the swing is ahead (0..1).
    #[serde(default)]
    pub phase: f32,
}

impl Swing {
    fn radians_at(&self, t: f64) -> f32 {
        let x = std::f64::consts::TAU * (t / f64::from(self.period) + f64::from(self.phase));
        (f64::from(self.degrees).to_radians() * x.sin()) as f32
    }
}

impl MotionDesc {
    /// Object → moved object at time `t` (seconds).
    pub fn at(&self, t: f64) -> Mat4 {
        let (mut rotation, translation) = self.keyed(t);
        for (swing, axis) in [(&self.nod, 0), (&self.turn, 1), (&self.tilt, 2)] {
            if let Some(s) = swing {
                rotation[axis] += s.radians_at(t);
            }
        }
        let r = Quat::from_rotation_y(rotation[1])
            * Quat::from_rotation_x(rotation[0])
            * Quat::from_rotation_z(rotation[2]);
        let pivot = Vec3::from_array(self.pivot);
        Mat4::from_translation(translation + pivot) * Mat4::from_quat(r) * Mat4::from_translation(-pivot)
    }

    /// The keys' rotation (radians) and translation at `t`.
    fn keyed(&self, t: f64) -> ([f32; 3], Vec3) {
        let keys = &self.keys;
        let value = |k: &MotionKey| {
            let r = k.rotation_degrees.map(f32::to_radians);
            [r[0], r[1], r[2], k.translation[0], k.translation[1], k.translation[2]]
        };
        let out = |v: [f32; 6]| ([v[0], v[1], v[2]], Vec3::new(v[3], v[4], v[5]));
        match keys.len() {
            0 => return ([0.0; 3], Vec3::ZERO),
            1 => return out(value(&keys[0])),
            _ => {}
        }
        let t = t as f32;
        if t <= keys[0].time {
            return out(value(&keys[0]));
        }
        let Some(i) = keys.windows(2).position(|w| t < w[1].time) else {
            return out(value(&keys[keys.len() - 1]));
        };
        // Cubic Hermite with Catmull-Rom tangents over non-uniform key times.
        let at = |j: isize| keys[j.clamp(0, keys.len() as isize - 1) as usize];
        let (k0, k1, k2, k3) = (at(i as isize - 1), keys[i], keys[i + 1], at(i as isize + 2));
        let span = k2.time - k1.time;
        let f = (t - k1.time) / span;
        let (v0, v1, v2, v3) = (value(&k0), value(&k1), value(&k2), value(&k3));
        let tangent = |a: &[f32; 6], b: &[f32; 6], ta: f32, tb: f32, c: usize| {
            if tb > ta { (b[c] - a[c]) / (tb - ta) * span } else { 0.0 }
        };
        let (h00, h10, h01, h11) = (
            2.0 * f * f * f - 3.0 * f * f + 1.0,
            f * f * f - 2.0 * f * f + f,
            -2.0 * f * f * f + 3.0 * f * f,
            f * f * f - f * f,
        );
        let v = std::array::from_fn(|c| {
            let m1 = tangent(&v0, &v2, k0.time, k2.time, c);
            let m2 = tangent(&v1, &v3, k1.time, k3.time, c);
            h00 * v1[c] + h10 * m1 + h01 * v2[c] + h11 * m2
        });
        out(v)
    }

    /// Checks every field; the error is (the field under `motion`, the message).
    fn validate(&self) -> Result<(), (String, String)> {
        if !self.pivot.iter().all(|x| x.is_finite()) {
            return Err(("pivot".into(), format!("{:?} is not finite", self.pivot)));
        }
        if self.keys.len() > 100_000 {
            return Err(("keys".into(), format!("{} keys (at most 100000)", self.keys.len())));
        }
        for (i, k) in self.keys.iter().enumerate() {
            let all = [k.time].into_iter().chain(k.rotation_degrees).chain(k.translation);
            if !all.into_iter().all(f32::is_finite) {
                return Err((format!("keys[{i}]"), "a value is not finite".into()));
            }
            if i > 0 && k.time <= self.keys[i - 1].time {
                return Err((format!("keys[{i}].time"), format!("{} (times must increase)", k.time)));
            }
        }
        for (name, s) in [("turn", &self.turn), ("nod", &self.nod), ("tilt", &self.tilt)] {
            if let Some(s) = s
                && !(s.degrees.is_finite()
                    && s.degrees.abs() <= 180.0
                    && s.period.is_finite()
                    && s.period > 0.0
                    && s.phase.is_finite())
            {
                return Err((
                    name.into(),
                    format!(
                        "degrees {}, period {}, phase {} (expected degrees within ±180, a period in seconds > 0, a finite phase)",
                        s.degrees, s.period, s.phase
                    ),
                ));
            }
        }
        Ok(())
    }
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

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Transparency {
    /// Every hair fragment writes depth, alpha = its coverage: the nearest drawn wins, and a
    /// sub-pixel strand hides the strands behind it. Cheapest; looks closest to `oit` when
    /// strands are about a pixel wide or wider (close-ups).
    #[default]
    Opaque,
    /// Only fragments of strands at least a pixel wide write depth (a depth prepass); thinner
    /// strands blend with their coverage in draw order and never hide the strands behind them,
    /// so sub-pixel hair keeps its density and strand LOD (fewer, wider strands) keeps its
    /// look. For distant characters and crowds; in close-ups of sub-pixel hair the draw order
    /// shows (bundles drawn later lie on top).
    Blended,
    /// Per-pixel linked lists with a k-buffer resolve: order-independent and the most accurate.
    Oit,
}

/// Which rasterizer draws the hair (`effects.raster`).
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Raster {
    /// The compute rasterizer on CPU devices (where the triangle pipeline is the bottleneck)
    /// when it can draw the scene's effects, the triangle raster otherwise.
    #[default]
    Auto,
    /// Camera-facing strips through the triangle pipeline: every effect, the reference.
    Triangles,
    /// The compute rasterizer ([`crate::raster`]): opaque and blended transparency (drawn
    /// alike) without MSAA so far, on devices with 64-bit buffer atomics.
    Compute,
}

impl std::str::FromStr for Raster {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "triangles" => Ok(Self::Triangles),
            "compute" => Ok(Self::Compute),
            other => Err(format!("unknown raster {other:?} (expected auto, triangles or compute)")),
        }
    }
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Effects {
    /// Which rasterizer draws the hair.
    pub raster: Raster,
    pub transparency: Transparency,
    /// OIT: fragments kept sorted per pixel (the rest blend order-independently), 1..=16.
    pub oit_k: u32,
    /// OIT: average list nodes per pixel the pool holds (capped at `frame::OIT_POOL_BYTES` where
    /// the shaders reach the pool through its device address, else by the storage-buffer range).
    pub oit_nodes_per_pixel: f32,
    /// Opaque mode: samples per pixel (1 = coverage AA only; 2, 4 or 8 add MSAA).
    pub msaa: u32,
    /// Deep opacity maps (and occluder depth maps) for every light with `cast_shadows`.
    pub shadows: bool,
    /// Shadow map resolution (texels per side).
    pub shadow_map_size: u32,
    /// Ends of the three opacity layers, as fractions of the light box's radius.
    pub shadow_layers: [f32; 3],
    /// Ambient occlusion from the hair's density volume ([`crate::volume`]): every strand and
    /// volume sample is darkened by the hair around it.
    pub ao: bool,
    /// AO: radius of the sphere whose hair occludes a point, as a fraction of the hair's
    /// largest extent.
    pub ao_radius: f32,
    /// Characters at most `volume_lod_pixels` on screen (the larger side of their hair's
    /// projected bounds) are raymarched through their density volume instead of rasterized
    /// strand by strand ([`crate::volume`]).
    pub volume_lod: bool,
    /// Hair shadowed by its own density volume (a march toward each light with `cast_shadows`)
    /// instead of the deep opacity maps' hair layers; with `shadows` the maps still give the
    /// occluders' shadows.
    pub volume_shadows: bool,
    /// Projected size (pixels: the larger side of the hair's projected bounds) at or below which
    /// a character is drawn as a volume, with a transition band up to 1.5 times it. Default 256:
    /// a head of long hair about 1 % of a 1280×720 frame, where the default largest grid (128)
    /// has a voxel per two pixels; never beyond twice the resolution the scene's volumes get
    /// (lowered when many hairs share them).
    pub volume_lod_pixels: f32,
    /// Largest volume resolution (voxels along the hair's longest side; a power of two): a
    /// volume's resolution follows its character's projected size up to this.
    pub volume_resolution: u32,
    /// Simulates the hair meshes of the characters with a `dynamics` block
    /// ([`hairmesh::dynamics`]); the others cost nothing.
    pub dynamics: bool,
}

impl Effects {
    /// Whether the scene needs hair volumes (`ao`, `volume_lod` or `volume_shadows`).
    pub fn uses_volumes(&self) -> bool {
        self.ao || self.volume_lod || self.volume_shadows
    }

    /// What the shading reads from a volume, as the shaders' flags: bit 0 AO, bit 1 volume
    /// shadows.
    pub fn volume_flags(&self) -> u32 {
        u32::from(self.ao) | (u32::from(self.volume_shadows) << 1)
    }
}

impl Default for Effects {
    fn default() -> Self {
        Self {
            raster: Raster::Auto,
            transparency: Transparency::Opaque,
            oit_k: 8,
            oit_nodes_per_pixel: 32.0,
            msaa: 1,
            shadows: false,
            shadow_map_size: 512,
            shadow_layers: [0.02, 0.06, 0.16],
            ao: false,
            ao_radius: 0.04,
            volume_lod: false,
            volume_lod_pixels: 256.0,
            volume_shadows: false,
            volume_resolution: 128,
            dynamics: false,
        }
    }
}

/// Level of detail: `"lod": "auto"`, or explicit settings
/// `{"enabled": true, "strand_alpha": 1, "vertex_alpha": 1, "vertex_error_pixels": 0}`.
///
/// Explicit settings apply the same α to every character (`hairmesh::reference` has the
/// formulas). `"auto"` is [`LodDesc::AUTO`]: strand and vertex LOD with the α and the
/// style-aware vertex error measured to keep a crowd within a mean FLIP of
/// [`AUTO_LOD_FLIP`] of its full-detail render (docs/benchmarks.md, "Crowds: LOD off vs on";
/// README, "Level of detail"), and, when
/// the hair goes through the compute rasterizer, the volume LOD path for characters at most
/// [`AUTO_VOLUME_PIXELS`] on screen (with its transition band), as if `volume_lod` were on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodDesc {
    pub enabled: bool,
    pub strand_alpha: f64,
    pub vertex_alpha: f64,
    /// Style-aware vertex LOD: the most a curl, wave or frizz may deviate from the drawn
    /// polyline, in pixels (`hairmesh::reference::LodParams::vertex_error_pixels`; 0: off).
    pub vertex_error_pixels: f64,
    /// Written as `"auto"`: also draws small characters as volumes on the compute rasterizer.
    pub auto: bool,
}

/// The image error `"lod": "auto"` is measured to stay within (mean FLIP against LOD off).
pub const AUTO_LOD_FLIP: f64 = 0.05;

/// `"lod": "auto"` raymarches characters at most this many pixels on screen (the larger side of
/// their hair's projected bounds; `effects.volume_lod_pixels` when the scene turns
/// `volume_lod` on itself): a crowd of larger volumes differs visibly from its strands
/// (measured on the 200 curly teapots of `hairkit crowd` at 1280×720 while choosing it, with
/// auto's strand and vertex LOD before the style rule's ramp: mean FLIP 0.032 with strands
/// only, 0.036 raymarching the teapots under 48 pixels, 0.049–0.051 under 64, 0.07–0.10 under
/// 128–256; with the final rule the benchmark's auto row is 0.033, 72 teapots raymarched).
pub const AUTO_VOLUME_PIXELS: f32 = 48.0;

impl LodDesc {
    /// `"lod": "auto"`.
    pub const AUTO: Self =
        Self { enabled: true, strand_alpha: 8.0, vertex_alpha: 1024.0, vertex_error_pixels: 0.5, auto: true };

    /// LOD off: every strand, every vertex.
    pub const OFF: Self = Self { enabled: false, ..Self::EXPLICIT_DEFAULT };

    const EXPLICIT_DEFAULT: Self =
        Self { enabled: true, strand_alpha: 1.0, vertex_alpha: 1.0, vertex_error_pixels: 0.0, auto: false };

    /// Explicit strand and vertex α (the linear rule alone).
    pub fn alphas(strand_alpha: f64, vertex_alpha: f64) -> Self {
        Self { strand_alpha, vertex_alpha, ..Self::EXPLICIT_DEFAULT }
    }

    /// The generator's LOD parameters.
    pub fn params(&self) -> hairmesh::reference::LodParams {
        hairmesh::reference::LodParams {
            enabled: self.enabled,
            strand_alpha: self.strand_alpha,
            vertex_alpha: self.vertex_alpha,
            vertex_error_pixels: self.vertex_error_pixels,
            ..hairmesh::reference::LodParams::default()
        }
    }
}

impl Default for LodDesc {
    fn default() -> Self {
        Self::EXPLICIT_DEFAULT
    }
}

/// The explicit form of [`LodDesc`] as written in a file.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
struct ExplicitLod {
    enabled: bool,
    strand_alpha: f64,
    vertex_alpha: f64,
    vertex_error_pixels: f64,
}

impl From<&LodDesc> for ExplicitLod {
    fn from(l: &LodDesc) -> Self {
        Self {
            enabled: l.enabled,
            strand_alpha: l.strand_alpha,
            vertex_alpha: l.vertex_alpha,
            vertex_error_pixels: l.vertex_error_pixels,
        }
    }
}

impl From<ExplicitLod> for LodDesc {
    fn from(e: ExplicitLod) -> Self {
        Self {
            enabled: e.enabled,
            strand_alpha: e.strand_alpha,
            vertex_alpha: e.vertex_alpha,
            vertex_error_pixels: e.vertex_error_pixels,
            auto: false,
        }
    }
}

impl Default for ExplicitLod {
    fn default() -> Self {
        (&LodDesc::default()).into()
    }
}

impl Serialize for LodDesc {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        if self.auto {
            return serializer.serialize_str("auto");
        }
        ExplicitLod::from(self).serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for LodDesc {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct LodVisitor;
        impl<'de> serde::de::Visitor<'de> for LodVisitor {
            type Value = LodDesc;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(
                    "\"auto\" or an object with enabled, strand_alpha, vertex_alpha, vertex_error_pixels",
                )
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<LodDesc, E> {
                match v {
                    "auto" => Ok(LodDesc::AUTO),
                    other => Err(E::invalid_value(serde::de::Unexpected::Str(other), &self)),
                }
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<LodDesc, A::Error> {
                // The derived struct's errors (unknown fields, types) keep their positions.
                Ok(ExplicitLod::deserialize(serde::de::value::MapAccessDeserializer::new(map))?.into())
            }
        }
        deserializer.deserialize_any(LodVisitor)
    }
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

fn validate(loaded: &LoadedScene) -> Result<(), SceneError> {
    validate_with(loaded, true)
}

/// [`validate`], with or without the character list (an in-memory instance brings its own).
fn validate_with(loaded: &LoadedScene, characters: bool) -> Result<(), SceneError> {
    let s = &loaded.scene;
    let path = &loaded.path;
    let invalid = |field: &str, message: String| SceneError::Invalid {
        path: path.clone(),
        field: field.into(),
        message,
    };
    let finite = |field: &str, v: &[f32]| -> Result<(), SceneError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(invalid(field, format!("{v:?} is not finite")))
        }
    };
    let validate_transform = |field: &str, t: &TransformDesc| -> Result<(), SceneError> {
        finite(&format!("{field}.translation"), &t.translation)?;
        finite(&format!("{field}.rotation_y_degrees"), &[t.rotation_y_degrees])?;
        match t.scale {
            Some(scale) if !(scale.is_finite() && scale > 0.0) => {
                Err(invalid(&format!("{field}.scale"), format!("{scale} (expected a positive number)")))
            }
            _ => Ok(()),
        }
    };
    let o = s.output;
    if o.width == 0 || o.height == 0 || o.width > MAX_OUTPUT_SIDE || o.height > MAX_OUTPUT_SIDE {
        return Err(invalid(
            "output",
            format!("{}×{} (each side must be 1..={MAX_OUTPUT_SIDE})", o.width, o.height),
        ));
    }
    finite("camera.eye", &s.camera.eye)?;
    finite("camera.target", &s.camera.target)?;
    if !(1.0..=179.0).contains(&s.camera.fov_y_degrees) {
        return Err(invalid(
            "camera.fov_y_degrees",
            format!("{} (expected 1..=179)", s.camera.fov_y_degrees),
        ));
    }
    if Vec3::from_array(s.camera.eye).distance(Vec3::from_array(s.camera.target)) <= 0.0 {
        return Err(invalid("camera", "eye and target are the same point".into()));
    }
    if s.camera_path.len() == 1 || s.camera_path.len() > 10_000 {
        return Err(invalid(
            "camera_path",
            format!("{} keys (expected none, or 2..=10000)", s.camera_path.len()),
        ));
    }
    for (i, k) in s.camera_path.iter().enumerate() {
        finite(&format!("camera_path[{i}].eye"), &k.eye)?;
        finite(&format!("camera_path[{i}].target"), &k.target)?;
        if Vec3::from_array(k.eye).distance(Vec3::from_array(k.target)) <= 0.0 {
            return Err(invalid(&format!("camera_path[{i}]"), "eye and target are the same point".into()));
        }
    }
    if s.lights.len() > MAX_LIGHTS {
        return Err(invalid("lights", format!("{} lights (at most {MAX_LIGHTS})", s.lights.len())));
    }
    finite("output.background", &o.background)?;
    for (i, l) in s.lights.iter().enumerate() {
        let (v, c) = match l {
            Light::Directional { direction, color, .. } => (direction, color),
            Light::Point { position, color, .. } => (position, color),
        };
        finite(&format!("lights[{i}]"), v)?;
        finite(&format!("lights[{i}].color"), c)?;
        if let Light::Directional { direction, .. } = l
            && Vec3::from_array(*direction).length() <= 0.0
        {
            return Err(invalid(&format!("lights[{i}].direction"), "is zero".into()));
        }
    }
    if characters && (s.characters.is_empty() || s.characters.len() > MAX_CHARACTERS) {
        return Err(invalid(
            "characters",
            format!("{} characters (expected 1..={MAX_CHARACTERS})", s.characters.len()),
        ));
    }
    for (i, c) in s.characters.iter().enumerate() {
        let field = format!("characters[{i}]");
        validate_transform(&format!("{field}.transform"), &c.transform)?;
        finite(&format!("{field}.color"), &c.color)?;
        let hair = loaded.hair_path(c);
        if let Some(w) = c.strand_width
            && !(w.is_finite() && w > 0.0)
        {
            return Err(invalid(
                &format!("{field}.strand_width"),
                format!("{w} (expected a positive number)"),
            ));
        }
        if !hair.exists() {
            return Err(invalid(&format!("{field}.hair"), format!("{} does not exist", hair.display())));
        }
        if let Some(occluder) = &c.occluder {
            finite(&format!("{field}.occluder.color"), &occluder.color)?;
            validate_transform(&format!("{field}.occluder.transform"), &occluder.transform)?;
            let mesh = loaded.resolve(&occluder.mesh);
            if !mesh.is_file() {
                let what = match std::fs::metadata(&mesh) {
                    Ok(m) => format!("is {}, not a mesh file", hairmesh::input::describe(&m)),
                    Err(_) => "does not exist".into(),
                };
                return Err(invalid(&format!("{field}.occluder.mesh"), format!("{} {what}", mesh.display())));
            }
        }
    }
    let l = s.lod;
    if !(l.strand_alpha.is_finite()
        && l.strand_alpha > 0.0
        && l.vertex_alpha.is_finite()
        && l.vertex_alpha > 0.0)
    {
        return Err(invalid("lod", "alphas must be positive".into()));
    }
    if !(l.vertex_error_pixels.is_finite() && l.vertex_error_pixels >= 0.0) {
        return Err(invalid(
            "lod.vertex_error_pixels",
            format!("{} (expected a number of pixels, at least 0)", l.vertex_error_pixels),
        ));
    }
    let e = s.effects;
    if ![1, 2, 4, 8].contains(&e.msaa) {
        return Err(invalid("effects.msaa", format!("{} (expected 1, 2, 4 or 8)", e.msaa)));
    }
    if e.msaa > 1 && e.transparency == Transparency::Oit {
        return Err(invalid(
            "effects.msaa",
            format!("{} with transparency \"oit\" (MSAA anti-aliases the opaque and blended modes)", e.msaa),
        ));
    }
    if e.raster == Raster::Compute && e.msaa > 1 {
        return Err(invalid(
            "effects.msaa",
            format!("{} with raster \"compute\" (MSAA applies to the triangle raster)", e.msaa),
        ));
    }
    if e.shadows {
        if !(16..=4096).contains(&e.shadow_map_size) {
            return Err(invalid(
                "effects.shadow_map_size",
                format!("{} (expected 16..=4096)", e.shadow_map_size),
            ));
        }
        let l = e.shadow_layers;
        if !(l.iter().all(|x| x.is_finite() && *x > 0.0) && l[0] < l[1] && l[1] < l[2]) {
            return Err(invalid(
                "effects.shadow_layers",
                format!("{l:?} (expected three increasing positive numbers)"),
            ));
        }
    }
    if !(1..=16).contains(&e.oit_k) {
        return Err(invalid("effects.oit_k", format!("{} (expected 1..=16)", e.oit_k)));
    }
    if !(e.oit_nodes_per_pixel.is_finite() && e.oit_nodes_per_pixel > 0.0 && e.oit_nodes_per_pixel <= 256.0) {
        return Err(invalid(
            "effects.oit_nodes_per_pixel",
            format!("{} (expected more than 0, at most 256)", e.oit_nodes_per_pixel),
        ));
    }
    if e.ao && !(e.ao_radius.is_finite() && e.ao_radius > 0.0 && e.ao_radius <= 0.5) {
        return Err(invalid(
            "effects.ao_radius",
            format!("{} (expected more than 0, at most 0.5)", e.ao_radius),
        ));
    }
    if e.volume_lod && !(e.volume_lod_pixels.is_finite() && e.volume_lod_pixels >= 0.0) {
        return Err(invalid(
            "effects.volume_lod_pixels",
            format!("{} (expected a number of pixels, at least 0)", e.volume_lod_pixels),
        ));
    }
    if e.uses_volumes()
        && !(e.volume_resolution.is_power_of_two()
            && (crate::volume::MIN_RESOLUTION..=crate::volume::MAX_RESOLUTION).contains(&e.volume_resolution))
    {
        return Err(invalid(
            "effects.volume_resolution",
            format!(
                "{} (expected a power of two from {} to {})",
                e.volume_resolution,
                crate::volume::MIN_RESOLUTION,
                crate::volume::MAX_RESOLUTION
            ),
        ));
    }
    if e.volume_lod && e.raster == Raster::Triangles {
        return Err(invalid(
            "effects.volume_lod",
            "needs the compute rasterizer (raster \"auto\" or \"compute\"): the raymarched samples go \
             through its visibility buffer"
                .into(),
        ));
    }
    if let Some(a) = s.animation {
        if !(1..=MAX_FRAMES).contains(&a.frames) {
            return Err(invalid("animation.frames", format!("{} (expected 1..={MAX_FRAMES})", a.frames)));
        }
        if !(a.fps.is_finite() && a.fps > 0.0 && a.fps <= 1000.0) {
            return Err(invalid(
                "animation.fps",
                format!("{} (expected frames per second, 0 < fps ≤ 1000)", a.fps),
            ));
        }
    }
    let mut dynamic = 0;
    for (i, c) in s.characters.iter().enumerate() {
        let field = format!("characters[{i}]");
        if let Some(m) = &c.motion {
            m.validate().map_err(|(sub, message)| invalid(&format!("{field}.motion.{sub}"), message))?;
            if s.animation.is_none() {
                return Err(invalid(
                    &format!("{field}.motion"),
                    "needs the scene's \"animation\": {\"frames\": N, \"fps\": R} (time is frame / fps)"
                        .into(),
                ));
            }
        }
        let Some(d) = &c.dynamics else { continue };
        dynamic += 1;
        let dyn_field = format!("{field}.dynamics");
        d.validate().map_err(|m| invalid(&dyn_field, m))?;
        if !e.dynamics {
            return Err(invalid(&dyn_field, "needs \"effects\": {\"dynamics\": true}".into()));
        }
        if s.animation.is_none() {
            return Err(invalid(
                &dyn_field,
                "needs the scene's \"animation\": {\"frames\": N, \"fps\": R} (the simulation's time step is 1 / fps)"
                    .into(),
            ));
        }
        let hair = loaded.hair_path(c);
        if matches!(hair.extension().and_then(|e| e.to_str()), Some("tfx" | "hair")) {
            return Err(invalid(
                &dyn_field,
                format!(
                    "{} holds explicit strands: dynamics simulate hair meshes (hair assets)",
                    hair.display()
                ),
            ));
        }
    }
    if characters && e.dynamics && dynamic == 0 {
        return Err(invalid(
            "effects.dynamics",
            "no character has a \"dynamics\" block (add \"dynamics\": {} to the characters to simulate)"
                .into(),
        ));
    }
    Ok(())
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
