#version 460
// Compute path, pass 2: one workgroup per strand slot writes its vertices.
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"

layout(local_size_x = 32) in;

void main() {
    uint slot = gl_WorkGroupID.y * DISPATCH_ROW + gl_WorkGroupID.x;
    if (slot >= min(total_strands, params.seed_info.z)) {
        return;
    }
    uint bundle = slot_bundle(slot);
    uint strand = slot - offsets[bundle];
    BundleLod l = lods[bundle];
    uint thread = gl_LocalInvocationID.x;
    uint segments = 1u << l.level;
    for (uint k = thread; k <= segments; k += STRAND_THREADS) {
        strand_compute_vertex(bundle, strand, l, 0u, k);
    }
    barrier();
    for (uint k = thread; k <= segments; k += STRAND_THREADS) {
        store_vertex(slot, k, strand_vertex(bundle, strand, l, 0u, k));
    }
    if (thread == 0u) {
        strand_info[slot] = uvec4(bundle, strand, segments + 1u, l.level);
    }
}
