//! The viewport's orbit camera, and the projection the overlay and picking share with the
//! renderer ([`render::camera::view_proj`]): a vertex drawn by the overlay lies exactly where
//! the preview draws it.

use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

/// An orbit camera around `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
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

#[cfg(test)]
mod tests {
    use super::*;

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
