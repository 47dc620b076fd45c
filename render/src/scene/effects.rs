//! What a scene asks the renderer for: transparency, the rasterizer, shadows, AO, volumes,
//! dynamics.

use super::*;

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
