//! Procedural styling, applied per strand vertex on top of the hair-mesh curves.
//!
//! Everything here is the specification the GPU implements line for line
//! (`gen-gpu/shaders/style.glsl` once it exists): same hash, same formulas, same order.
//!
//! **Inputs at a vertex.** Bundle `b`, strand `j` (its root sample index), the style `seed`,
//! strand parameter `τ ∈ [0, 1]` (root to tip), the curve point `p`, the styling frame
//! `(û, v̂, ŵ)` and styling coordinate `w` (object-space length from the root) fetched at the
//! same place, and the bundle's centre curve point `c` (block parameter `(½, ½)` for quads,
//! the centroid `(½, ⅓)` for triangles).
//!
//! **Random numbers.** `rand(b, j, k) = pcg(pcg(pcg(b ⊕ seed) + j) + k) / 2³²` with the 32-bit
//! PCG hash [`pcg_hash`]; `k` names the use (0 length, 1 curl phase, 2 wave phase, 3 stray,
//! 16+ frizz lattice).
//!
//! **Root fade.** `f(τ) = smoothstep(0, root_fade, τ)`; every operation is scaled by `f`, so the
//! root vertex (`τ = 0`) is never moved.
//!
//! **Order.** (1) length: the curve is evaluated at `τ′ = λτ`, `λ = 1 − length_variation·rand(b,j,0)`;
//! (2) offsets `d = (d_u, d_v, d_w)` in the frame: curl + wave + frizz, `p₁ = p + d_u û + d_v v̂ + d_w ŵ`;
//! (3) twist about `ŵ` through `c`; (4) clump toward `c`. Stray strands skip the clump and get
//! extra frizz.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A helix around the strand's path.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Curl {
    /// Helix radius (object units).
    pub radius: f64,
    /// Turns per object unit of `w`.
    pub frequency: f64,
    /// Phase in turns, added to a random per-strand phase.
    pub phase: f64,
}

impl Default for Curl {
    fn default() -> Self {
        Self { radius: 0.0, frequency: 1.0, phase: 0.0 }
    }
}

/// A planar wave along û.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Wave {
    pub amplitude: f64,
    /// Waves per object unit of `w`.
    pub frequency: f64,
    /// How much of the wave's random phase a bundle's strands share, 0..=1: 0 (the default)
    /// gives every strand its own phase (a fine crimp where strands cross), 1 puts the whole
    /// bundle in step, so it waves as one lock (long wavy hair). The phase's random number is
    /// `(1 − c)·rand(b, j, 2) + c·rand(b, BUNDLE_RANDOM, 2)`. Written only when set, so assets
    /// without it stay readable by builds that predate it.
    #[serde(skip_serializing_if = "is_zero")]
    pub coherence: f64,
}

impl Default for Wave {
    fn default() -> Self {
        Self { amplitude: 0.0, frequency: 1.0, coherence: 0.0 }
    }
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// The strand index whose random numbers are a bundle's own ([`Wave::coherence`]).
pub const BUNDLE_RANDOM: u32 = u32::MAX;

/// Smooth per-strand noise growing toward the tip.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Frizz {
    pub amplitude: f64,
    /// Noise lattice cells per object unit of `w`.
    pub frequency: f64,
    /// Growth toward the tip: amplitude × τ^exponent.
    pub exponent: f64,
}

impl Default for Frizz {
    fn default() -> Self {
        Self { amplitude: 0.0, frequency: 4.0, exponent: 2.0 }
    }
}

/// Pull toward the bundle's centre curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Clump {
    /// 0 = none, 1 = all strands meet the centre curve at the tip.
    pub strength: f64,
    /// Growth toward the tip: strength × τ^exponent.
    pub exponent: f64,
}

impl Default for Clump {
    fn default() -> Self {
        Self { strength: 0.0, exponent: 1.0 }
    }
}

/// Stray strands: a random fraction that ignores clumping and frizzes more.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Stray {
    /// Fraction of strands in [0, 1].
    pub fraction: f64,
    /// Extra frizz amplitude (object units).
    pub amplitude: f64,
}

/// The procedural style of a hair asset. Amplitudes are object-space lengths.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Style {
    pub seed: u32,
    /// Strand width at the root (object units).
    pub width: f64,
    /// Width at the tip as a fraction of the root width.
    pub tip_width: f64,
    /// Fraction of τ over which styling fades in from the root.
    pub root_fade: f64,
    /// Strands are shortened by up to this fraction (random per strand).
    pub length_variation: f64,
    pub curl: Curl,
    pub wave: Wave,
    pub frizz: Frizz,
    pub clump: Clump,
    /// Turns of the bundle around its centre curve from root to tip.
    pub twist: f64,
    pub stray: Stray,
}

impl Default for Style {
    fn default() -> Self {
        Self {
            seed: 1,
            width: 0.002,
            tip_width: 0.2,
            root_fade: 0.1,
            length_variation: 0.0,
            curl: Curl::default(),
            wave: Wave::default(),
            frizz: Frizz::default(),
            clump: Clump::default(),
            twist: 0.0,
            stray: Stray::default(),
        }
    }
}

impl Style {
    /// Every number of the style with the range it must lie in: the one place these ranges are
    /// stated. Lengths are object units; a range wide enough for any head's units still keeps
    /// the generator's arithmetic finite.
    pub fn fields(&self) -> [(&'static str, f64, std::ops::RangeInclusive<f64>); 18] {
        let mut copy = *self;
        copy.fields_mut().map(|(name, value, range)| (name, *value, range))
    }

    /// [`Style::fields`], each value to be changed in place.
    fn fields_mut(&mut self) -> [(&'static str, &mut f64, std::ops::RangeInclusive<f64>); 18] {
        const LENGTH: std::ops::RangeInclusive<f64> = 0.0..=1e4;
        const PER_LENGTH: std::ops::RangeInclusive<f64> = 0.0..=1e4;
        const FRACTION: std::ops::RangeInclusive<f64> = 0.0..=1.0;
        const EXPONENT: std::ops::RangeInclusive<f64> = 0.0..=64.0;
        [
            // Hair of width 0 would silently vanish.
            ("width", &mut self.width, 1e-9..=1e4),
            ("tip_width", &mut self.tip_width, 0.0..=16.0),
            ("root_fade", &mut self.root_fade, FRACTION),
            ("length_variation", &mut self.length_variation, FRACTION),
            ("curl.radius", &mut self.curl.radius, LENGTH),
            ("curl.frequency", &mut self.curl.frequency, PER_LENGTH),
            ("curl.phase", &mut self.curl.phase, -1e6..=1e6),
            ("wave.amplitude", &mut self.wave.amplitude, LENGTH),
            ("wave.frequency", &mut self.wave.frequency, PER_LENGTH),
            ("wave.coherence", &mut self.wave.coherence, FRACTION),
            ("frizz.amplitude", &mut self.frizz.amplitude, LENGTH),
            ("frizz.frequency", &mut self.frizz.frequency, PER_LENGTH),
            ("frizz.exponent", &mut self.frizz.exponent, EXPONENT),
            ("clump.strength", &mut self.clump.strength, FRACTION),
            ("clump.exponent", &mut self.clump.exponent, EXPONENT),
            ("twist", &mut self.twist, -1e4..=1e4),
            ("stray.fraction", &mut self.stray.fraction, FRACTION),
            ("stray.amplitude", &mut self.stray.amplitude, LENGTH),
        ]
    }

    /// The range of the field named as in [`Style::fields`] (`"curl.radius"`).
    pub fn range(field: &str) -> Option<std::ops::RangeInclusive<f64>> {
        Self::default().fields().into_iter().find(|(f, _, _)| *f == field).map(|(_, _, r)| r)
    }

    /// The style with every value brought into its range (a non-number to the range's start):
    /// what an editor applies after a value was typed in.
    #[must_use]
    pub fn clamped(mut self) -> Self {
        for (_, value, range) in self.fields_mut() {
            *value = if value.is_nan() { *range.start() } else { value.clamp(*range.start(), *range.end()) };
        }
        self
    }

    /// The first value outside its range ([`Style::fields`]), as `field: problem`.
    pub fn validate(&self) -> Result<(), String> {
        for (field, value, range) in self.fields() {
            if !range.contains(&value) {
                return Err(format!("{field}: {value:e} is outside {}..={}", range.start(), range.end()));
            }
        }
        Ok(())
    }
}

/// PCG hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering"): one u32 in, one out.
pub fn pcg_hash(input: u32) -> u32 {
    let state = input.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// `rand(b, j, k) ∈ [0, 1)` as described in the module docs.
pub fn strand_random(seed: u32, bundle: u32, strand: u32, k: u32) -> f64 {
    let h = pcg_hash(pcg_hash(pcg_hash(bundle ^ seed).wrapping_add(strand)).wrapping_add(k));
    f64::from(h) / 4_294_967_296.0
}

pub fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    if edge1 <= edge0 {
        return if x >= edge1 { 1.0 } else { 0.0 };
    }
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The frame and surroundings of one vertex, as fetched from the textures.
#[derive(Clone, Copy, Debug)]
pub struct StyleInput {
    pub bundle: u32,
    pub strand: u32,
    /// Strand parameter τ ∈ [0, 1] (before the length scale).
    pub tau: f64,
    /// Curve point at τ′ = λτ.
    pub position: DVec3,
    /// Bundle centre curve point at τ′.
    pub centre: DVec3,
    /// Orthonormal styling frame at τ′.
    pub frame: [DVec3; 3],
    /// Styling coordinate at τ′ (object length from the root).
    pub w: f64,
}

impl Style {
    /// `λ` for a strand: the fraction of the curve it covers.
    pub fn length_scale(&self, bundle: u32, strand: u32) -> f64 {
        1.0 - self.length_variation.clamp(0.0, 1.0) * strand_random(self.seed, bundle, strand, 0)
    }

    fn is_stray(&self, bundle: u32, strand: u32) -> bool {
        strand_random(self.seed, bundle, strand, 3) < self.stray.fraction
    }

    /// Smooth 1D value noise in [-1, 1]³ for a strand: lattice values `2·rand(b, j, 16+3i+c) − 1`
    /// at integer `i`, blended with smoothstep weights.
    pub fn frizz_noise(&self, bundle: u32, strand: u32, x: f64) -> DVec3 {
        let i = x.floor();
        let f = x - i;
        let blend = f * f * (3.0 - 2.0 * f);
        // The lattice repeats every 2^20 cells: far beyond any strand, and keeps the index in u32.
        let cell = (i.rem_euclid(1_048_576.0)) as u32;
        let lattice = |cell: u32| {
            DVec3::new(
                strand_random(self.seed, bundle, strand, 16 + 3 * cell) * 2.0 - 1.0,
                strand_random(self.seed, bundle, strand, 17 + 3 * cell) * 2.0 - 1.0,
                strand_random(self.seed, bundle, strand, 18 + 3 * cell) * 2.0 - 1.0,
            )
        };
        lattice(cell).lerp(lattice(cell.wrapping_add(1) % 1_048_576), blend)
    }

    /// The styled position of one vertex.
    pub fn apply(&self, input: &StyleInput) -> DVec3 {
        let StyleInput { bundle, strand, tau, position, centre, frame, w } = *input;
        let fade = smoothstep(0.0, self.root_fade, tau);
        if fade == 0.0 {
            return position;
        }
        let stray = self.is_stray(bundle, strand);
        let turn = std::f64::consts::TAU;
        let curl_phase =
            turn * (self.curl.frequency * w + self.curl.phase + strand_random(self.seed, bundle, strand, 1));
        let wave_phase = turn * (self.wave.frequency * w + self.wave_random(bundle, strand));
        let frizz_amplitude = self.frizz.amplitude + if stray { self.stray.amplitude } else { 0.0 };
        let frizz = self.frizz_noise(bundle, strand, w * self.frizz.frequency)
            * (frizz_amplitude * tau.powf(self.frizz.exponent.max(0.0)));
        let d = DVec3::new(
            self.curl.radius * curl_phase.cos() + self.wave.amplitude * wave_phase.sin(),
            self.curl.radius * curl_phase.sin(),
            0.0,
        ) + frizz;
        let [u, v, wdir] = frame;
        let offset = (u * d.x + v * d.y + wdir * d.z) * fade;
        let mut p = position + offset;
        if self.twist != 0.0 {
            let angle = turn * self.twist * tau * fade;
            p = centre + rotate_about(p - centre, wdir, angle);
        }
        if !stray && self.clump.strength != 0.0 {
            let amount =
                (self.clump.strength * tau.powf(self.clump.exponent.max(0.0)) * fade).clamp(0.0, 1.0);
            p = p.lerp(centre, amount);
        }
        p
    }

    /// The random number of the wave's phase ([`Wave::coherence`]; out-of-range coherences
    /// clamped, NaN taken as 0).
    pub fn wave_random(&self, bundle: u32, strand: u32) -> f64 {
        let own = strand_random(self.seed, bundle, strand, 2);
        // NaN and values ≤ 0 fail the comparison: independent phases.
        let c = self.wave.coherence;
        if c.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return own;
        }
        let c = c.min(1.0);
        own * (1.0 - c) + strand_random(self.seed, bundle, BUNDLE_RANDOM, 2) * c
    }

    /// Strand width at τ (before LOD compensation).
    pub fn width_at(&self, tau: f64) -> f64 {
        self.width * (1.0 + (self.tip_width - 1.0) * tau.clamp(0.0, 1.0))
    }

    /// Largest distance styling can move a vertex away from its curve point, for culling
    /// bounds (twist and clump stay within the bundle, so they add nothing beyond it).
    pub fn max_displacement(&self) -> f64 {
        self.curl.radius.abs()
            + self.wave.amplitude.abs()
            + 3f64.sqrt() * (self.frizz.amplitude.abs() + self.stray.amplitude.abs())
    }
}

/// Rodrigues' rotation of `v` about unit `axis` by `angle` radians.
pub fn rotate_about(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A style typed far outside its ranges is refused by `validate` and repaired by `clamped`;
    /// the default is inside every range.
    #[test]
    fn values_outside_their_ranges_are_refused_or_clamped() {
        assert!(Style::default().validate().is_ok());
        let mut wild = Style { width: f64::NAN, twist: 1e300, ..Style::default() };
        wild.curl.radius = -1.0;
        wild.clump.strength = 7.0;
        let e = wild.validate().expect_err("wild");
        assert!(e.starts_with("width: NaN"), "{e}");
        let fixed = wild.clamped();
        assert!(fixed.validate().is_ok(), "{fixed:?}");
        assert_eq!((fixed.width, fixed.curl.radius, fixed.clump.strength), (1e-9, 0.0, 1.0));
        assert_eq!(Style::range("stray.amplitude"), Some(0.0..=1e4));
        assert!(Style::range("no.such").is_none());
        assert_eq!(Style::default().fields().len(), 18);
    }

    #[test]
    fn wave_coherence_puts_a_bundle_in_step() {
        let style = |coherence: f64| Style {
            wave: Wave { amplitude: 0.05, frequency: 2.0, coherence },
            ..Style::default()
        };
        let randoms = |s: &Style, bundle: u32| (0..8).map(|j| s.wave_random(bundle, j)).collect::<Vec<_>>();
        // 0: every strand its own phase (today's default and older files).
        let own = randoms(&style(0.0), 5);
        assert!(own.windows(2).all(|w| w[0] != w[1]));
        assert_eq!(own[3], strand_random(style(0.0).seed, 5, 3, 2));
        // 1: the whole bundle in step, bundles apart from each other.
        let locked = randoms(&style(1.0), 5);
        assert!(locked.iter().all(|&r| r == locked[0]));
        assert_ne!(locked[0], randoms(&style(1.0), 6)[0]);
        // Between: nearer the bundle's phase; out of range clamped, NaN taken as 0.
        let half = randoms(&style(0.5), 5);
        assert!(half.iter().zip(&own).all(|(h, o)| (h - locked[0]).abs() <= (o - locked[0]).abs() + 1e-12));
        assert_eq!(randoms(&style(3.0), 5), locked);
        assert_eq!(randoms(&style(f64::NAN), 5), own);
        // Old style files without the field read as 0, and 0 is not written (older builds read
        // the file); a set coherence round-trips.
        let old: Style =
            serde_json::from_str(r#"{"wave": {"amplitude": 0.1, "frequency": 3.0}}"#).expect("old style");
        assert_eq!(old.wave.coherence, 0.0);
        assert!(!serde_json::to_string(&old).expect("json").contains("coherence"));
        let text = serde_json::to_string(&style(0.75)).expect("json");
        let back: Style = serde_json::from_str(&text).expect("round trip");
        assert_eq!(back.wave.coherence, 0.75);
    }

    fn input(tau: f64) -> StyleInput {
        StyleInput {
            bundle: 3,
            strand: 5,
            tau,
            position: DVec3::new(1.0, 2.0, 3.0),
            centre: DVec3::new(1.1, 2.0, 3.0),
            frame: [DVec3::X, DVec3::Z, DVec3::Y],
            w: tau * 2.0,
        }
    }

    fn busy_style() -> Style {
        Style {
            curl: Curl { radius: 0.1, frequency: 3.0, phase: 0.2 },
            wave: Wave { amplitude: 0.05, frequency: 2.0, coherence: 0.0 },
            frizz: Frizz { amplitude: 0.02, frequency: 5.0, exponent: 1.5 },
            clump: Clump { strength: 0.5, exponent: 1.0 },
            twist: 0.5,
            stray: Stray { fraction: 0.1, amplitude: 0.05 },
            length_variation: 0.3,
            ..Style::default()
        }
    }

    #[test]
    fn the_root_never_moves() {
        let style = busy_style();
        assert_eq!(style.apply(&input(0.0)), input(0.0).position);
        let moved = style.apply(&input(0.7));
        assert!(moved.distance(input(0.7).position) > 1e-3);
    }

    #[test]
    fn deterministic_per_bundle_strand_and_seed() {
        let style = busy_style();
        assert_eq!(style.apply(&input(0.5)), style.apply(&input(0.5)));
        let other_seed = Style { seed: 2, ..style };
        assert_ne!(style.apply(&input(0.5)), other_seed.apply(&input(0.5)));
        let mut other_strand = input(0.5);
        other_strand.strand = 6;
        assert_ne!(style.apply(&input(0.5)), style.apply(&other_strand));
    }

    #[test]
    fn displacement_stays_within_the_documented_bound() {
        let style = Style { clump: Clump::default(), twist: 0.0, ..busy_style() };
        for i in 0..=100 {
            let inp = input(f64::from(i) / 100.0);
            let d = style.apply(&inp).distance(inp.position);
            assert!(d <= style.max_displacement() + 1e-12, "{d}");
        }
    }

    #[test]
    fn pcg_matches_reference_values() {
        // Values of the GLSL/C reference implementation of pcg_hash.
        assert_eq!(pcg_hash(0), 129_708_002);
        assert_eq!(pcg_hash(1), 2_831_084_092);
        let r = strand_random(1, 2, 3, 4);
        assert!((0.0..1.0).contains(&r));
    }

    #[test]
    fn style_json_rejects_unknown_fields() {
        let style: Style = serde_json::from_str(r#"{"curl": {"radius": 0.1}}"#).expect("partial style");
        assert_eq!(style.curl.radius, 0.1);
        assert_eq!(style.curl.frequency, 1.0);
        assert!(serde_json::from_str::<Style>(r#"{"curly": 1}"#).is_err());
    }
}
