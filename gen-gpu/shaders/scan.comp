#version 460
// Compute path, pass 1b: exclusive prefix sum of the strand counts (one workgroup, in order, so
// strand slots are deterministic), then the indirect dispatch and draw arguments.
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"

layout(local_size_x = 256) in;

shared uint partial[256];

// Each invocation sums a contiguous run of bundles, one invocation scans the 256 sums, and each
// writes its run's offsets: two barriers whatever the bundle count (a tree scan of 256 took 16
// per 256 bundles, and on CPU devices a barrier costs more than the whole serial work).
void main() {
    uint t = gl_LocalInvocationID.x;
    uint count = params.counts.x;
    uint run = (count + 255u) / 256u;
    uint begin = min(t * run, count);
    uint end = min(begin + run, count);
    uint sum = 0u;
    for (uint i = begin; i < end; ++i) {
        sum += lods[i].strands;
    }
    partial[t] = sum;
    barrier();
    if (t == 0u) {
        uint carry = 0u;
        for (uint j = 0u; j < 256u; ++j) {
            uint value = partial[j];
            partial[j] = carry;
            carry += value;
        }
        total_strands = carry;
        // Slots beyond the buffers' capacity are not generated (the host sized them from its
        // own LOD estimate; total_strands still reports the real count).
        generated_strands = min(carry, params.seed_info.z);
    }
    // (total_strands is read below by every invocation: chunk_size.)
    memoryBarrierBuffer();
    barrier();
    uint carry = partial[t];
    for (uint i = begin; i < end; ++i) {
        offsets[i] = carry;
        carry += lods[i].strands;
    }
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
