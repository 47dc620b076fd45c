#version 460
// Volume bricks (render/src/volume.rs): per brick of 4³ voxels, 1 when it or a voxel next to it
// holds hair — every voxel a trilinear sample inside the brick reads — else 0: the raymarch
// jumps over the bricks marked 0. CPU port: volume.rs cpu::occupied_bricks.
#extension GL_GOOGLE_include_directive : require
#include "hk_render_contract.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = HK_BINDING_VOLUME) readonly buffer VolumeBuffer { vec4 volume[]; };
layout(std430, set = 0, binding = HK_BINDING_VOLUME_BRICKS) writeonly buffer BrickBuffer { uint bricks[]; };

layout(push_constant) uniform VolumeParams {
    uvec4 dims;    // xyz voxels per axis, w: the region's first voxel
    vec4 ao;       // unused here
    uvec4 first;   // x: the region's first brick
} region;

const int BRICK = 4;

void main() {
    uint brick = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    ivec3 d = ivec3(region.dims.xyz);
    ivec3 nb = (d + BRICK - 1) / BRICK;
    if (brick >= uint(nb.x * nb.y * nb.z)) {
        return;
    }
    ivec3 b = ivec3(int(brick) % nb.x, (int(brick) / nb.x) % nb.y, int(brick) / (nb.x * nb.y));
    ivec3 lo = max(b * BRICK - 1, ivec3(0));
    ivec3 hi = min((b + 1) * BRICK + 1, d);
    uint any_hair = 0u;
    for (int z = lo.z; z < hi.z && any_hair == 0u; ++z) {
        for (int y = lo.y; y < hi.y && any_hair == 0u; ++y) {
            for (int x = lo.x; x < hi.x; ++x) {
                if (volume[region.dims.w + uint((z * d.y + y) * d.x + x)].w > 0.0) {
                    any_hair = 1u;
                    break;
                }
            }
        }
    }
    bricks[region.first.x + brick] = any_hair;
}
