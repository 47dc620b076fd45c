//! The scene's lights and each character's shading constants as the shaders read them.

use super::*;

/// `Shading` push constants of the hair fragment stages (after the pre-raster bytes; see
/// `shading_constants.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Shading {
    pub(super) model: [f32; 16],
    pub(super) eye: [f32; 4],
    pub(super) hair_color: [f32; 4],
    pub(super) specular_shift: [f32; 4],
    pub(super) specular_strength: [f32; 4],
    pub(super) hair_opacity: [f32; 4],
    /// The character's hair volume: object → voxel is `(p − xyz) · w`; its grid (dims, first
    /// voxel); (first brick, bit 0 AO, bit 1 volume shadows). Zero without volumes.
    pub(super) volume_box: [f32; 4],
    pub(super) volume_grid: [u32; 4],
    pub(super) volume_info: [u32; 4],
}

/// `SceneLight` of `lighting.glsl` (std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GpuLight {
    vector: [f32; 4],
    color: [f32; 4],
    view_proj: [f32; 16],
    layer_ends: [f32; 4],
    map: [f32; 4],
    depth: [f32; 4],
}

impl SceneRenderer {
    pub(crate) fn shading(&self, c: &SceneCharacter, eye: Vec3) -> Shading {
        Shading {
            model: c.transform.to_cols_array(),
            eye: eye.extend(self.scene.lights().len() as f32).to_array(),
            hair_color: Vec4::new(c.color[0], c.color[1], c.color[2], c.variation).to_array(),
            specular_shift: [-0.08, 0.12, 80.0, 12.0],
            specular_strength: [0.25, 0.35, 0.2, 0.6],
            // Opaque mode draws strands solid (coverage aside); OIT lets a strand transmit.
            hair_opacity: [if self.oit.is_some() { 0.7 } else { 1.0 }, 0.0, 0.0, 0.0],
            volume_box: [0.0; 4],
            volume_grid: [0; 4],
            volume_info: [0; 4],
        }
    }

    /// The lights buffer of `lighting.glsl`: every light, with its shadow maps' place.
    pub(super) fn light_data(&self, atlas: Option<&ShadowAtlas>) -> Vec<GpuLight> {
        let shadow_lights = self.scene.shadow_lights();
        self.scene
            .lights()
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let vector = match *l {
                    Light::Directional { direction, .. } => {
                        Vec3::from_array(direction).normalize().extend(0.0)
                    }
                    Light::Point { position, .. } => Vec3::from_array(position).extend(1.0),
                };
                let shadow = atlas.and_then(|a| {
                    shadow_lights.iter().position(|&s| s == i).and_then(|k| a.lights.get(k)).map(|ls| (a, ls))
                });
                let (view_proj, layer_ends, map, depth) = match shadow {
                    Some((a, ls)) => (
                        ls.light_view_proj,
                        [ls.layer_ends[0], ls.layer_ends[1], ls.layer_ends[2], 0.0],
                        [a.size as f32, ls.first_texel as f32, ls.occluder_bias, 0.0],
                        ls.depth_params,
                    ),
                    None => (Mat4::IDENTITY, [0.0; 4], [0.0; 4], [0.0; 4]),
                };
                let [r, g, b] = l.color();
                let casts = matches!(
                    l,
                    Light::Directional { cast_shadows: true, .. } | Light::Point { cast_shadows: true, .. }
                );
                // w: the hair's volume shadows it from this light (`light_volume_shadows`).
                let volume_shadows = self.effects.volume_shadows && casts;
                let depth = [depth[0], depth[1], depth[2], if volume_shadows { 1.0 } else { 0.0 }];
                GpuLight {
                    vector: vector.to_array(),
                    color: [r, g, b, 0.0],
                    view_proj: view_proj.to_cols_array(),
                    layer_ends,
                    map,
                    depth,
                }
            })
            .collect()
    }
}
