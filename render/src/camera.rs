//! Cameras: a perspective camera, its Vulkan view-projection, and a character's generation
//! inputs seen through it (the camera moved into the character's object space).

use gen_gpu::FrameInputs;
use glam::{Mat4, Vec3};
use hairmesh::reference::{LodParams, Projection, ViewParams};

/// How a frame is drawn: the camera, the image size, the generation path and the LOD
/// settings.
#[derive(Clone, Copy, Debug)]
pub struct FrameView {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub path: gen_gpu::GenerationPath,
    pub lod: LodParams,
}

/// One character: which uploaded hair, and where (object → world).
#[derive(Clone, Copy, Debug)]
pub struct Character {
    pub hair: usize,
    pub transform: Mat4,
}

/// A perspective camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub fov_y: f32,
}

/// Near and far planes of every perspective camera (world units). Depth output is linearized
/// with them.
pub const NEAR: f32 = 0.01;
pub const FAR: f32 = 1000.0;

/// The eight corners of the box `lo`–`hi` (corner k takes `hi` on axis i when bit i of k is set).
pub fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Where a box lands on a `width`×`height` screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BoxOnScreen {
    /// Every corner in front of the near plane: the bounds of their projections in pixels
    /// (x right, y down; not clamped to the screen).
    InFront { lo: glam::Vec2, hi: glam::Vec2 },
    /// Corners on both sides of the near plane, or a non-finite one: its projection is
    /// unbounded, so a caller must assume it may cover the whole screen.
    Straddling,
    /// Every corner behind the near plane: nothing of it is visible.
    Behind,
}

/// Projects the box `lo`–`hi` through `object_to_clip` (the one rule the raster's dispatch
/// rectangles, the raymarch rectangles and the volume LOD's sizes share).
pub fn project_box(object_to_clip: Mat4, lo: Vec3, hi: Vec3, width: u32, height: u32) -> BoxOnScreen {
    let size = glam::Vec2::new(width as f32, height as f32);
    let mut bounds = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
    let mut behind = 0;
    for corner in box_corners(lo, hi) {
        let clip = object_to_clip * corner.extend(1.0);
        if !clip.is_finite() {
            return BoxOnScreen::Straddling;
        }
        if clip.w <= NEAR {
            behind += 1;
            continue;
        }
        let p = (glam::Vec2::new(clip.x, clip.y) / clip.w * 0.5 + 0.5) * size;
        bounds = (bounds.0.min(p), bounds.1.max(p));
    }
    match behind {
        0 => BoxOnScreen::InFront { lo: bounds.0, hi: bounds.1 },
        8 => BoxOnScreen::Behind,
        _ => BoxOnScreen::Straddling,
    }
}

/// World space → Vulkan clip space (y down, depth in [0, 1]) of `camera`.
pub fn view_proj(camera: &Camera, width: u32, height: u32) -> Mat4 {
    let aspect = width as f32 / height.max(1) as f32;
    let proj = Mat4::perspective_rh(camera.fov_y, aspect, NEAR, FAR);
    let flip = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
    flip * proj * gen_gpu::view_matrix(camera.eye, camera.target)
}

/// The per-character generation inputs: the camera moved into the character's object space.
pub fn character_inputs(
    camera: &Camera,
    character: &Character,
    width: u32,
    height: u32,
    lod: LodParams,
) -> FrameInputs {
    let object_eye = character.transform.inverse().transform_point3(camera.eye);
    // LOD distances are measured in object space; a uniformly scaled character scales them.
    FrameInputs {
        view_proj: view_proj(camera, width, height) * character.transform,
        view: ViewParams {
            eye: object_eye.as_dvec3(),
            vertical_resolution: f64::from(height),
            projection: Projection::Perspective { fov_y: f64::from(camera.fov_y) },
        },
        lod,
        viewport: [width, height],
        cull: true,
    }
}

#[cfg(test)]
mod box_tests {
    use super::{BoxOnScreen, Camera, project_box, view_proj};
    use glam::{Mat4, Vec3};

    #[test]
    fn boxes_project_in_front_straddling_or_behind() {
        let camera = Camera { eye: Vec3::new(0.0, 0.0, 5.0), target: Vec3::ZERO, fov_y: 0.8 };
        let m = view_proj(&camera, 200, 100);
        let unit = |c: Vec3| (c - Vec3::splat(0.5), c + Vec3::splat(0.5));
        let (lo, hi) = unit(Vec3::ZERO);
        match project_box(m, lo, hi, 200, 100) {
            BoxOnScreen::InFront { lo, hi } => {
                // Centred on the screen, a few dozen pixels across.
                assert!((0.5 * (lo + hi) - glam::Vec2::new(100.0, 50.0)).length() < 1e-3, "{lo} {hi}");
                assert!((hi - lo).min_element() > 10.0 && (hi - lo).max_element() < 60.0, "{lo} {hi}");
            }
            other => panic!("{other:?}"),
        }
        let (lo, hi) = unit(Vec3::new(0.0, 0.0, 5.0));
        assert_eq!(project_box(m, lo, hi, 200, 100), BoxOnScreen::Straddling, "around the eye");
        let (lo, hi) = unit(Vec3::new(0.0, 0.0, 9.0));
        assert_eq!(project_box(m, lo, hi, 200, 100), BoxOnScreen::Behind);
        let nan = Mat4::from_cols_array(&[f32::NAN; 16]);
        assert_eq!(project_box(nan, Vec3::ZERO, Vec3::ONE, 200, 100), BoxOnScreen::Straddling);
    }
}
