// The fragment-stage side of hair shading: a strand pipeline's varyings (gen-gpu's contract)
// and the Shading push constants become shade_hair's explicit inputs.

#include "hk_gen_contract.glsl"

layout(location = HK_LOCATION_POSITION_TAU) in vec4 v_position_tau;
layout(location = HK_LOCATION_TANGENT_RANDOM) in vec4 v_tangent_random;
layout(location = HK_LOCATION_COVERAGE_SIDE) in vec4 v_coverage_side;

#include "shading_constants.glsl"
#include "hk_render_contract.glsl"

// The hair volumes (render/src/volume.rs), read when shading.volume_info.y asks for AO or
// volume shadows.
#include "volume_ao.glsl"
layout(std430, set = 0, binding = HK_BINDING_VOLUME) readonly buffer VolumeBuffer { vec4 volume[]; };
layout(std430, set = 0, binding = HK_BINDING_VOLUME_BRICKS) readonly buffer BrickBuffer { uint bricks[]; };
#include "volume_sample.glsl"

// Hair shading with volume shadows: the light through the character's own hair volume.
float fragment_light_transmittance(uint i, vec3 p);
#define HAIR_LIGHT_TRANSMITTANCE(i, p) fragment_light_transmittance(i, p)
#include "hair_shading.glsl"

// Object-space point -> voxel coordinates of the character's volume.
vec3 fragment_voxel_point(vec3 object_position) {
    return (object_position - shading.volume_box.xyz) * shading.volume_box.w;
}

// The maps' light (occluders, and the hair unless the volume shadows it), times the
// transmittance of the character's hair volume from world point p toward light i (half a voxel
// on, so a fragment does not shadow itself).
float fragment_light_transmittance(uint i, vec3 p) {
    vec2 maps = light_visibility(i, p);
    if ((shading.volume_info.y & 2u) == 0u || !light_volume_shadows(i)) {
        return maps.x * maps.y;
    }
    mat4 world_to_object = inverse(shading.model);
    vec3 origin = fragment_voxel_point((world_to_object * vec4(p, 1.0)).xyz);
    vec3 direction = mat3(world_to_object) * light_direction(i, p) * shading.volume_box.w;
    vec4 lv = lights[i].vector;
    float t1 = lv.w > 0.5 ? distance(lv.xyz, p) : 1e30;
    float t0 = 0.5 / max(length(direction), 1e-20);
    return maps.x * volume_transmittance(shading.volume_grid, shading.volume_info.x, origin, direction, t0, t1,
                                         shading.hair_opacity.x);
}

// AO at an object-space point (1 without AO).
float fragment_ambient_occlusion(vec3 object_position) {
    if ((shading.volume_info.y & 1u) == 0u) {
        return 1.0;
    }
    return volume_ao_sample(shading.volume_grid, fragment_voxel_point(object_position));
}

HairSample hair_sample_from_varyings() {
    return HairSample(v_position_tau.xyz, v_position_tau.w, v_tangent_random.xyz, v_tangent_random.w,
                      v_coverage_side.x, fragment_ambient_occlusion(v_position_tau.xyz));
}

HairMaterial hair_material_from_push_constants() {
    return HairMaterial(shading.model, shading.eye.xyz, uint(shading.eye.w), shading.hair_color,
                        shading.specular_shift, shading.specular_strength, shading.hair_opacity.x);
}

// This fragment's premultiplied colour.
vec4 shade_hair_fragment() {
    return shade_hair(hair_sample_from_varyings(), hair_material_from_push_constants());
}
