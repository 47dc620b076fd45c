//! A scene's animation: its length and rate, and each character's head motion (keys and
//! periodic swings).

use super::*;

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

pub(super) fn default_fps() -> f32 {
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
    pub(super) fn validate(&self) -> Result<(), (String, String)> {
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
