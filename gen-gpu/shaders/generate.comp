#version 460
// Compute path, pass 2: one workgroup per strand slot writes its vertices.
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"

layout(local_size_x = 32) in;

layout(push_constant) uniform ChunkParams {
    uint chunk;
} chunk_params;

void main() {
    uint local_slot = gl_WorkGroupID.y * DISPATCH_ROW + gl_WorkGroupID.x;
    if (local_slot >= chunk_size(chunk_params.chunk)) {
        return;
    }
    uint slot = chunk_params.chunk * chunk_slots() + local_slot;
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
        store_vertex(local_slot, k, strand_vertex(bundle, strand, l, 0u, k));
    }
    if (thread == 0u) {
        strand_info[local_slot] = uvec4(bundle, strand, segments + 1u, floatBitsToUint(l.width_scale));
    }
}
