//! Curves through a vertex column: centripetal Catmull-Rom → cubic Bézier → two quadratics.
//!
//! A vertex column is one root vertex followed through all layers, `p_0 … p_L`. Between layers
//! `i` and `i+1` the curve is the centripetal Catmull-Rom segment (knot spacing `|Δp|^½`)
//! through `p_{i-1}, p_i, p_{i+1}, p_{i+2}`, with phantom end points reflected through the ends
//! (`p_{-1} = 2p_0 − p_1`, `p_{L+1} = 2p_L − p_{L−1}`). Each segment is converted to its cubic
//! Bézier form `(B0, B1, B2, B3)` (Yuksel, Schaefer & Keyser 2011) and then split at `t = ½` into
//! two quadratics sharing a C¹ join (Truong et al. 2020):
//!
//! ```text
//! q_a = B0 + ¾ (B1 − B0),   q_b = B3 + ¾ (B2 − B3),   m = (q_a + q_b) / 2
//! first half:  (B0, q_a, m) over t ∈ [0, ½]      second half: (m, q_b, B3) over t ∈ [½, 1]
//! ```
//!
//! These three points per segment are the intermediate slices of the hair-mesh texture.

use glam::DVec3;

/// Centripetal parameterisation exponent.
pub const ALPHA: f64 = 0.5;

/// A cubic Bézier segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicBezier(pub [DVec3; 4]);

/// The two quadratics replacing one cubic: `(B0, q_a, m)` and `(m, q_b, B3)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadraticPair {
    pub start: DVec3,
    pub q_a: DVec3,
    pub m: DVec3,
    pub q_b: DVec3,
    pub end: DVec3,
}

impl CubicBezier {
    pub fn eval(&self, t: f64) -> DVec3 {
        let [b0, b1, b2, b3] = self.0;
        let s = 1.0 - t;
        b0 * (s * s * s) + b1 * (3.0 * s * s * t) + b2 * (3.0 * s * t * t) + b3 * (t * t * t)
    }

    pub fn to_quadratics(&self) -> QuadraticPair {
        let [b0, b1, b2, b3] = self.0;
        let q_a = b0 + 0.75 * (b1 - b0);
        let q_b = b3 + 0.75 * (b2 - b3);
        QuadraticPair { start: b0, q_a, m: 0.5 * (q_a + q_b), q_b, end: b3 }
    }
}

/// De Casteljau evaluation of a quadratic: two lerps then one (what the GPU does with two
/// trilinear fetches and one lerp).
pub fn quadratic(p0: DVec3, p1: DVec3, p2: DVec3, s: f64) -> DVec3 {
    p0.lerp(p1, s).lerp(p1.lerp(p2, s), s)
}

impl QuadraticPair {
    /// Position at segment parameter `t ∈ [0, 1]`.
    pub fn eval(&self, t: f64) -> DVec3 {
        if t < 0.5 {
            quadratic(self.start, self.q_a, self.m, 2.0 * t)
        } else {
            quadratic(self.m, self.q_b, self.end, 2.0 * t - 1.0)
        }
    }

    /// Largest distance to the cubic at the same parameter, sampled at `samples + 1` points.
    pub fn max_error_to(&self, cubic: &CubicBezier, samples: u32) -> f64 {
        (0..=samples)
            .map(|i| {
                let t = f64::from(i) / f64::from(samples);
                self.eval(t).distance(cubic.eval(t))
            })
            .fold(0.0, f64::max)
    }
}

/// The Bézier control points of the centripetal Catmull-Rom segment from `p1` to `p2`.
///
/// Zero-length knot intervals (coincident vertices, which artists do produce) would divide by
/// zero in the textbook formula; a zero outer interval is replaced by the inner one, and a
/// zero inner interval gives the degenerate segment that stays at `p1`, so the result is
/// always finite.
pub fn catmull_rom_segment(p0: DVec3, p1: DVec3, p2: DVec3, p3: DVec3) -> CubicBezier {
    let scale = p1.abs().max(p2.abs()).max_element().max(1.0);
    let eps = 1e-12 * scale;
    let d2 = p1.distance(p2).powf(ALPHA);
    if p1.distance(p2) <= eps {
        return CubicBezier([p1, p1, p1, p1]);
    }
    let interval = |a: DVec3, b: DVec3| {
        let d = a.distance(b);
        if d <= eps { d2 } else { d.powf(ALPHA) }
    };
    let d1 = interval(p0, p1);
    let d3 = interval(p2, p3);
    let b1 = (d1 * d1 * p2 - d2 * d2 * p0 + (2.0 * d1 * d1 + 3.0 * d1 * d2 + d2 * d2) * p1)
        / (3.0 * d1 * (d1 + d2));
    let b2 = (d3 * d3 * p1 - d2 * d2 * p3 + (2.0 * d3 * d3 + 3.0 * d3 * d2 + d2 * d2) * p2)
        / (3.0 * d3 * (d3 + d2));
    CubicBezier([p1, b1, b2, p2])
}

/// The `L` Bézier segments of a column of `L + 1` points (empty for fewer than 2 points).
pub fn column_segments(column: &[DVec3]) -> Vec<CubicBezier> {
    let n = column.len();
    if n < 2 {
        return Vec::new();
    }
    let at = |i: isize| -> DVec3 {
        if i < 0 {
            2.0 * column[0] - column[1]
        } else if i as usize >= n {
            2.0 * column[n - 1] - column[n - 2]
        } else {
            column[i as usize]
        }
    };
    (0..n as isize - 1).map(|i| catmull_rom_segment(at(i - 1), at(i), at(i + 1), at(i + 2))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wavy_column(n: usize) -> Vec<DVec3> {
        (0..n)
            .map(|i| {
                let t = i as f64;
                DVec3::new((t * 0.7).sin() * 0.3, -t * 0.5, (t * 1.3).cos() * 0.2)
            })
            .collect()
    }

    #[test]
    fn segments_interpolate_the_column() {
        let column = wavy_column(6);
        let segs = column_segments(&column);
        assert_eq!(segs.len(), 5);
        for (i, s) in segs.iter().enumerate() {
            assert!(s.eval(0.0).distance(column[i]) < 1e-12);
            assert!(s.eval(1.0).distance(column[i + 1]) < 1e-12);
            let q = s.to_quadratics();
            assert!(q.eval(0.0).distance(column[i]) < 1e-12);
            assert!(q.eval(1.0).distance(column[i + 1]) < 1e-12);
        }
    }

    #[test]
    fn consecutive_segments_join_with_matching_tangents() {
        let segs = column_segments(&wavy_column(5));
        for pair in segs.windows(2) {
            let out = pair[0].0[3] - pair[0].0[2];
            let inn = pair[1].0[1] - pair[1].0[0];
            // Centripetal Catmull-Rom is C1 in its own knot parameter; across segments of
            // different knot length the Bézier tangents stay parallel (G1).
            assert!(out.normalize().dot(inn.normalize()) > 1.0 - 1e-9);
        }
    }

    #[test]
    fn quadratic_pair_is_c1_at_the_join() {
        for s in column_segments(&wavy_column(5)) {
            let q = s.to_quadratics();
            let left = q.m - q.q_a;
            let right = q.q_b - q.m;
            assert!((left - right).length() < 1e-12, "equal derivatives at m");
        }
    }

    /// The error of two quadratics against the cubic, relative to the segment's length.
    #[test]
    fn quadratic_error_is_small_relative_to_segment_length() {
        let mut worst: f64 = 0.0;
        let column = wavy_column(12);
        for s in column_segments(&column) {
            let len = s.0[0].distance(s.0[3]);
            let err = s.to_quadratics().max_error_to(&s, 256);
            worst = worst.max(err / len);
        }
        eprintln!("max quadratic-vs-cubic error: {:.3}% of segment length", worst * 100.0);
        // Two quadratics match a cubic's ends and end tangents; the remaining error is the
        // cubic's third-order term, (|B0 − 3B1 + 3B2 − B3| / 48)-ish, a few percent at most
        // for the bends between hair-mesh layers.
        assert!(worst < 0.02, "{worst}");
    }

    #[test]
    fn straight_columns_stay_straight() {
        let column: Vec<DVec3> = (0..4).map(|i| DVec3::new(0.0, i as f64, 0.0)).collect();
        for s in column_segments(&column) {
            for t in [0.1, 0.3, 0.5, 0.9] {
                let p = s.to_quadratics().eval(t);
                assert!(p.x.abs() < 1e-12 && p.z.abs() < 1e-12);
            }
        }
    }

    #[test]
    fn coincident_and_doubling_back_vertices_stay_finite() {
        let a = DVec3::new(1.0, 2.0, 3.0);
        let b = DVec3::new(1.0, 1.0, 3.0);
        let cases = [
            vec![a, a, a, a],
            vec![a, a, b, b],
            vec![a, b, a, b],
            vec![a, b, b, a],
            vec![a * 1e4, b * 1e4, (a + b) * 1e4],
            vec![a * 1e-4, b * 1e-4, (a + b) * 1e-4],
        ];
        for column in cases {
            for s in column_segments(&column) {
                for p in s.0 {
                    assert!(p.is_finite(), "{column:?} -> {s:?}");
                }
                let q = s.to_quadratics();
                assert!(q.eval(0.25).is_finite() && q.eval(0.75).is_finite());
            }
        }
    }
}
