#![allow(
    clippy::neg_cmp_op_on_partial_ord,
    reason = "`!(x > 0.0)` is true for NaN, as the GLSL's tests are: degenerate input draws nothing"
)]
//! The CPU port of `strand_raster.glsl` and `raster_common.glsl` (f32, the same formulas
//! in the same order): what the GPU kernels' coverage and visibility are tested against.

use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::raster::{COVERAGE_SCALE, MAX_MATERIALS};

/// No coverage is added past this sum, and it is read clamped to it, as opaque.
pub use crate::contract::COVERAGE_LIMIT;

/// The port of `raster_split.comp`: the drawing order of `slots` live strand slots from
/// their marks (`history`: the marks are a frame's; else there are none).
pub fn slot_order(marks: &[u32], slots: usize, history: bool) -> crate::raster::StrandOrder {
    let stride = gen_gpu::contract::SPARSE_SLOT_STRIDE as usize;
    let marked = |slot: usize| if history { marks.get(slot).copied().unwrap_or(0) } else { 0 };
    let sparse_unmarked = |slot: usize| marked(slot) == 0 && slot.is_multiple_of(stride);
    let marked_count = (0..slots).filter(|&slot| marked(slot) != 0).count();
    // Fewer marked strands than the sparse subset holds: the sparse ones join the front.
    let both = marked_count * stride < slots;
    let mut order = crate::raster::StrandOrder::default();
    order.front.extend((0..slots).filter(|&s| marked(s) != 0).map(|s| [s as u32, marked(s)]));
    if both {
        order.front.extend((0..slots).filter(|&s| sparse_unmarked(s)).map(|s| [s as u32, u32::MAX]));
    }
    order.rest.extend(
        (0..slots)
            .filter(|&s| marked(s) != u32::MAX && !(both && sparse_unmarked(s)))
            .map(|s| [s as u32, marked(s)]),
    );
    order
}

/// What the kernel needs of the frame (`GenParams` of the strands' object space).
#[derive(Clone, Copy, Debug)]
pub struct RasterView {
    /// Object space → clip space.
    pub view_proj: Mat4,
    /// The eye in object space.
    pub eye: Vec3,
    pub width: u32,
    pub height: u32,
    /// Object → world (tangents are stored in world space).
    pub model: Mat4,
    pub max_half_width: f32,
}

/// One strand vertex as generation or a strand buffer hands it over (object space).
#[derive(Clone, Copy, Debug)]
pub struct StrandPoint {
    pub position: Vec3,
    pub width: f32,
    pub tangent: Vec3,
    pub tau: f32,
}

/// The visibility and coverage buffers.
#[derive(Clone, Debug, PartialEq)]
pub struct RasterBuffers {
    pub width: u32,
    pub height: u32,
    pub visibility: Vec<u64>,
    /// The optical-depth sum (fixed point) per pixel, as the GPU's coverage word holds it
    /// (complemented there).
    pub coverage: Vec<u64>,
}

impl RasterBuffers {
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, visibility: vec![u64::MAX; n], coverage: vec![0; n] }
    }

    /// The alpha the resolve gives pixel `i` (`coverage_alpha`: opaque at the limit).
    pub fn alpha(&self, i: usize) -> f32 {
        let sum = self.coverage[i];
        if sum >= u64::from(COVERAGE_LIMIT) { 1.0 } else { 1.0 - (-(sum as f32) / COVERAGE_SCALE).exp() }
    }
}

#[derive(Clone, Copy, Debug)]
struct RasterVertex {
    clip: Vec4,
    side: Vec4,
    tangent: Vec3,
    tau: f32,
    /// The projection (`project_vertex`): pixel position, half width in pixels (capped),
    /// 1 / w, NDC z.
    screen: Vec2,
    half_width: f32,
    inv_w: f32,
    z: f32,
}

fn try_normalize(v: Vec3, fallback: Vec3) -> Vec3 {
    let l = v.length();
    let inv = 1.0 / l;
    if l > 0.0 && inv.is_finite() { v * inv } else { fallback }
}

fn any_orthonormal(v: Vec3) -> Vec3 {
    v.any_orthonormal_vector()
}

fn raster_vertex(view: &RasterView, v: &StrandPoint) -> RasterVertex {
    let to_eye = view.eye - v.position;
    let side = try_normalize(v.tangent.cross(to_eye), any_orthonormal(v.tangent)) * (0.5 * v.width);
    project_vertex(
        view,
        RasterVertex {
            clip: view.view_proj * v.position.extend(1.0),
            side: view.view_proj * side.extend(0.0),
            tangent: glam::Mat3::from_mat4(view.model) * v.tangent,
            tau: v.tau,
            ..UNPROJECTED
        },
    )
}

const UNPROJECTED: RasterVertex = RasterVertex {
    clip: Vec4::ZERO,
    side: Vec4::ZERO,
    tangent: Vec3::ZERO,
    tau: 0.0,
    screen: Vec2::ZERO,
    half_width: 0.0,
    inv_w: 0.0,
    z: 0.0,
};

fn project_vertex(view: &RasterView, r: RasterVertex) -> RasterVertex {
    let size = Vec2::new(view.width as f32, view.height as f32);
    let inv_w = 1.0 / r.clip.w;
    RasterVertex {
        screen: (Vec2::new(r.clip.x, r.clip.y) * inv_w * 0.5 + 0.5) * size,
        half_width: half_width_pixels(view, r.clip, r.side, inv_w).min(view.max_half_width),
        inv_w,
        z: r.clip.z * inv_w,
        ..r
    }
}

/// The point at t between a and b, not projected.
fn mix_vertex(a: &RasterVertex, b: &RasterVertex, t: f32) -> RasterVertex {
    RasterVertex {
        clip: a.clip.lerp(b.clip, t),
        side: a.side.lerp(b.side, t),
        tangent: a.tangent.lerp(b.tangent, t),
        tau: a.tau + (b.tau - a.tau) * t,
        ..UNPROJECTED
    }
}

fn clip_range(da: f32, db: f32, t0: &mut f32, t1: &mut f32) {
    if da < 0.0 && db < 0.0 {
        *t1 = -1.0;
    } else if da < 0.0 {
        *t0 = t0.max(da / (da - db));
    } else if db < 0.0 {
        *t1 = t1.min(da / (da - db));
    }
}

fn half_width_pixels(view: &RasterView, clip: Vec4, side: Vec4, inv_w: f32) -> f32 {
    let d = (Vec2::new(side.x, side.y) - Vec2::new(clip.x, clip.y) * (side.w * inv_w)) * inv_w;
    (d * 0.5 * Vec2::new(view.width as f32, view.height as f32)).length()
}

fn oct_wrap(v: Vec2) -> Vec2 {
    let s = Vec2::new(if v.x >= 0.0 { 1.0 } else { -1.0 }, if v.y >= 0.0 { 1.0 } else { -1.0 });
    (Vec2::ONE - Vec2::new(v.y.abs(), v.x.abs())) * s
}

/// 9 + 9 bits of octahedral tangent (`encode_tangent`).
pub fn encode_tangent(t: Vec3) -> u32 {
    let n = t / (t.x.abs() + t.y.abs() + t.z.abs()).max(1e-20);
    let e = if n.z >= 0.0 { Vec2::new(n.x, n.y) } else { oct_wrap(Vec2::new(n.x, n.y)) };
    let q = ((e * 0.5 + 0.5) * 511.0).round().clamp(Vec2::ZERO, Vec2::splat(511.0));
    ((q.x as u32) << 9) | q.y as u32
}

/// The unit vector of [`encode_tangent`]'s bits.
pub fn decode_tangent(bits: u32) -> Vec3 {
    let e = Vec2::new(((bits >> 9) & 511) as f32, (bits & 511) as f32) / 511.0 * 2.0 - 1.0;
    let mut n = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
    if n.z < 0.0 {
        let w = oct_wrap(Vec2::new(n.x, n.y));
        n.x = w.x;
        n.y = w.y;
    }
    n.normalize()
}

fn attributes(material: u32, tangent: Vec3, tau: f32, random: f32) -> u64 {
    let q_tau = (tau * 31.0).round().clamp(0.0, 31.0) as u64;
    let q_random = (random * 32.0).floor().clamp(0.0, 31.0) as u64;
    (u64::from(material & (MAX_MATERIALS as u32 - 1)) << 32)
        | (u64::from(encode_tangent(tangent)) << 14)
        | (q_tau << 9)
        | (q_random << 4)
}

/// Bit position of the view depth in a visibility word (`DEPTH_SHIFT`).
pub const DEPTH_SHIFT: u32 = 42;

/// The visibility word of a fragment at view depth `w` (its coverage bits 0).
pub fn visibility_word(w: f32, material: u32, tangent: Vec3, tau: f32, random: f32) -> u64 {
    (u64::from(w.to_bits() >> 9) << DEPTH_SHIFT) | attributes(material, tangent, tau, random)
}

/// The coverage bits of a fragment of coverage `c > 0` (`coverage_bits`): 1..15.
pub fn coverage_bits(c: f32) -> u64 {
    (c * 15.0).round().clamp(1.0, 15.0) as u64
}

/// The view depth a visibility word holds (the middle of its quantization step).
pub fn visibility_depth(word: u64) -> f32 {
    f32::from_bits((((word >> DEPTH_SHIFT) as u32) << 9) | 256)
}

/// The coverage increment of a fragment of alpha `a` (`coverage_increment`).
pub fn coverage_increment(a: f32) -> u32 {
    (-(1.0 - a.min(0.999)).ln() * COVERAGE_SCALE + 0.5) as u32
}

/// One slot (K = 1), strands of opacity 1.
fn fragment(out: &mut RasterBuffers, pixel: usize, coverage: f32, word: u64) {
    out.visibility[pixel] = out.visibility[pixel].min(word);
    if out.coverage[pixel] < u64::from(COVERAGE_LIMIT) {
        out.coverage[pixel] += u64::from(coverage_increment(coverage));
    }
}

/// One column's (or row's) fragment attributes, as the kernel interpolates them.
struct Column {
    /// View depth (clip w).
    w: f32,
    /// Vulkan depth (NDC z), linear in screen space.
    z: f32,
    tangent: Vec3,
    tau: f32,
}

/// The kernel's segment walker (`raster_segment`): every pixel the segment's footprint
/// covers goes to `fragment(pixel, coverage, column)`.
fn walk_segment(
    view: &RasterView,
    a: &RasterVertex,
    b: &RasterVertex,
    mut fragment: impl FnMut(usize, f32, &Column),
) {
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    clip_range(a.clip.z, b.clip.z, &mut t0, &mut t1);
    clip_range(a.clip.w - a.clip.z, b.clip.w - b.clip.z, &mut t0, &mut t1);
    if !(t0 < t1) {
        return;
    }
    // Unclipped segments keep their ends' projections, as the kernel does.
    let (p, q) = if t0 > 0.0 || t1 < 1.0 {
        (project_vertex(view, mix_vertex(a, b, t0)), project_vertex(view, mix_vertex(a, b, t1)))
    } else {
        (*a, *b)
    };
    if !(p.clip.w > 1e-20) || !(q.clip.w > 1e-20) {
        return;
    }
    let (sp, sq) = (p.screen, q.screen);
    let (hp, hq) = (p.half_width, q.half_width);
    let d = sq - sp;
    let len = d.length();
    if !(len > 1e-6) || !(hp + hq > 0.0) {
        return;
    }
    let x_major = d.x.abs() >= d.y.abs();
    let (a_major, a_minor, d_major, d_minor) =
        if x_major { (sp.x, sp.y, d.x, d.y) } else { (sp.y, sp.x, d.y, d.x) };
    let (size_major, size_minor) = if x_major {
        (view.width as i32, view.height as i32)
    } else {
        (view.height as i32, view.width as i32)
    };
    let lo = a_major.min(a_major + d_major);
    let hi = a_major.max(a_major + d_major);
    let first = ((lo - 0.5).ceil() as i32).max(0);
    let last = (((hi - 0.5).ceil() as i32) - 1).min(size_major - 1);
    let inv_d_major = 1.0 / d_major;
    let stretch = len * inv_d_major.abs();
    let (inv_wp, inv_wq) = (p.inv_w, q.inv_w);
    let (zp, zq) = (p.z, q.z);
    for i in first..=last {
        let t = (i as f32 + 0.5 - a_major) * inv_d_major;
        let m = a_minor + t * d_minor;
        let h = (hp + (hq - hp) * t) * stretch;
        let inv_w = inv_wp + (inv_wq - inv_wp) * t;
        let w = 1.0 / inv_w;
        let tq = t * inv_wq * w;
        let column = Column {
            w,
            z: zp + (zq - zp) * t,
            tangent: p.tangent.lerp(q.tangent, tq),
            tau: p.tau + (q.tau - p.tau) * tq,
        };
        let j0 = ((m - h).floor() as i32).max(0);
        let j1 = ((m + h).floor() as i32).min(size_minor - 1);
        for j in j0..=j1 {
            let coverage = (m + h).min((j + 1) as f32) - (m - h).max(j as f32);
            let (x, y) = if x_major { (i, j) } else { (j, i) };
            fragment(y as usize * view.width as usize + x as usize, coverage, &column);
        }
    }
}

/// A light's deep opacity maps as the compute shadow kernels fill them
/// (`shadow_raster.glsl`): the nearest hair depth's bits per texel and the fixed-point
/// opacity sums of the three layers behind it (and one unused word).
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowMaps {
    pub depth_bits: Vec<u32>,
    pub opacity: Vec<[u32; 4]>,
    /// Layer ends (world units).
    pub ends: [f32; 3],
    /// Near, far, 1 = perspective (the light's depth parameters).
    pub depth: [f32; 3],
}

impl ShadowMaps {
    /// Empty maps of `texels` texels: depth at the far plane, no opacity.
    pub fn new(texels: usize, ends: [f32; 3], depth: [f32; 3]) -> Self {
        Self { depth_bits: vec![1f32.to_bits(); texels], opacity: vec![[0; 4]; texels], ends, depth }
    }

    fn linear_depth(&self, z: f32) -> f32 {
        let [n, f, perspective] = self.depth;
        if perspective > 0.5 { n * f / (f - z * (f - n)) } else { n + z * (f - n) }
    }
}

/// Rasterizes one strand into `maps` as the compute shadow kernels do: with `opacity`
/// false the nearest depth, else (over the depth already there) the opacity sums.
pub fn shadow_strand(view: &RasterView, maps: &mut ShadowMaps, strand: &[StrandPoint], opacity: bool) {
    let vertices: Vec<RasterVertex> = strand.iter().map(|v| raster_vertex(view, v)).collect();
    for pair in vertices.windows(2) {
        walk_segment(view, &pair[0], &pair[1], |texel, coverage, c| {
            if !(coverage > 0.0) {
                return;
            }
            if !opacity {
                let bits = c.z.max(0.0).to_bits();
                maps.depth_bits[texel] = maps.depth_bits[texel].min(bits);
                return;
            }
            let d = maps.linear_depth(c.z) - maps.linear_depth(f32::from_bits(maps.depth_bits[texel]));
            let add =
                (coverage.min(1.0) * crate::shadow::STRAND_OPACITY * crate::shadow::SHADOW_OPACITY_SCALE
                    + 0.5) as u32;
            for layer in 0..3 {
                if d <= maps.ends[layer] && maps.opacity[texel][layer] < crate::shadow::SHADOW_OPACITY_LIMIT {
                    maps.opacity[texel][layer] += add;
                }
            }
        });
    }
}

/// Every fragment of one strand as the GPU kernels make it: `fragment(pixel, coverage,
/// word)` for each pixel its segments cover (coverage > 0), with the visibility word
/// (coverage bits included).
pub fn strand_fragments(
    view: &RasterView,
    strand: &[StrandPoint],
    material: u32,
    random: f32,
    mut fragment: impl FnMut(usize, f32, u64),
) {
    let vertices: Vec<RasterVertex> = strand.iter().map(|v| raster_vertex(view, v)).collect();
    for pair in vertices.windows(2) {
        walk_segment(view, &pair[0], &pair[1], |pixel, coverage, c| {
            if coverage > 0.0 {
                let word = visibility_word(c.w, material, c.tangent, c.tau, random);
                fragment(pixel, coverage, word | coverage_bits(coverage));
            }
        });
    }
}

/// Rasterizes one strand (its vertices in order) into `out` with one slot, as the GPU
/// kernels do.
pub fn raster_strand(
    view: &RasterView,
    out: &mut RasterBuffers,
    strand: &[StrandPoint],
    material: u32,
    random: f32,
) {
    strand_fragments(view, strand, material, random, |pixel, coverage, word| {
        fragment(out, pixel, coverage, word);
    });
}
