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

/// World space → Vulkan clip space (y down, depth in [0, 1]) of `camera`.
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

pub fn view_proj(camera: &Camera, width: u32, height: u32) -> Mat4 {
    let aspect = width as f32 / height.max(1) as f32;
    let proj = Mat4::perspective_rh(camera.fov_y, aspect, NEAR, FAR);
    let flip = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
    flip * proj * Mat4::look_at_rh(camera.eye, camera.target, Vec3::Y)
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
