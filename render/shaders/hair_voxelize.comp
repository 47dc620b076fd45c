#version 460
// Voxelization fused with generation (render/src/volume.rs): one invocation generates a strand
// (gen-gpu's strand-coherent evaluation, as the compute rasterizer's hair_raster.comp) at full
// detail and samples each of its segments once per voxel of its length; each sample adds its share
// of the segment's projected area (length × width, voxel units) and that area times the
// segment's direction to the voxel it falls in, as 64-bit fixed point (exact sums in any order).
// Dispatched over the strands of a LOD pass without culling (volume.rs voxelization_inputs). CPU port:
// volume.rs cpu::voxelize.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#include "hk_render_contract.glsl"

layout(local_size_x = 32) in;

#include "voxelize_common.glsl"

void main() {
    uint slot;
    if (!invocation_slot(0u, slot)) {
        return;
    }
    uint bundle = slot_bundle(slot);
    uint strand = slot - offsets[bundle];
    BundleLod l = lods[bundle];
    uint segments = 1u << l.level;
    StrandStream s = strand_stream(bundle, strand, l, PER_VERTEX_FETCH == 0u);
    float to_voxels = length(vox.object_to_voxel[0].xyz);
    vec3 previous = vec3(0.0);
    float previous_width = 0.0;
    for (uint k = 0u; k <= segments; ++k) {
        float tau = float(k) / float(segments);
        vec3 q = (vox.object_to_voxel * vec4(strand_stream_point(s, k), 1.0)).xyz;
        float width = width_at(tau) * l.width_scale * to_voxels;
        if (k > 0u) {
            voxelize_segment(previous, q, previous_width, width);
        }
        previous = q;
        previous_width = width;
    }
    flush_voxel();
}
