#version 460
// Compute path, pass 1b: exclusive prefix sum of the strand counts (one workgroup, in order, so
// strand slots are deterministic), then the indirect dispatch and draw arguments.
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"

layout(local_size_x = 256) in;

shared uint partial[256];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint count = params.counts.x;
    uint carry = 0u;
    for (uint base = 0u; base < count; base += 256u) {
        uint i = base + t;
        uint value = i < count ? lods[i].strands : 0u;
        partial[t] = value;
        barrier();
        // Hillis-Steele inclusive scan.
        for (uint step = 1u; step < 256u; step <<= 1u) {
            uint add = t >= step ? partial[t - step] : 0u;
            barrier();
            partial[t] += add;
            barrier();
        }
        if (i < count) {
            offsets[i] = carry + partial[t] - value;
        }
        carry += partial[255];
        barrier();
    }
    if (t == 0u) {
        // Slots beyond the buffers' capacity are not generated (the host sized them from its
        // own LOD estimate; total_strands still reports the real count).
        total_strands = carry;
        generated_strands = min(carry, params.seed_info.z);
    }
    barrier();
    if (t < MAX_CHUNKS) {
        uint slots = chunk_size(t);
        // generate.comp: a workgroup per slot, or per STRANDS_PER_GROUP slots (one per
        // invocation) in the strand-coherent variant.
        uint groups = PER_VERTEX_FETCH == 1u ? slots : (slots + STRANDS_PER_GROUP - 1u) / STRANDS_PER_GROUP;
        dispatches[t].x = min(groups, DISPATCH_ROW);
        dispatches[t].y = (groups + DISPATCH_ROW - 1u) / DISPATCH_ROW;
        dispatches[t].z = 1u;
        draws[t].vertex_count = MAX_SEGMENTS * 6u;
        draws[t].instance_count = slots;
        draws[t].first_vertex = 0u;
        draws[t].first_instance = 0u;
    }
    if (t < 2u) {
        uint subset = t == 0u ? SLOT_SUBSET_SPARSE : SLOT_SUBSET_REMAINDER;
        uint groups = (subset_size(subset, chunk_size(0u)) + STRANDS_PER_GROUP - 1u) / STRANDS_PER_GROUP;
        subset_dispatches[t].x = min(groups, DISPATCH_ROW);
        subset_dispatches[t].y = (groups + DISPATCH_ROW - 1u) / DISPATCH_ROW;
        subset_dispatches[t].z = 1u;
    }
}
