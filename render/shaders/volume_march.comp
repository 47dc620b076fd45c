#version 460
// Volume LOD path (render/src/volume.rs): one invocation per pixel of a character's screen
// rectangle marches the eye ray through the character's hair volume one voxel per step (jumping
// over empty bricks of 4³ voxels), trilinear samples accumulating optical depth
// σ · opacity · |sin(T, ray)| (volume_sample.glsl), from the near plane or the volume's entry to its exit or
// the occluders' depth; it stops once the ray is opaque. What it saw becomes one fragment in the
// compute rasterizer's visibility buffer — at the transmittance-weighted mean depth (where the
// light it returns comes from), with the mean tangent there, the ray's opacity as coverage and
// its optical depth in the coverage word — so the shade and resolve passes shade, composite and
// depth-sort it with the strands.
#extension GL_GOOGLE_include_directive : require
#include "visibility_write.glsl"
#include "raster_frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = HK_BINDING_VOLUME) readonly buffer VolumeBuffer { vec4 volume[]; };
// Per brick of 4³ voxels: 0 where no sample inside can see hair (volume_bricks.comp).
layout(std430, set = 0, binding = HK_BINDING_VOLUME_BRICKS) readonly buffer BrickBuffer { uint bricks[]; };
// The occluders' Vulkan depth per pixel (1 = none), read when march.info.z bit 0 is set.
layout(std430, set = 0, binding = HK_BINDING_SCENE_DEPTH) readonly buffer SceneDepthBuffer { float scene_depth[]; };

layout(push_constant) uniform MarchParams {
    mat4 world_to_voxel;
    uvec4 dims;  // xyz voxels per axis, w: the region's first voxel
    uvec4 rect;  // pixels x0, y0, x1, y1 (exclusive ends)
    uvec4 info;  // x material, y slots K, z flags (bit 0: occluders), w strand opacity (float bits)
    uvec4 extra; // x: the region's first brick, y: the transition band's volume fraction (float bits)
} march;

#include "volume_sample.glsl"
#include "dispatch_order.glsl"

// One sample per voxel travelled: trilinear samples of a grid whose voxels are about a pixel.
const uint MAX_STEPS = 2048u;

float hash_voxel(uvec3 c) {
    uint h = c.x * 73856093u ^ c.y * 19349663u ^ c.z * 83492791u;
    h = (h ^ 61u) ^ (h >> 16u);
    h *= 9u;
    h ^= h >> 4u;
    h *= 0x27d4eb2du;
    h ^= h >> 15u;
    return float(h >> 8u) / 16777216.0;
}

vec3 world_at(vec2 ndc, float z) {
    vec4 p = frame.inv_view_proj * vec4(ndc, z, 1.0);
    return p.xyz / p.w;
}

void main() {
    // Tiles in the dispatch order (dispatch_order.glsl): on CPU devices each worker thread
    // marches tiles from all over the character's rectangle.
    uvec2 xy = ORDERED_GLOBAL_INVOCATION_ID.xy + march.rect.xy;
    if (xy.x >= march.rect.z || xy.y >= march.rect.w) {
        return;
    }
    // In the transition band the volume draws only its share of the pixels.
    float fraction = uintBitsToFloat(march.extra.y);
    if (fraction < 1.0 && !(transition_dither(xy) < fraction)) {
        return;
    }
    uint pixel = xy.y * frame.size.x + xy.x;
    vec2 ndc = (vec2(xy) + 0.5) / vec2(frame.size.xy) * 2.0 - 1.0;
    vec3 eye = frame.eye.xyz;
    vec3 ray = normalize(world_at(ndc, 1.0) - eye);
    // The volume in voxel coordinates: t stays the world distance along the ray.
    vec3 origin = (march.world_to_voxel * vec4(eye, 1.0)).xyz;
    vec3 direction = volume_safe_direction(mat3(march.world_to_voxel) * ray);
    vec2 range = volume_box_range(origin, direction, vec3(march.dims.xyz));
    float t_near = dot(world_at(ndc, 0.0) - eye, ray);
    float t0 = max(range.x, t_near);
    float t1 = range.y;
    if ((march.info.z & 1u) != 0u && scene_depth[pixel] < 1.0) {
        t1 = min(t1, dot(world_at(ndc, scene_depth[pixel]) - eye, ray));
    }
    if (!(t0 < t1)) {
        return;
    }
    float opacity = uintBitsToFloat(march.info.w);
    float speed = length(direction);  // voxels per world unit along the ray
    float dt = 1.0 / speed;
    vec3 unit = direction / speed;
    float transmittance = 1.0;
    float weight = 0.0;
    float mean_t = 0.0;
    vec3 mean_tangent = vec3(0.0);
    float t = t0;
    for (uint i = 0u; i < MAX_STEPS && t < t1 && transmittance > VOLUME_OPAQUE; ++i) {
        float ts = t + 0.5 * dt;
        vec3 p = origin + direction * ts;
        float skip = volume_skip_brick(march.dims, march.extra.x, origin, direction, t, p);
        if (skip >= 0.0) {
            t = skip;
            continue;
        }
        t += dt;
        vec4 s = volume_sample(march.dims, p);
        if (!(s.w > 0.0)) {
            continue;
        }
        float alpha = 1.0 - exp(-volume_extinction(s, unit, opacity));
        float w = transmittance * alpha;
        weight += w;
        mean_t += w * ts;
        mean_tangent += w * s.xyz;
        transmittance *= 1.0 - alpha;
    }
    float a = 1.0 - transmittance;
    if (!(a > 1.0 / 512.0)) {
        return;
    }
    float t_mean = mean_t / weight;
    float view_depth = t_mean * dot(ray, frame.forward.xyz);
    if (!(view_depth > 0.0)) {
        return;
    }
    // Voxel-space directions are object-space ones; to world through the inverse.
    mat3 voxel_to_world = inverse(mat3(march.world_to_voxel));
    vec3 tangent = voxel_to_world * mean_tangent;
    if (!(length(tangent) > 1e-12)) {
        vec3 up = abs(ray.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
        tangent = cross(ray, up);
    }
    uvec3 voxel = uvec3(floor_int3(clamp(origin + direction * t_mean, vec3(0.0), vec3(march.dims.xyz) - 1.0)));
    uint k = march.info.y;
    uint first = pixel_word(pixel, k, 0u);
    uint64_t attributes = visibility_attributes(march.info.x, normalize(tangent), 0.5, hash_voxel(voxel));
    float coverage = min(a / max(opacity, 1e-6), 1.0);
    insert_visibility(first, k, visibility_word(visibility_depth_bits(view_depth), attributes)
                                    | uint64_t(coverage_bits(coverage)));
    add_coverage(first + k, uint(max(floor_int(-log(transmittance) * COVERAGE_SCALE + 0.5), 0)));
}
