// Compute path, pass 2: writes the strand slots' vertices, one strand per invocation
// (strand-coherent variant) or per workgroup of 32 (per-vertex variants). The kernel's body,
// compiled twice: generate.comp (32-bit stores) and generate_int64.comp (each vertex one
// store of four 64-bit words, on devices with shaderInt64: hair_outputs.glsl `store_vertex`).
#include "hair_gen.glsl"
#include "hair_outputs.glsl"

layout(local_size_x = 32) in;

layout(push_constant) uniform ChunkParams {
    uint chunk;
} chunk_params;

// Strand-coherent variant: one invocation per strand slot.
void generate_per_invocation() {
    uint local_slot;
    if (!invocation_slot(chunk_params.chunk, local_slot)) {
        return;
    }
    uint slot = chunk_params.chunk * chunk_slots() + local_slot;
    uint bundle = slot_bundle(slot);
    uint strand = slot - offsets[bundle];
    BundleLod l = lods[bundle];
    uint segments = 1u << l.level;
    // The mesh path's rule for short strands, so both paths generate the same strands.
    StrandStream s = strand_stream(bundle, strand, l, strand_coherent(strands_per_mesh_group(l.level)));
    // Segment by segment (strand_stream_enter).
    while (strand_stream_walking(s)) {
        int segment = strand_stream_enter(s);
        do {
            StrandVertex v;
            uint k;
            if (strand_stream_step(s, v, k)) {
                store_vertex(local_slot, k, v);
            }
        } while (strand_stream_within(s, segment));
    }
    strand_info[local_slot] = uvec4(bundle, strand, segments + 1u, floatBitsToUint(l.width_scale));
}

// Per-vertex variants: one workgroup of 32 invocations per strand slot.
void generate_per_workgroup() {
    uvec3 group = ordered_workgroup_id();
    uint local_slot = group.y * DISPATCH_ROW + group.x;
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
        strand_compute_vertex(bundle, strand, l, 0u, k, false);
    }
    barrier();
    for (uint k = thread; k <= segments; k += STRAND_THREADS) {
        store_vertex(local_slot, k, strand_vertex_of_group(bundle, strand, l, 0u, k));
    }
    if (thread == 0u) {
        strand_info[local_slot] = uvec4(bundle, strand, segments + 1u, floatBitsToUint(l.width_scale));
    }
}

void main() {
    if (PER_VERTEX_FETCH == 0u) {
        generate_per_invocation();
    } else {
        generate_per_workgroup();
    }
}
