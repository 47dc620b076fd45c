#version 460
// Volume resolve (render/src/volume.rs): per voxel, the voxelization's fixed-point sums become
// the area density σ (projected strand area per voxel volume, voxel units: the optical depth per
// voxel of travel across perpendicular strands, before their opacity) and the mean strand
// direction (unit where the strands agree, shorter where they cross, 0 where there are none);
// the AO starts at 1 (none). CPU port: volume.rs cpu::resolve.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "hk_render_contract.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = HK_BINDING_VOXEL_SUMS) readonly buffer SumBuffer { uint64_t sums[]; };
layout(std430, set = 0, binding = HK_BINDING_VOLUME) writeonly buffer VolumeBuffer { vec4 volume[]; };
layout(std430, set = 0, binding = HK_BINDING_VOLUME_AO) writeonly buffer AoBuffer { float volume_ao[]; };

layout(push_constant) uniform VolumeParams {
    uvec4 dims;  // xyz voxels per axis, w: the region's first voxel
    vec4 ao;     // unused here
    uvec4 first; // x: the region's first brick (unused here)
} region;

const float AREA_SCALE = 1048576.0;

void main() {
    uint voxel = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x;
    if (voxel >= region.dims.x * region.dims.y * region.dims.z) {
        return;
    }
    float area = float(sums[4u * voxel]) / AREA_SCALE;
    vec3 direction = vec3(float(int64_t(sums[4u * voxel + 1u])), float(int64_t(sums[4u * voxel + 2u])),
                          float(int64_t(sums[4u * voxel + 3u]))) / AREA_SCALE;
    vec3 mean = area > 0.0 ? direction / area : vec3(0.0);
    // Rounding may leave the mean a hair over unit length.
    float l = length(mean);
    mean = l > 1.0 ? mean / l : mean;
    volume[region.dims.w + voxel] = vec4(mean, area);
    volume_ao[region.dims.w + voxel] = 1.0;
}
