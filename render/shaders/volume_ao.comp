#version 460
// Volume ambient occlusion (render/src/volume.rs): per voxel, the transmittance of the hair
// within R voxels averaged over the 26 neighbour directions: along each, the σ of the voxels at
// steps 1..R (one voxel long each; outside the grid is empty) times the strand opacity and π/4
// (the mean |sin| between a strand and a random direction) is the optical depth τ, and
// ao = mean exp(-τ). Averaging the transmittances, not the densities, keeps a point on the
// hair's surface half lit, as its open half-space lets it be. CPU port: volume.rs
// cpu::ambient_occlusion.
#extension GL_GOOGLE_include_directive : require
#include "hk_render_contract.glsl"
#include "dispatch_order.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = HK_BINDING_VOLUME) readonly buffer VolumeBuffer { vec4 volume[]; };
layout(std430, set = 0, binding = HK_BINDING_VOLUME_AO) writeonly buffer AoBuffer { float volume_ao[]; };

layout(push_constant) uniform VolumeParams {
    uvec4 dims;  // xyz voxels per axis, w: the region's first voxel
    vec4 ao;     // x: radius R in voxels (1..4), y: strand opacity
    uvec4 first; // x: the region's first brick (unused here)
} region;

const float MEAN_SIN = 0.78539816;

// Voxel offset of step s (1..R) along neighbour direction d (components in {-1, 0, 1}):
// round(s · d / |d|). No product lands on a half, so the CPU port rounds alike.
ivec3 step_offset(ivec3 d, int s) {
    return ivec3(round(vec3(d) * (float(s) / length(vec3(d)))));
}

void main() {
    // In the dispatch order (dispatch_order.glsl): empty voxels leave at once, so on CPU devices
    // a worker thread given the region's empty half would sit idle.
    uvec3 id = ORDERED_GLOBAL_INVOCATION_ID;
    uint voxel = id.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + id.x;
    uvec3 dims = region.dims.xyz;
    if (voxel >= dims.x * dims.y * dims.z) {
        return;
    }
    ivec3 c = ivec3(voxel % dims.x, (voxel / dims.x) % dims.y, voxel / (dims.x * dims.y));
    int r = int(region.ao.x);
    float sum = 0.0;
    for (int k = 0; k < 27; ++k) {
        ivec3 d = ivec3(k % 3, (k / 3) % 3, k / 9) - 1;
        if (d == ivec3(0)) {
            continue;
        }
        float depth = 0.0;
        for (int s = 1; s <= r; ++s) {
            ivec3 p = c + step_offset(d, s);
            if (any(lessThan(p, ivec3(0))) || any(greaterThanEqual(p, ivec3(dims)))) {
                break;
            }
            depth += volume[region.dims.w + (uint(p.z) * dims.y + uint(p.y)) * dims.x + uint(p.x)].w;
        }
        sum += exp(-depth * region.ao.y * MEAN_SIN);
    }
    volume_ao[region.dims.w + voxel] = sum / 26.0;
}
