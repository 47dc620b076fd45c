//! Strand-level collision with the head: a signed distance field of the head, sampled by every
//! generator (this crate's reference, gen-gpu's include) to push strand vertices that end up
//! inside the head, or closer to it than a margin, out along the field's gradient.
//!
//! The hair mesh is kept out of the head vertex by vertex and curve by curve at conversion
//! (`convert::keep_outside`), but strands are interpolated inside a bundle and styled (curls,
//! waves, frizz, clumps): a strand between outside vertices can still cut through a curved
//! head. Only a test on the strands themselves keeps every one out, and strands exist only in
//! the generator, so the test lives there.
//!
//! **Field**: signed distances (negative inside, [`HeadSurface::signed_distance`]) at the
//! points `lo + i·cell` of a grid over the head's bounds where they meet the hair's (widened by
//! two cells), at most [`HeadField::MAX_POINTS`] points along its longest side. **Sampling**: trilinear, texels
//! fetched and blended like `hair_gen.glsl`'s `keep_out_of_head`, with the gradient of the
//! same trilinear interpolant (its derivative, cell by cell). **Push**: a point inside the grid
//! whose distance `d` is below the margin `m` (grown where the slope `s = |∇d|` is below 1:
//! `m + (1 − s)·cell`, [`HeadField::push_out`]) moves by the difference along the normalized
//! gradient, again from where it lands while it is still short ([`PUSH_STEPS`] at most), a
//! step halved until the distance grows ([`PUSH_HALVINGS`] at most, else the point stays where
//! it got); points outside the grid, or where the gradient vanishes, stay.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::head::HeadSurface;
use crate::texture::Texture3;

/// Most steps [`HeadField::push_out`] takes (`hair_gen.glsl` takes as many).
pub const PUSH_STEPS: u32 = 4;

/// Most times [`HeadField::push_out`] halves a step that would not take a point further out.
pub const PUSH_HALVINGS: u32 = 3;

/// The head's signed distance field and the margin strands keep from it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeadField {
    /// Object-space position of grid point (0, 0, 0).
    pub lo: DVec3,
    /// Spacing of the grid points (object units).
    pub cell: f64,
    /// How far out of the head strand vertices are kept (object units).
    pub margin: f64,
    /// Signed distances, one channel, grid point `(x, y, z)` at texel `(x, y, z)`; values are
    /// half floats (files and the GPU store them so).
    pub distance: Texture3,
}

impl HeadField {
    /// Most grid points along the longest side of the head's bounds.
    pub const MAX_POINTS: u32 = 96;

    /// The field of `head` over the part of its bounds within `around` (the hair's bounds:
    /// nothing elsewhere can collide), with strands kept `margin` out of it; `None` when the two
    /// do not meet, for a head without triangles or an invalid margin.
    pub fn build(head: &HeadSurface, around: (DVec3, DVec3), margin: f64) -> Option<Self> {
        let (head_lo, head_hi) = head.bounds();
        let (lo, hi) = (head_lo.max(around.0), head_hi.min(around.1));
        let extent = hi - lo;
        if !(extent.is_finite() && extent.min_element() > 0.0 && margin.is_finite() && margin >= 0.0) {
            return None;
        }
        // Two cells of padding on every side: beyond them the head is at least that far away.
        let cell = extent.max_element() / f64::from(Self::MAX_POINTS - 5);
        let lo = lo - DVec3::splat(2.0 * cell);
        let points = ((extent / cell).ceil() + 5.0).min(DVec3::splat(f64::from(Self::MAX_POINTS)));
        let [w, h, d] = [points.x as u32, points.y as u32, points.z as u32].map(|n| n.max(2));
        // Exact distances where a push can read them: at the grid points within a band around
        // the surface (a sample's eight corners are within a cell diagonal of it, plus the
        // margin and the deepest a strand goes in). Elsewhere, a coarse grid's trilinear value
        // (every COARSE-th point, exact) gives sign and size, which is all a point that is never
        // pushed needs.
        const COARSE: u32 = 4;
        let at = |x: u32, y: u32, z: u32| lo + DVec3::new(f64::from(x), f64::from(y), f64::from(z)) * cell;
        let coarse_size = [w, h, d].map(|n| (n - 1).div_ceil(COARSE) + 1);
        use rayon::prelude::*;
        let coarse: Vec<f64> = (0..coarse_size[0] * coarse_size[1] * coarse_size[2])
            .into_par_iter()
            .map(|i| {
                let (x, y, z) = (
                    i % coarse_size[0],
                    i / coarse_size[0] % coarse_size[1],
                    i / (coarse_size[0] * coarse_size[1]),
                );
                head.signed_distance(at(x * COARSE, y * COARSE, z * COARSE))
            })
            .collect();
        let coarse_field = Self {
            lo,
            cell: cell * f64::from(COARSE),
            margin,
            distance: Texture3 {
                width: coarse_size[0],
                height: coarse_size[1],
                depth: coarse_size[2],
                channels: 1,
                data: coarse,
            },
        };
        // Distance is 1-Lipschitz, so the coarse interpolant (a convex blend of its corners) is
        // off by at most the weighted distance to them: half its cell's diagonal. A push reads
        // the corners of a cell within a cell's diagonal of the vertex, which is at most the
        // margin out or two cells in (how deep strands dip in between the hair mesh's vertices).
        let sqrt3 = 3.0_f64.sqrt();
        let band = sqrt3 * cell * (0.5 * f64::from(COARSE) + 1.0) + 2.0 * cell + 2.0 * margin;
        let mut data = vec![0.0; (w * h * d) as usize];
        // Rows in parallel.
        data.par_chunks_mut(w as usize).enumerate().for_each(|(row, out)| {
            let (y, z) = (row as u32 % h, row as u32 / h);
            for (x, value) in out.iter_mut().enumerate() {
                let p = at(x as u32, y, z);
                *value = match coarse_field.sample(p) {
                    Some((rough, _)) if rough.abs() > band => rough,
                    _ => head.signed_distance(p),
                };
            }
        });
        // Half floats, as the files and the GPU keep them (near the surface, where the values
        // are read, they are small and keep their precision), so every generator reads the
        // same field. Far values only need their sign and size: clamped into half's range.
        for v in &mut data {
            *v = half::f16::from_f64(v.clamp(-60_000.0, 60_000.0)).to_f64();
        }
        if !data.iter().all(|v| v.is_finite()) {
            return None;
        }
        Some(Self {
            lo,
            cell,
            margin,
            distance: Texture3 { width: w, height: h, depth: d, channels: 1, data },
        })
    }

    /// The object-space corner opposite [`Self::lo`].
    pub fn hi(&self) -> DVec3 {
        let t = &self.distance;
        self.lo
            + DVec3::new(f64::from(t.width - 1), f64::from(t.height - 1), f64::from(t.depth - 1)) * self.cell
    }

    /// The signed distance at `p` and its gradient (trilinear interpolation of the grid and
    /// that interpolant's derivative); `None` outside the grid.
    pub fn sample(&self, p: DVec3) -> Option<(f64, DVec3)> {
        let (lo, hi) = (self.lo, self.hi());
        if !(p.cmpge(lo).all() && p.cmple(hi).all()) {
            return None;
        }
        let t = &self.distance;
        let size = DVec3::new(f64::from(t.width), f64::from(t.height), f64::from(t.depth));
        let f = ((p - lo) / self.cell).clamp(DVec3::ZERO, size - 1.0);
        let i0 = f.floor();
        let w = f - i0;
        let (x0, y0, z0) = (i0.x as u32, i0.y as u32, i0.z as u32);
        let (x1, y1, z1) = ((x0 + 1).min(t.width - 1), (y0 + 1).min(t.height - 1), (z0 + 1).min(t.depth - 1));
        let at = |x: u32, y: u32, z: u32| t.data[((z * t.height + y) * t.width + x) as usize];
        let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
        let (c000, c100, c010, c110) = (at(x0, y0, z0), at(x1, y0, z0), at(x0, y1, z0), at(x1, y1, z0));
        let (c001, c101, c011, c111) = (at(x0, y0, z1), at(x1, y0, z1), at(x0, y1, z1), at(x1, y1, z1));
        let (c00, c10) = (lerp(c000, c100, w.x), lerp(c010, c110, w.x));
        let (c01, c11) = (lerp(c001, c101, w.x), lerp(c011, c111, w.x));
        let distance = lerp(lerp(c00, c10, w.y), lerp(c01, c11, w.y), w.z);
        let dx = lerp(lerp(c100 - c000, c110 - c010, w.y), lerp(c101 - c001, c111 - c011, w.y), w.z);
        let dy = lerp(c10 - c00, c11 - c01, w.z);
        let dz = lerp(c01, c11, w.y) - lerp(c00, c10, w.y);
        Some((distance, DVec3::new(dx, dy, dz) / self.cell))
    }

    /// `p` moved out of the head to the margin when the field says it is inside or closer
    /// (module docs); otherwise `p`. Where the grid blurs a thin part of the head (an ear: both
    /// of its sides within a cell) the field's slope drops below 1 and its distance runs up to
    /// a cell too high: there the margin grows by `(1 − slope)` cells, and one step falls short,
    /// so it steps again from where it lands ([`PUSH_STEPS`] at most), never to a place the field
    /// puts deeper.
    pub fn push_out(&self, p: DVec3) -> DVec3 {
        let mut q = p;
        let Some(mut here) = self.sample(q) else { return p };
        for _ in 0..PUSH_STEPS {
            let (d, gradient) = here;
            let slope = gradient.length();
            let target = self.margin + (1.0 - slope.min(1.0)) * self.cell;
            if d >= target || slope.is_nan() || slope <= 1e-9 {
                break;
            }
            // A step only counts if the distance grows: across a crease (between an ear and the
            // skull) the gradient of the next cell can point back in. Half the step, up to
            // [`PUSH_HALVINGS`] times, else stay.
            let mut step = gradient / slope * (target - d);
            let mut moved = None;
            for _ in 0..=PUSH_HALVINGS {
                if let Some(next) = self.sample(q + step)
                    && next.0 > d
                {
                    moved = Some((q + step, next));
                    break;
                }
                step *= 0.5;
            }
            let Some((next_q, next)) = moved else { break };
            q = next_q;
            here = next;
        }
        q
    }

    /// Grid points (texels) of the field.
    pub fn texels(&self) -> u64 {
        u64::from(self.distance.width) * u64::from(self.distance.height) * u64::from(self.distance.depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed UV sphere about the origin.
    fn sphere(radius: f64) -> HeadSurface {
        let (rings, segments) = (24u32, 48u32);
        let mut positions = vec![DVec3::new(0.0, radius, 0.0)];
        for r in 1..rings {
            let theta = std::f64::consts::PI * f64::from(r) / f64::from(rings);
            for s in 0..segments {
                let phi = std::f64::consts::TAU * f64::from(s) / f64::from(segments);
                positions.push(
                    radius * DVec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin()),
                );
            }
        }
        positions.push(DVec3::new(0.0, -radius, 0.0));
        let bottom = positions.len() as u32 - 1;
        let at = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
        let mut triangles = Vec::new();
        for s in 0..segments {
            triangles.push([0, at(1, s), at(1, s + 1)]);
            triangles.push([bottom, at(rings - 1, s + 1), at(rings - 1, s)]);
            for r in 1..rings - 1 {
                triangles.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
                triangles.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
            }
        }
        HeadSurface::new(positions, triangles)
    }

    #[test]
    fn the_field_measures_a_sphere() {
        let head = sphere(1.0);
        let field = HeadField::build(&head, (DVec3::splat(-2.0), DVec3::splat(2.0)), 0.01).expect("field");
        assert!(field.distance.width <= HeadField::MAX_POINTS && field.distance.width >= 90);
        // Near the surface, where pushes happen, the field is close to exact (deep inside,
        // at the medial axis, trilinear interpolation rounds the distance's crease off).
        for p in [DVec3::new(0.6, 0.5, -0.2), DVec3::new(0.9, 0.3, 0.1), DVec3::new(-0.1, -1.03, 0.2)] {
            let (d, g) = field.sample(p).expect("inside the grid");
            let exact = head.signed_distance(p);
            assert!((d - exact).abs() < 0.005, "{p}: {d} vs {exact}");
            assert!(g.normalize().dot(p.normalize()) > 0.98, "{p}: gradient {g}");
        }
        assert_eq!(field.sample(DVec3::new(5.0, 0.0, 0.0)), None);
    }

    #[test]
    fn points_inside_are_pushed_to_the_margin_and_outside_ones_stay() {
        let head = sphere(1.0);
        let field = HeadField::build(&head, (DVec3::splat(-2.0), DVec3::splat(2.0)), 0.02).expect("field");
        for p in [DVec3::new(0.7, 0.1, 0.2), DVec3::new(0.0, 0.99, 0.0), DVec3::new(-0.2, -0.5, 0.75)] {
            let q = field.push_out(p);
            let d = head.signed_distance(q);
            assert!(d > 0.0 && (d - 0.02).abs() < 0.01, "{p} → {q}: {d}");
        }
        let clear = DVec3::new(1.2, 0.0, 0.0);
        assert_eq!(field.push_out(clear), clear);
        assert_eq!(field.push_out(DVec3::splat(9.0)), DVec3::splat(9.0));
    }
}
