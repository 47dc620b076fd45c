//! The viewport's orbit camera, and the projection the overlay and picking share with the
//! renderer ([`render::camera::view_proj`]): a vertex drawn by the overlay lies exactly where
//! the preview draws it.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

/// An orbit camera around `target`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OrbitCamera {
    pub target: Vec3,
    /// Radians about +Y; 0 looks along −Z (from +Z toward the target).
    pub yaw: f32,
    /// Radians above the horizon, within ±89°.
    pub pitch: f32,
    pub distance: f32,
    pub fov_y_degrees: f32,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        Self { target: Vec3::ZERO, yaw: 0.5, pitch: 0.25, distance: 3.0, fov_y_degrees: 35.0 }
    }
}

const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;

impl OrbitCamera {
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(cp * sy, sp, cp * cy)
    }

    /// The renderer's camera.
    pub fn camera(&self) -> render::camera::Camera {
        render::camera::Camera {
            eye: self.eye(),
            target: self.target,
            fov_y: self.fov_y_degrees.to_radians(),
        }
    }

    /// Rotates by a pointer motion of `delta` pixels (a full turn per 600 px).
    pub fn orbit(&mut self, delta: Vec2) {
        let per_pixel = std::f32::consts::TAU / 600.0;
        self.yaw -= delta.x * per_pixel;
        self.pitch = (self.pitch + delta.y * per_pixel).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves the target in the view plane by `delta` pixels of a viewport `height` pixels high:
    /// the point under the pointer stays under it.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        let (right, up) = self.basis();
        let world_per_pixel = self.world_per_pixel(self.distance, height);
        self.target += (-delta.x * right + delta.y * up) * world_per_pixel;
    }

    /// Zooms by `steps` (positive: closer), 10 % per step.
    pub fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(1e-3, 1e5);
    }

    /// Looks at the box `lo`–`hi` from the current direction, filling about 80 % of the view.
    pub fn frame(&mut self, lo: Vec3, hi: Vec3) {
        if !(lo.is_finite() && hi.is_finite()) || hi.cmplt(lo).any() {
            return;
        }
        self.target = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        // The bounding sphere fills 80 % of the half-height.
        self.distance = radius / (0.8 * (0.5 * self.fov_y_degrees.to_radians()).tan()).max(1e-3);
    }

    /// The camera's right and up vectors (world space).
    pub fn basis(&self) -> (Vec3, Vec3) {
        let forward = (self.target - self.eye()).normalize_or(Vec3::NEG_Z);
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        (right, right.cross(forward))
    }

    /// World units per pixel at `depth` in front of the camera, for a viewport `height` high.
    pub fn world_per_pixel(&self, depth: f32, height: f32) -> f32 {
        2.0 * depth * (0.5 * self.fov_y_degrees.to_radians()).tan() / height.max(1.0)
    }

    /// A world point moved by `delta` pixels in the view plane through it.
    pub fn drag_point(&self, point: Vec3, delta: Vec2, height: f32) -> Vec3 {
        let (right, up) = self.basis();
        let forward = (self.target - self.eye()).normalize_or(Vec3::NEG_Z);
        let depth = (point - self.eye()).dot(forward).max(1e-4);
        point + (delta.x * right - delta.y * up) * self.world_per_pixel(depth, height)
    }
}

/// World → pixel coordinates of a `size` viewport seen through a camera.
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    view_proj: Mat4,
    size: Vec2,
}

impl Projection {
    pub fn new(camera: &OrbitCamera, size: Vec2) -> Self {
        let (w, h) = (size.x.max(1.0).round() as u32, size.y.max(1.0).round() as u32);
        Self { view_proj: render::camera::view_proj(&camera.camera(), w, h), size }
    }

    /// The pixel (from the viewport's top left) and depth (clip w) of `p`; `None` behind the
    /// camera.
    pub fn project(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let clip = self.view_proj * p.extend(1.0);
        // Behind the camera, or not a point (NaN marks points to leave out).
        if !(clip.w > 1e-6 && clip.is_finite()) {
            return None;
        }
        let ndc = clip.xy() / clip.w;
        // view_proj is Vulkan's clip space: y already points down.
        Some(((ndc * 0.5 + 0.5) * self.size, clip.w))
    }
}

/// The index of the point whose projection is nearest to `pointer` within `radius` pixels
/// (the nearest to the camera among ties), or `None`.
pub fn pick(
    projection: &Projection,
    points: impl Iterator<Item = Vec3>,
    pointer: Vec2,
    radius: f32,
) -> Option<usize> {
    let mut best: Option<(usize, f32, f32)> = None;
    for (i, p) in points.enumerate() {
        let Some((pixel, depth)) = projection.project(p) else { continue };
        let d = pixel.distance(pointer);
        if d > radius {
            continue;
        }
        let better = match best {
            None => true,
            Some((_, bd, bz)) => d + 0.5 < bd || (d - bd).abs() <= 0.5 && depth < bz,
        };
        if better {
            best = Some((i, d, depth));
        }
    }
    best.map(|(i, _, _)| i)
}

/// The nearest depth (clip w) of a mesh per cell of a coarse grid over the viewport: what the
/// overlay tests hair-mesh vertices against, so a vertex the head hides is neither drawn bright
/// nor pickable. A CPU rasterization of the occluder's triangles (a few thousand to tens of
/// thousands: a millisecond or two at the grid's size), redone only when the view changes.
#[derive(Clone, Debug)]
pub struct DepthGrid {
    /// Viewport pixels per cell.
    cell: f32,
    width: usize,
    height: usize,
    depth: Vec<f32>,
}

impl DepthGrid {
    /// Viewport pixels per cell: fine enough for the overlay's 8-pixel pick radius.
    pub const CELL: f32 = 4.0;

    /// Rasterizes the triangles `indices` of `positions` (world space) as `projection` sees
    /// them. Triangles with a corner behind the camera are left out (they hide nothing in
    /// front of a camera outside the head).
    pub fn rasterize(projection: &Projection, positions: &[Vec3], indices: &[u32]) -> Self {
        let cell = Self::CELL;
        let width = (projection.size.x / cell).ceil().max(1.0) as usize;
        let height = (projection.size.y / cell).ceil().max(1.0) as usize;
        let mut depth = vec![f32::INFINITY; width * height];
        let corner = |i: u32| positions.get(i as usize).and_then(|&p| projection.project(p));
        for t in indices.chunks_exact(3) {
            let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) else { continue };
            // In cell units; 1/w interpolates linearly in screen space.
            let (pa, pb, pc) = (a.0 / cell, b.0 / cell, c.0 / cell);
            let area = (pb - pa).perp_dot(pc - pa);
            // Degenerate (or NaN) triangles cover nothing.
            if area.abs() <= 1e-12 || area.is_nan() {
                continue;
            }
            let lo = pa.min(pb).min(pc).floor().max(Vec2::ZERO);
            let hi = pa.max(pb).max(pc).ceil().min(Vec2::new(width as f32, height as f32));
            for y in lo.y as usize..hi.y as usize {
                for x in lo.x as usize..hi.x as usize {
                    let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let (wa, wb) = ((pb - q).perp_dot(pc - q) / area, (pc - q).perp_dot(pa - q) / area);
                    let wc = 1.0 - wa - wb;
                    if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                        continue;
                    }
                    let w = 1.0 / (wa / a.1 + wb / b.1 + wc / c.1);
                    let d = &mut depth[y * width + x];
                    *d = d.min(w);
                }
            }
        }
        Self { cell, width, height, depth }
    }

    /// Whether the mesh lies in front of a point at `pixel` and `depth` (clip w), by more than
    /// `tolerance` (a fraction of the depth: the grid is coarse, and hair roots sit on the
    /// scalp). Every cell within a cell's distance must be in front, so silhouettes stay
    /// visible.
    pub fn hides(&self, pixel: Vec2, depth: f32, tolerance: f32) -> bool {
        let c = pixel / self.cell;
        let (x, y) = (c.x.floor() as i64, c.y.floor() as i64);
        let limit = depth * (1.0 - tolerance);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (cx, cy) = (x + dx, y + dy);
                if cx < 0 || cy < 0 || cx >= self.width as i64 || cy >= self.height as i64 {
                    return false;
                }
                // NaN depth (an unusable point) hides nothing.
                if self.depth[cy as usize * self.width + cx as usize] >= limit || limit.is_nan() {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mesh_in_front_hides_points_behind_it_and_not_beside_or_before_it() {
        let cam =
            OrbitCamera { target: Vec3::ZERO, yaw: 0.0, pitch: 0.0, distance: 3.0, fov_y_degrees: 35.0 };
        let proj = Projection::new(&cam, Vec2::new(320.0, 180.0));
        // A square of side 1 at z = 0 (the camera looks along −Z from z = 3).
        let square = [
            Vec3::new(-0.5, -0.5, 0.0),
            Vec3::new(0.5, -0.5, 0.0),
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(-0.5, 0.5, 0.0),
        ];
        let grid = DepthGrid::rasterize(&proj, &square, &[0, 1, 2, 0, 2, 3]);
        let hidden = |p: Vec3| {
            let (pixel, depth) = proj.project(p).expect("in front of the camera");
            grid.hides(pixel, depth, 0.02)
        };
        assert!(hidden(Vec3::new(0.0, 0.0, -0.3)), "behind the square's centre");
        assert!(hidden(Vec3::new(0.3, -0.2, -1.0)), "behind, off centre");
        assert!(!hidden(Vec3::new(0.0, 0.0, 0.3)), "in front of the square");
        assert!(!hidden(Vec3::new(0.0, 0.0, -0.01)), "on it, within the tolerance");
        assert!(!hidden(Vec3::new(0.9, 0.0, -0.3)), "beside it");
        // Seen from z = 3, (0.55, 0, -0.3) lies right behind the square's edge x = 0.5: within a
        // cell of the silhouette a point stays visible.
        assert!(!hidden(Vec3::new(0.545, 0.0, -0.3)), "behind its edge: the silhouette stays visible");
        assert!(hidden(Vec3::new(0.45, 0.0, -0.3)), "well inside the edge, behind it");
        // Winding does not matter; a triangle with a corner behind the camera is left out.
        let grid = DepthGrid::rasterize(&proj, &square, &[0, 2, 1, 0, 3, 2]);
        assert!(grid.hides(proj.project(Vec3::new(0.0, 0.0, -0.3)).expect("front").0, 3.3, 0.02));
        let behind = [Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.5, -0.5, 0.0), Vec3::new(0.0, 0.5, 5.0)];
        let grid = DepthGrid::rasterize(&proj, &behind, &[0, 1, 2]);
        assert!(grid.depth.iter().all(|d| d.is_infinite()));
        // Out-of-range indices are skipped, not a panic.
        let grid = DepthGrid::rasterize(&proj, &square, &[0, 1, 9]);
        assert!(grid.depth.iter().all(|d| d.is_infinite()));
    }

    #[test]
    fn the_target_projects_to_the_viewport_centre_and_picks() {
        let cam = OrbitCamera::default();
        let proj = Projection::new(&cam, Vec2::new(640.0, 360.0));
        let (pixel, depth) = proj.project(cam.target).expect("in front");
        assert!(pixel.distance(Vec2::new(320.0, 180.0)) < 1e-3, "{pixel}");
        assert!((depth - cam.distance).abs() < 1e-4);
        let points = [cam.target + Vec3::X, cam.target];
        assert_eq!(pick(&proj, points.into_iter(), Vec2::new(322.0, 181.0), 8.0), Some(1));
        assert_eq!(pick(&proj, points.into_iter(), Vec2::new(10.0, 10.0), 8.0), None);
        assert_eq!(pick(&proj, [Vec3::NAN, cam.target].into_iter(), Vec2::new(320.0, 180.0), 8.0), Some(1));
    }

    #[test]
    fn a_dragged_point_follows_the_pointer() {
        let cam = OrbitCamera { yaw: 1.1, pitch: -0.4, ..OrbitCamera::default() };
        let size = Vec2::new(400.0, 300.0);
        let proj = Projection::new(&cam, size);
        let p = cam.target + Vec3::new(0.2, 0.1, -0.3);
        let (before, _) = proj.project(p).expect("in front");
        let moved = cam.drag_point(p, Vec2::new(25.0, -12.0), size.y);
        let (after, _) = proj.project(moved).expect("in front");
        // The view plane through the point, so the pointer's motion up to perspective.
        assert!((after - before).distance(Vec2::new(25.0, -12.0)) < 0.5, "{before} → {after}");
    }

    #[test]
    fn framing_keeps_the_box_in_view() {
        let mut cam = OrbitCamera::default();
        cam.frame(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0));
        let proj = Projection::new(&cam, Vec2::new(300.0, 300.0));
        for c in render::camera::box_corners(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0)) {
            let (p, _) = proj.project(c).expect("in front");
            assert!(p.cmpge(Vec2::ZERO).all() && p.cmple(Vec2::splat(300.0)).all(), "{c} → {p}");
        }
    }
}
