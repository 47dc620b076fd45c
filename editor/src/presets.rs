//! Hairstyle presets: a way to make the layers (when the document came from a scalp) and a
//! style, both relative to the head's frame (its skull's centre and radius, its up and front;
//! [`hairmesh::head_frame`]), so one preset looks the same on heads modelled in metres or in
//! centimetres, facing any way.

use glam::DVec3;
use hairmesh::convert::LayerShape;
use hairmesh::head_frame::HeadFrame;
use hairmesh::style::{Clump, Curl, Frizz, Stray, Style, Wave};

/// A named hairstyle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    pub name: &'static str,
    /// Hair length in skull radii.
    pub length: f64,
    pub layers: u32,
    pub shape: PresetShape,
    /// The style for hair of length 1 (amplitudes and widths are scaled by the hair length,
    /// frequencies divided by it).
    pub style: Style,
}

/// How a preset makes the layers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PresetShape {
    /// Out along the normals, drooping by this fraction of the length.
    Extrude { droop: f64 },
    /// Laid over the head and combed back (away from the face), lifted off it by `lift` per
    /// unit of length.
    DrapeBack { lift: f64 },
}

/// The presets, in menu order.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "Short curly",
        length: 0.35,
        layers: 3,
        shape: PresetShape::Extrude { droop: 0.5 },
        style: Style {
            seed: 1,
            width: 0.018,
            tip_width: 0.3,
            root_fade: 0.1,
            length_variation: 0.3,
            curl: Curl { radius: 0.11, frequency: 2.2, phase: 0.0 },
            wave: Wave { amplitude: 0.0, frequency: 1.0, coherence: 0.0 },
            frizz: Frizz { amplitude: 0.02, frequency: 4.0, exponent: 2.0 },
            clump: Clump { strength: 0.3, exponent: 1.5 },
            twist: 0.0,
            stray: Stray { fraction: 0.03, amplitude: 0.05 },
        },
    },
    Preset {
        name: "Long wavy",
        length: 2.4,
        layers: 6,
        shape: PresetShape::DrapeBack { lift: 0.04 },
        style: Style {
            seed: 7,
            width: 0.0018,
            tip_width: 0.2,
            // Smooth over the crown, waving down the lengths.
            root_fade: 0.35,
            length_variation: 0.15,
            curl: Curl { radius: 0.0, frequency: 1.0, phase: 0.0 },
            // Every bundle waves as one lock (with independent phases the waves cross into a
            // fine crimp).
            wave: Wave { amplitude: 0.045, frequency: 3.5, coherence: 1.0 },
            frizz: Frizz { amplitude: 0.002, frequency: 4.0, exponent: 2.0 },
            clump: Clump { strength: 0.3, exponent: 1.2 },
            twist: 0.0,
            stray: Stray { fraction: 0.02, amplitude: 0.01 },
        },
    },
    Preset {
        name: "Straight bob",
        length: 1.6,
        layers: 5,
        shape: PresetShape::DrapeBack { lift: 0.06 },
        style: Style {
            seed: 3,
            width: 0.004,
            tip_width: 0.5,
            root_fade: 0.05,
            length_variation: 0.05,
            curl: Curl { radius: 0.0, frequency: 1.0, phase: 0.0 },
            wave: Wave { amplitude: 0.0, frequency: 1.0, coherence: 0.0 },
            frizz: Frizz { amplitude: 0.002, frequency: 4.0, exponent: 2.0 },
            clump: Clump { strength: 0.15, exponent: 2.0 },
            twist: 0.0,
            stray: Stray { fraction: 0.01, amplitude: 0.01 },
        },
    },
    Preset {
        name: "Frizzy",
        length: 0.96,
        layers: 4,
        shape: PresetShape::Extrude { droop: 0.6 },
        style: Style {
            seed: 5,
            width: 0.006,
            tip_width: 0.3,
            root_fade: 0.1,
            length_variation: 0.35,
            curl: Curl { radius: 0.02, frequency: 6.0, phase: 0.0 },
            wave: Wave { amplitude: 0.0, frequency: 1.0, coherence: 0.0 },
            frizz: Frizz { amplitude: 0.06, frequency: 6.0, exponent: 1.5 },
            clump: Clump { strength: 0.1, exponent: 1.0 },
            twist: 0.0,
            stray: Stray { fraction: 0.08, amplitude: 0.05 },
        },
    },
];

impl Preset {
    /// The preset's style for hair of length `length` (object units).
    pub fn style_for(&self, length: f64) -> Style {
        let s = self.style;
        let h = length.max(1e-9);
        Style {
            width: s.width * h,
            curl: Curl { radius: s.curl.radius * h, frequency: s.curl.frequency / h, ..s.curl },
            wave: Wave { amplitude: s.wave.amplitude * h, frequency: s.wave.frequency / h, ..s.wave },
            frizz: Frizz { amplitude: s.frizz.amplitude * h, frequency: s.frizz.frequency / h, ..s.frizz },
            stray: Stray { amplitude: s.stray.amplitude * h, ..s.stray },
            ..s
        }
    }

    /// How to make the layers on the head of `frame`: (hair length, shape). Gravity pulls
    /// against the frame's up ([`hairmesh::convert::ConvertSettings::up`]).
    pub fn layers_on(&self, frame: &HeadFrame) -> (f64, LayerShape) {
        let length = self.length * frame.radius;
        let shape = match self.shape {
            PresetShape::Extrude { droop } => LayerShape::Extrude { droop },
            PresetShape::DrapeBack { lift } => {
                // `+ 0.0` makes −0 components 0 for the panel.
                LayerShape::Drape { centre: frame.centre, comb: frame.front * -COMB_BACK + 0.0, lift }
            }
        };
        (length, shape)
    }
}

/// How hard draped presets comb the hair back, as a multiple of gravity.
pub const COMB_BACK: f64 = 2.5;

/// A skull's radius per bounding-box diagonal of its scalp (the sample head's), for a scalp
/// without a head to estimate the frame from.
const RADIUS_PER_SCALP_DIAGONAL: f64 = 0.31;

/// A frame guessed from a scalp spanning `lo`–`hi` alone (no head): +Y up, facing +Z, the
/// centre below the middle of the scalp by a third of its height (about the skull's centre for
/// a scalp cap).
pub fn scalp_frame(lo: DVec3, hi: DVec3) -> HeadFrame {
    let c = 0.5 * (lo + hi);
    HeadFrame {
        centre: DVec3::new(c.x, c.y - (hi.y - lo.y) / 3.0, c.z),
        up: DVec3::Y,
        front: DVec3::Z,
        radius: RADIUS_PER_SCALP_DIAGONAL * lo.distance(hi),
    }
}
