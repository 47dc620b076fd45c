//! Level of detail as a scene writes it: `"auto"` or explicit α and error settings.

use super::*;

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
pub(super) struct ExplicitLod {
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
