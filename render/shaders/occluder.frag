#version 460
// Occluder shading: Lambert with every scene light, shadowed by the hair's deep opacity maps and
// by other occluders, darkened by its character's hair AO; both sides of the surface are lit
// (scalp meshes are often open).
#extension GL_GOOGLE_include_directive : require

layout(push_constant) uniform Occluder {
    mat4 model;
    mat4 view_proj;
    vec4 eye;
    vec4 color;
    mat4 world_to_voxel;  // the character's hair volume (AO), when volume.x > 0
    uvec4 volume;         // voxels per axis, first voxel
} occluder;

#include "lighting.glsl"
#include "volume_ao.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 0) out vec4 out_color;

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(occluder.eye.xyz - v_position);
    if (dot(n, v) < 0.0) {
        n = -n;
    }
    vec3 albedo = occluder.color.rgb;
    vec3 color = albedo * occluder.color.w;
    uint light_count = uint(occluder.eye.w);
    // Light by light with constant indices (lighting.glsl).
#define OCCLUDER_LIGHT_TURN(I) \
    { \
        vec3 l = light_direction(I, v_position); \
        float lambert = max(dot(n, l), 0.0); \
        if (lambert > 0.0) { \
            color += albedo * lights[I].color.rgb * lambert * light_transmittance(I, v_position); \
        } \
    }
    FOR_EACH_SCENE_LIGHT(light_count, OCCLUDER_LIGHT_TURN)
#undef OCCLUDER_LIGHT_TURN
    // The hair's AO darkens the scalp and skin under and beside it.
    if (occluder.volume.x > 0u) {
        color *= volume_ao_sample(occluder.volume, (occluder.world_to_voxel * vec4(v_position, 1.0)).xyz);
    }
    out_color = vec4(color, 1.0);
}
