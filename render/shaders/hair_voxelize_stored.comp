#version 460
// Voxelization of stored strands (an artist's groom uploaded once; render/src/volume.rs): one
// invocation per slot of a strand buffer in gen-gpu's layout samples its segments as the fused
// kernel does (voxelize_common.glsl).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#define HAIR_GEN_NO_WORKGROUP
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#include "dispatch_order.glsl"
#include "hk_render_contract.glsl"

layout(local_size_x = 32) in;

#include "voxelize_common.glsl"

void main() {
    // In the dispatch order (dispatch_order.glsl).
    uint slot = ORDERED_GLOBAL_INVOCATION_ID.x;
    if (slot >= vox.dims.w) {
        return;
    }
    uint n = min(strand_info[slot].z, MAX_VERTICES);
    float to_voxels = length(vox.object_to_voxel[0].xyz);
    vec3 previous = vec3(0.0);
    float previous_width = 0.0;
    for (uint k = 0u; k < n; ++k) {
        vec4 point = strand_vertices[(slot * MAX_VERTICES + k) * 2u];
        vec3 q = (vox.object_to_voxel * vec4(point.xyz, 1.0)).xyz;
        float width = point.w * to_voxels;
        if (k > 0u) {
            voxelize_segment(previous, q, previous_width, width);
        }
        previous = q;
        previous_width = width;
    }
    flush_voxel();
}
