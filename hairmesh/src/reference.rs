//! The CPU reference strand generator, in f64: the oracle every GPU result is tested against.
//!
//! For each bundle: strand LOD picks `N′_i` of its `N_i` strands (a prefix of its progressive
//! root set), vertex LOD picks `2^e + 1` vertices per strand with morphing of odd vertices;
//! each vertex is the hair-mesh curve at the strand's root parameter (two trilinear fetches
//! and a lerp per quadratic, emulated in f64), styled by [`Style::apply`]; tangents follow
//! Eq. 5–6 and widths the style's taper times the LOD width compensation.
//!
//! **Detail level** (DESIGN.md): `L = min(1, h·R / (α·d·tan(θ/2)))`, with `h` the bundle's face
//! size (strand LOD) or hair length (vertex LOD), `R` the vertical resolution, `d` the distance
//! from the eye to the bundle's bounds centre and `θ` the vertical field of view; orthographic
//! views use the view height `H` in place of `2·d·tan(θ/2)`… precisely: `d·tan(θ/2)` becomes
//! `H/2`. `d ≤ 0` (eye inside the bundle) gives `L = 1`.
//!
//! **Strand LOD**: `N′_i = clamp(⌈L·N_i − δ_i⌉, 1, N_i)` with `δ_i = pcg_hash(b ⊕ 0x5bd1e995)/2³²`;
//! widths × `min(1/L, N_i)`.
//!
//! **Vertex LOD**: `x = log2(L·2^E)`, `e = clamp(⌈x⌉, 0, E)`, `ē = clamp(⌈x − λ⌉, 0, E)`;
//! when `e > ē` odd vertices morph `p′_k = (1−γ) p_k + γ (p_{k−1}+p_{k+1})/2`,
//! `γ = clamp(1 − (x − ē)/λ, 0, 1)`, and tangents blend the same way between the full set's
//! and the even-only set's tangents.
//!
//! **Style-aware vertex LOD** ([`LodParams::vertex_error_pixels`] `ε > 0`): the linear rule
//! above gives every strand the same number of segments per pixel of its length, which keeps
//! straight hair but straightens curls and frizz that are still several pixels wide. Each
//! periodic style term — curl (radius `A`, `f·h` turns along a hair of length `h`), wave
//! (amplitude, `f·h` waves) and frizz (amplitude, plus the strays' when there are strays; value
//! noise with `f·h` lattice cells, about `f·h/2` periods) — deviates from a chord spanning a
//! phase step `φ` by at most `A·(1 − cos(φ/2))`. With `a = A·P` its amplitude in pixels (`P`
//! pixels per object unit at the bundle's distance: `R / (2·d·tan(θ/2))`), a term needs
//! `n = π·c / acos(1 − ε/a)` segments for `c` periods to stay within `ε` pixels; a term with
//! `2a < ε` is within the error whatever is drawn, and its level ramps in from 0 between
//! `a = ε/4` and `ε/2` so that levels change continuously with distance ([`style_term_level`]). Vertex LOD then takes
//! `x = max(log2(L·2^E), log2(n) + λ)` over the terms — a strand at `x` is level `⌈x⌉` morphed
//! toward `⌈x − λ⌉`, so the coarser of the two must already meet the error — and the levels,
//! the morph band and the cap `E` work as before (a curl finer than `2^E` segments can draw
//! stays at `E`).

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::asset::HairAsset;
use crate::style::{StyleInput, pcg_hash};

/// The camera, in the asset's object space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewParams {
    pub eye: DVec3,
    /// Output height in pixels (`R`).
    pub vertical_resolution: f64,
    pub projection: Projection,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Projection {
    /// Vertical field of view in radians.
    Perspective { fov_y: f64 },
    /// View height in object units (shadow maps).
    Orthographic { height: f64 },
}

/// The vertex-LOD cap `E`: a strand has at most `2^E` segments (`2^E + 1` vertices). The GPU
/// generator's strand slots hold exactly `2^E + 1` vertices, so the CPU reference and the GPU
/// share this one constant (gen-gpu asserts it at compile time and writes it into its GLSL
/// contract header); a larger [`LodParams::max_segments_log2`] is clamped to it on both sides.
pub const MAX_SEGMENTS_LOG2: u32 = 5;

/// LOD controls.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LodParams {
    /// Off: every strand, every vertex (`2^E + 1`).
    pub enabled: bool,
    /// Quality knob α of strand LOD (larger = coarser).
    pub strand_alpha: f64,
    /// Quality knob α of vertex LOD.
    pub vertex_alpha: f64,
    /// `E`: at most `2^E` segments per strand, clamped to [`MAX_SEGMENTS_LOG2`].
    pub max_segments_log2: u32,
    /// λ: width of the morph band in LOD levels.
    pub morph_band: f64,
    /// ε: the most, in pixels, a periodic style term (curl, wave, frizz) may deviate from the
    /// drawn polyline; vertex LOD keeps at least the segments that takes (module docs). 0 (the
    /// default) is the linear rule alone.
    #[serde(default)]
    pub vertex_error_pixels: f64,
}

impl Default for LodParams {
    fn default() -> Self {
        Self {
            enabled: true,
            strand_alpha: 1.0,
            vertex_alpha: 1.0,
            max_segments_log2: MAX_SEGMENTS_LOG2,
            morph_band: 1.0,
            vertex_error_pixels: 0.0,
        }
    }
}

/// LOD decisions for one bundle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BundleLod {
    pub strand_detail: f64,
    pub strands: u32,
    pub width_scale: f64,
    /// `x = log2(L·2^E)`, may be −∞ at L = 0.
    pub vertex_x: f64,
    pub level: u32,
    pub coarse_level: u32,
    /// Morph weight of odd vertices (0 = full detail).
    pub gamma: f64,
}

/// The per-bundle LOD offset `δ_i ∈ [0, 1)`.
pub fn bundle_delta(bundle: u32) -> f64 {
    f64::from(pcg_hash(bundle ^ 0x5bd1_e995)) / 4_294_967_296.0
}

/// Half the view's height in object units at distance `d` (`d·tan(θ/2)`, or `H/2`
/// orthographic): what both LOD rules measure sizes against.
fn half_view(d: f64, view: &ViewParams) -> f64 {
    match view.projection {
        Projection::Perspective { fov_y } => d * (0.5 * fov_y).tan(),
        Projection::Orthographic { height } => 0.5 * height,
    }
}

/// `L` for a world size `h` at distance `d`.
pub fn detail_level(h: f64, d: f64, alpha: f64, view: &ViewParams) -> f64 {
    let half_height = half_view(d, view);
    // NaN fails both comparisons, so a NaN input also means full detail.
    let measurable = half_height > 0.0 && alpha > 0.0;
    if !measurable {
        return 1.0;
    }
    let l = h * view.vertical_resolution / (alpha * half_height);
    if l.is_nan() { 1.0 } else { l.clamp(0.0, 1.0) }
}

/// Pixels per object unit at distance `d` (`R / (2·d·tan(θ/2))`, or `R / H` orthographic); 0
/// when that is not measurable (the eye at the point, a degenerate view).
pub fn pixels_per_unit(d: f64, view: &ViewParams) -> f64 {
    let p = view.vertical_resolution / (2.0 * half_view(d, view));
    if p.is_finite() && p > 0.0 { p } else { 0.0 }
}

/// The vertex-LOD `x` a style term of amplitude `amplitude` (object units) with `periods`
/// periods along the strand asks for at `pixels` pixels per object unit (module docs):
/// `log2(n) + λ` with `n = π·c / acos(1 − ε/a)` segments while its amplitude `a` in pixels is
/// at least `ε/2` (below, every polyline is within `2a < ε` of it); between `ε/4` and `ε/2` a
/// ramp from 0 (one segment) up to that value, so that levels change continuously with
/// distance (a term switching on would otherwise add `log2(c) + λ` at once); `−∞` (nothing)
/// under `ε/4` or when not measurable.
pub fn style_term_level(
    amplitude: f64,
    periods: f64,
    pixels: f64,
    error_pixels: f64,
    morph_band: f64,
) -> f64 {
    let a = amplitude.abs() * pixels;
    let c = periods.abs();
    // An unmeasurable term (NaN, infinite) asks for nothing.
    let counts = a.is_finite() && c.is_finite() && error_pixels > 0.0 && 4.0 * a > error_pixels;
    if !counts {
        return f64::NEG_INFINITY;
    }
    let lambda = morph_band.max(1e-6);
    let x = if 2.0 * a >= error_pixels {
        (std::f64::consts::PI * c / (1.0 - error_pixels / a).acos()).log2() + lambda
    } else {
        // At a = ε/2 the formula gives n = c (acos(−1) = π).
        (4.0 * a / error_pixels - 1.0) * (c.log2() + lambda)
    };
    if x.is_nan() { f64::NEG_INFINITY } else { x }
}

/// The vertex-LOD `x` the asset's style asks for on a strand of length `length` at `pixels`
/// pixels per object unit (`−∞`: nothing beyond the linear rule): the largest of its curl,
/// wave and frizz terms.
pub fn style_level(
    style: &crate::style::Style,
    length: f64,
    pixels: f64,
    error_pixels: f64,
    morph_band: f64,
) -> f64 {
    let frizz = style.frizz.amplitude.abs()
        + if style.stray.fraction > 0.0 { style.stray.amplitude.abs() } else { 0.0 };
    let terms = [
        (style.curl.radius, style.curl.frequency * length),
        (style.wave.amplitude, style.wave.frequency * length),
        (frizz, 0.5 * style.frizz.frequency * length),
    ];
    terms
        .iter()
        .map(|&(a, c)| style_term_level(a, c, pixels, error_pixels, morph_band))
        .fold(f64::NEG_INFINITY, f64::max)
}

impl BundleLod {
    /// LOD off: `strands` strands of `2^level` segments, nothing widened or morphed.
    pub fn full_detail(strands: u32, level: u32) -> Self {
        Self {
            strand_detail: 1.0,
            strands,
            width_scale: 1.0,
            vertex_x: f64::from(level),
            level,
            coarse_level: level,
            gamma: 0.0,
        }
    }
}

/// LOD of bundle `b` seen from `view`.
pub fn bundle_lod(asset: &HairAsset, bundle: u32, view: &ViewParams, lod: &LodParams) -> BundleLod {
    let info = &asset.bundles[bundle as usize];
    let e_max = lod.max_segments_log2.min(MAX_SEGMENTS_LOG2);
    if !lod.enabled {
        return BundleLod::full_detail(info.strands, e_max);
    }
    let d = view.eye.distance(info.centre());
    let ls = detail_level(info.face_size(), d, lod.strand_alpha, view);
    let n = f64::from(info.strands);
    let strands = ((ls * n - bundle_delta(bundle)).ceil()).clamp(1.0, n) as u32;
    let width_scale = if ls > 0.0 { (1.0 / ls).min(n) } else { n };
    let lv = detail_level(info.length, d, lod.vertex_alpha, view);
    let mut x = (lv * f64::from(1u32 << e_max)).log2();
    let styled = style_level(
        &asset.style,
        info.length,
        pixels_per_unit(d, view),
        lod.vertex_error_pixels,
        lod.morph_band,
    );
    if styled > x || x.is_nan() {
        x = styled;
    }
    let lambda = lod.morph_band.max(1e-6);
    let clamp_level = |v: f64| if v.is_nan() { 0 } else { v.ceil().clamp(0.0, f64::from(e_max)) as u32 };
    let level = clamp_level(x);
    let coarse_level = clamp_level(x - lambda);
    let gamma = if level > coarse_level {
        (1.0 - (x - f64::from(coarse_level)) / lambda).clamp(0.0, 1.0)
    } else {
        0.0
    };
    BundleLod { strand_detail: ls, strands, width_scale, vertex_x: x, level, coarse_level, gamma }
}

/// One generated strand.
#[derive(Clone, Debug, PartialEq)]
pub struct Strand {
    pub bundle: u32,
    pub index: u32,
    pub positions: Vec<DVec3>,
    pub tangents: Vec<DVec3>,
    pub widths: Vec<f64>,
}

/// Tangents by Eq. 5–6: central differences inside, reflections at the ends.
pub fn tangents(points: &[DVec3]) -> Vec<DVec3> {
    let n = points.len();
    if n < 2 {
        return vec![DVec3::Y; n];
    }
    let dir = |a: DVec3, b: DVec3, fallback: DVec3| (b - a).try_normalize().unwrap_or(fallback);
    let first_seg = dir(points[0], points[1], DVec3::Y);
    let last_seg = dir(points[n - 2], points[n - 1], first_seg);
    if n == 2 {
        return vec![first_seg, first_seg];
    }
    let mut t = vec![DVec3::ZERO; n];
    for k in 1..n - 1 {
        t[k] = dir(points[k - 1], points[k + 1], first_seg);
    }
    // t_0 = 2 q_1 (t̂_1·q_1) − t̂_1 and t_n = 2 q (t̂_{n−1}·q) − t̂_{n−1}: the neighbour's tangent
    // reflected about the end segment, so the end curvature continues smoothly.
    t[0] = (2.0 * first_seg * t[1].dot(first_seg) - t[1]).try_normalize().unwrap_or(first_seg);
    t[n - 1] = (2.0 * last_seg * t[n - 2].dot(last_seg) - t[n - 2]).try_normalize().unwrap_or(last_seg);
    t
}

impl HairAsset {
    /// Position of strand `j` of bundle `b` at strand parameter `tau`, styled.
    pub fn strand_point(&self, bundle: u32, strand: u32, root: DVec2, tau: f64) -> DVec3 {
        let style = &self.style;
        // The strand covers its bundle's reach (tip layer / L) scaled by its length variation.
        let lambda = style.length_scale(bundle, strand) * self.reach(bundle);
        let t_curve = tau * lambda;
        let tex = &self.textures;
        let position = tex.curve_point(self.curve, bundle, root.x, root.y, t_curve);
        if tau <= 0.0 {
            return position;
        }
        let centre_param = self.centre_parameter(bundle);
        let centre = tex.curve_point(self.curve, bundle, centre_param.x, centre_param.y, t_curve);
        let xy = tex.layout.block_coord(bundle, root.x, root.y);
        let z = DVec3::new(xy.x, xy.y, t_curve * f64::from(tex.layout.layers) + 0.5);
        let mut u = [0.0; 3];
        let mut v = [0.0; 3];
        let mut w = [0.0; 1];
        tex.u.sample(z, &mut u);
        tex.v.sample(z, &mut v);
        tex.w.sample(z, &mut w);
        let u = DVec3::from_array(u).try_normalize().unwrap_or(DVec3::X);
        let v = DVec3::from_array(v);
        let wdir = u.cross(v).try_normalize().unwrap_or_else(|| u.any_orthonormal_vector());
        let frame = [u, wdir.cross(u), wdir];
        let styled = style.apply(&StyleInput { bundle, strand, tau, position, centre, frame, w: w[0] });
        // Strand-level collision: whatever the curve and the style did, the vertex ends outside
        // the head (the root, on the scalp, is left where it grows).
        self.head_field.as_ref().map_or(styled, |field| field.push_out(styled))
    }

    /// Every strand the view asks for, as the GPU must produce them.
    pub fn generate_reference(&self, view: &ViewParams, lod: &LodParams) -> Vec<Strand> {
        (0..self.bundles.len() as u32)
            .flat_map(|b| {
                let l = bundle_lod(self, b, view, lod);
                (0..l.strands).map(move |j| self.generate_strand(b, j, &l))
            })
            .collect()
    }

    /// One strand at a given LOD.
    pub fn generate_strand(&self, bundle: u32, strand: u32, l: &BundleLod) -> Strand {
        let root = self.root_parameter(bundle, strand);
        let segments = 1usize << l.level;
        let full: Vec<DVec3> = (0..=segments)
            .map(|k| self.strand_point(bundle, strand, root, k as f64 / segments as f64))
            .collect();
        let full_tangents = tangents(&full);
        let (positions, tangents_out) = if l.gamma > 0.0 && l.level > l.coarse_level && segments >= 2 {
            let even: Vec<DVec3> = full.iter().step_by(2).copied().collect();
            let even_tangents = tangents(&even);
            let g = l.gamma;
            let positions = (0..=segments)
                .map(|k| {
                    if k % 2 == 1 {
                        (1.0 - g) * full[k] + g * 0.5 * (full[k - 1] + full[k + 1])
                    } else {
                        full[k]
                    }
                })
                .collect();
            let tangents_out = (0..=segments)
                .map(|k| {
                    // The even-only set's tangent at an odd vertex is its coarse segment's
                    // direction; at even vertex 2m it is the coarse set's tangent m.
                    let coarse = if k % 2 == 1 {
                        (full[k + 1] - full[k - 1]).try_normalize().unwrap_or(full_tangents[k])
                    } else {
                        even_tangents[k / 2]
                    };
                    ((1.0 - g) * full_tangents[k] + g * coarse).try_normalize().unwrap_or(full_tangents[k])
                })
                .collect();
            (positions, tangents_out)
        } else {
            (full, full_tangents)
        };
        let widths =
            (0..=segments).map(|k| self.style.width_at(k as f64 / segments as f64) * l.width_scale).collect();
        Strand { bundle, index: strand, positions, tangents: tangents_out, widths }
    }
}
