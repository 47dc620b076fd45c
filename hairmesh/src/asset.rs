//! A hair asset: the five textures plus what generation needs besides them (bundle table,
//! root sample sets, style). Built from a [`HairMesh`]; stored by [`crate::asset_io`].

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::curve::column_segments;
use crate::hair_mesh::{BundleFace, HairMesh};
use crate::roots::{
    EliminationParams, SampleDomain, permute_triangle_sample, prefix_quality, progressive_samples,
    triangle_to_square,
};
use crate::style::Style;
use crate::style::pcg_hash;
use crate::texture::{HairTextures, SliceLayout, block_vertices};
use crate::{HairMeshError, Result};

/// How many strands each bundle gets.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StrandCount {
    /// Strands per unit of root-face area (object units²).
    Density(f64),
    /// A total, shared by area.
    Total(u64),
}

/// Most strands one bundle may hold (the length of every sample set).
pub const MAX_STRANDS_PER_BUNDLE: u32 = 16_384;
/// Most strands an asset may hold.
pub const MAX_TOTAL_STRANDS: u64 = 50_000_000;

/// Build settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AssetParams {
    pub strands: StrandCount,
    /// Sample sets per domain; bundle `b` uses set `b mod sets`, under a symmetry of its domain
    /// chosen per bundle ([`HairAsset::root_symmetry`]), so one set already gives neighbours 8
    /// (squares) or 6 (triangles) different patterns. Each set costs 4 bytes per strand of the
    /// largest bundle on the GPU.
    pub sample_sets: u32,
    pub seed: u64,
    /// How bundles are laid out in the textures' slices.
    #[serde(default)]
    pub layout: SliceLayout,
}

impl Default for AssetParams {
    fn default() -> Self {
        Self { strands: StrandCount::Total(10_000), sample_sets: 1, seed: 1, layout: SliceLayout::Lattice }
    }
}

/// Per-bundle facts the generator needs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BundleInfo {
    pub domain: SampleDomain,
    /// `N_i`, the full strand count.
    pub strands: u32,
    /// Root-face area.
    pub area: f64,
    /// Axis-aligned bounds of the bundle's curves (the Bézier hull), object space.
    pub bounds_min: DVec3,
    pub bounds_max: DVec3,
    /// Longest vertex column (object length), the `h` of vertex LOD.
    pub length: f64,
}

impl BundleInfo {
    /// The `h` of strand LOD: the root face's size.
    pub fn face_size(&self) -> f64 {
        self.area.max(0.0).sqrt()
    }

    pub fn centre(&self) -> DVec3 {
        0.5 * (self.bounds_min + self.bounds_max)
    }
}

/// A progressive blue-noise sample set and its quality figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleSet {
    pub domain: SampleDomain,
    pub seed: u64,
    pub points: Vec<DVec2>,
    /// Normalized minimum distance of power-of-two prefixes.
    pub quality: Vec<(usize, f64)>,
}

/// Everything needed to generate the hair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HairAsset {
    pub textures: HairTextures,
    /// Curve evaluation of the reference generator (quadratics unless measuring accuracy).
    #[serde(default)]
    pub curve: crate::texture::CurveEvaluation,
    pub bundles: Vec<BundleInfo>,
    pub square_sets: Vec<SampleSet>,
    pub triangle_sets: Vec<SampleSet>,
    pub style: Style,
}

impl HairAsset {
    pub fn build(hm: &HairMesh, params: &AssetParams, style: Style) -> Result<Self> {
        let bad = |message: String| HairMeshError::InvalidParameter { what: "asset parameters", message };
        if hm.faces.is_empty() {
            return Err(bad("the hair mesh has no bundles".into()));
        }
        if params.sample_sets == 0 || params.sample_sets > 64 {
            return Err(bad(format!("{} sample sets (expected 1..=64)", params.sample_sets)));
        }
        let textures = HairTextures::build(hm, params.layout);
        let root = &hm.layers[0];
        let areas: Vec<f64> = hm
            .faces
            .iter()
            .map(|f| {
                let v = block_vertices(f).map(|i| root[i as usize]);
                0.5 * ((v[1] - v[0]).cross(v[2] - v[0]).length() + (v[2] - v[0]).cross(v[3] - v[0]).length())
            })
            .collect();
        let total_area: f64 = areas.iter().sum();
        let counts: Vec<u32> = match params.strands {
            StrandCount::Density(d) if d.is_finite() && d > 0.0 => {
                let total = d * total_area;
                if total > MAX_TOTAL_STRANDS as f64 {
                    return Err(bad(format!(
                        "density {d} gives {total:.0} strands, over {MAX_TOTAL_STRANDS}"
                    )));
                }
                areas
                    .iter()
                    .map(|a| (d * a).round().clamp(1.0, f64::from(MAX_STRANDS_PER_BUNDLE)) as u32)
                    .collect()
            }
            StrandCount::Total(n) if n > 0 && n <= MAX_TOTAL_STRANDS => {
                let per_area = if total_area > 0.0 { n as f64 / total_area } else { 0.0 };
                areas
                    .iter()
                    .map(|a| {
                        let share =
                            if total_area > 0.0 { per_area * a } else { n as f64 / areas.len() as f64 };
                        share.round().clamp(1.0, f64::from(MAX_STRANDS_PER_BUNDLE)) as u32
                    })
                    .collect()
            }
            other => {
                return Err(bad(format!(
                    "{other:?} (expected a positive density or 1..={MAX_TOTAL_STRANDS} strands)"
                )));
            }
        };
        let longest = counts.iter().copied().max().unwrap_or(1);
        let margin = style.max_displacement();
        let bundles = hm
            .faces
            .iter()
            .zip(areas.iter().zip(&counts))
            .map(|(face, (&area, &strands))| {
                let mut lo = DVec3::splat(f64::INFINITY);
                let mut hi = DVec3::splat(f64::NEG_INFINITY);
                let mut length: f64 = 0.0;
                for &v in face.vertices() {
                    let column = hm.column(v);
                    length = length.max(column.windows(2).map(|p| p[0].distance(p[1])).sum());
                    for p in column_segments(&column).iter().flat_map(|s| s.0) {
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                    lo = lo.min(column[0]);
                    hi = hi.max(column[0]);
                }
                BundleInfo {
                    domain: match face {
                        BundleFace::Quad(_) => SampleDomain::Square,
                        BundleFace::Triangle(_) => SampleDomain::Triangle,
                    },
                    strands,
                    area,
                    bounds_min: lo - DVec3::splat(margin),
                    bounds_max: hi + DVec3::splat(margin),
                    length,
                }
            })
            .collect();
        let sets = |domain: SampleDomain, salt: u64| -> Vec<SampleSet> {
            (0..params.sample_sets)
                .map(|k| {
                    let seed = params.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (salt + u64::from(k));
                    let points =
                        progressive_samples(longest as usize, domain, seed, &EliminationParams::default());
                    let quality = prefix_quality(&points, domain);
                    SampleSet { domain, seed, points, quality }
                })
                .collect()
        };
        let has = |d: SampleDomain| {
            hm.faces.iter().any(|f| {
                matches!(
                    (f, d),
                    (BundleFace::Quad(_), SampleDomain::Square)
                        | (BundleFace::Triangle(_), SampleDomain::Triangle)
                )
            })
        };
        Ok(Self {
            textures,
            curve: crate::texture::CurveEvaluation::Quadratic,
            bundles,
            square_sets: if has(SampleDomain::Square) { sets(SampleDomain::Square, 0) } else { Vec::new() },
            triangle_sets: if has(SampleDomain::Triangle) {
                sets(SampleDomain::Triangle, 1 << 32)
            } else {
                Vec::new()
            },
            style,
        })
    }

    /// Union of the bundles' bounds (object space, with the styling margin).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.bundles.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), b| {
            (lo.min(b.bounds_min), hi.max(b.bounds_max))
        })
    }

    pub fn total_strands(&self) -> u64 {
        self.bundles.iter().map(|b| u64::from(b.strands)).sum()
    }

    /// The sample set bundle `b` draws its roots from.
    pub fn sample_set(&self, bundle: u32) -> &SampleSet {
        let info = &self.bundles[bundle as usize];
        let sets = match info.domain {
            SampleDomain::Square => &self.square_sets,
            SampleDomain::Triangle => &self.triangle_sets,
        };
        &sets[bundle as usize % sets.len()]
    }

    /// The symmetry of its domain under which bundle `b` reads its sample set: a
    /// [`crate::lattice::SquareSymmetry`] code (0..8) for squares, a
    /// [`crate::roots::TRIANGLE_PERMUTATIONS`] index (0..6) for triangles. A hash of the bundle
    /// index, so neighbours sharing a set still get different root patterns.
    pub fn root_symmetry(&self, bundle: u32) -> u8 {
        let h = pcg_hash(bundle ^ 0x68e3_1da4);
        match self.bundles[bundle as usize].domain {
            SampleDomain::Square => (h % 8) as u8,
            SampleDomain::Triangle => (h % 6) as u8,
        }
    }

    /// Block parameter `(s, t)` of strand `j` of bundle `b`.
    pub fn root_parameter(&self, bundle: u32, strand: u32) -> DVec2 {
        let set = self.sample_set(bundle);
        let p = crate::roots::quantize_sample(set.points[strand as usize % set.points.len()]);
        let symmetry = self.root_symmetry(bundle);
        match self.bundles[bundle as usize].domain {
            SampleDomain::Square => {
                crate::lattice::SquareSymmetry::new(symmetry).unwrap_or_default().apply(p)
            }
            SampleDomain::Triangle => triangle_to_square(permute_triangle_sample(p, symmetry)),
        }
    }

    /// Block parameter of the bundle's centre curve: `(½, ½)` for quads, the centroid
    /// `(ξ1, ξ2) = (⅓, ⅓)` → `(½, ⅓)` for triangles.
    pub fn centre_parameter(&self, bundle: u32) -> DVec2 {
        match self.bundles[bundle as usize].domain {
            SampleDomain::Square => DVec2::new(0.5, 0.5),
            SampleDomain::Triangle => DVec2::new(0.5, 1.0 / 3.0),
        }
    }
}
