// Buffers written by the compute path (and by the mesh path in capture mode).

struct DrawArgs {
    uint vertex_count;
    uint instance_count;
    uint first_vertex;
    uint first_instance;
};

struct DispatchArgs {
    uint x;
    uint y;
    uint z;
};

// Strand slots are processed in chunks whose vertex buffer window fits the device's storage
// buffer range; chunk c holds slots [c * chunk_slots, (c + 1) * chunk_slots).
const uint MAX_CHUNKS = 16u;

layout(std430, set = 0, binding = HK_BINDING_BUNDLE_LODS) buffer LodBuffer { BundleLod lods[]; };
layout(std430, set = 0, binding = HK_BINDING_STRAND_OFFSETS) buffer OffsetBuffer {
    uint total_strands;
    uint generated_strands;    // min(total, capacity)
    uint pad0;
    uint pad1;
    DispatchArgs dispatches[MAX_CHUNKS];
    DrawArgs draws[MAX_CHUNKS];
    // One strand per invocation over chunk 0's sparse slots, then over the others
    // (SLOT_SUBSET_SPARSE, SLOT_SUBSET_REMAINDER; subset_slot).
    DispatchArgs subset_dispatches[2];
    uint offsets[];            // exclusive prefix sum of lods[].strands
};
// The current chunk's window. Per slot: MAX_VERTICES x (vec4(position, width),
// vec4(tangent, tau)).
#ifdef HK_VERTEX_STORES_INT64
// The same bytes as 64-bit words, four per vertex (store_vertex).
layout(std430, set = 0, binding = HK_BINDING_STRAND_VERTICES) writeonly buffer StrandVertexWords {
    u64vec4 strand_vertex_words[];
};
#else
layout(std430, set = 0, binding = HK_BINDING_STRAND_VERTICES) buffer StrandVertexBuffer { vec4 strand_vertices[]; };
#endif
// The current chunk's window. Per slot: (bundle, strand index, vertex count, LOD width scale as
// float bits).
layout(std430, set = 0, binding = HK_BINDING_STRAND_INFO) buffer StrandInfoBuffer { uvec4 strand_info[]; };

uint chunk_slots() {
    return params.seed_info.w;
}

// Slots in chunk c.
uint chunk_size(uint c) {
    uint generated = min(total_strands, params.seed_info.z);
    uint first = c * chunk_slots();
    return generated > first ? min(generated - first, chunk_slots()) : 0u;
}

// Strands per row of the 2D dispatch (keeps each dimension within every device's limit).
const uint DISPATCH_ROW = 32768u;

uint slot_bundle(uint slot) {
    // Largest b with offsets[b] <= slot: bundles with no strands share their successor's offset.
    uint lo = 0u;
    uint hi = params.counts.x;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (offsets[mid] <= slot) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Which of chunk 0's slots a fused dispatch covers (gen_gpu::SlotSubset): all of them, every
// SPARSE_SLOT_STRIDE-th one (slots 0, 8, 16, ...: an even sample of every bundle's strands,
// whose slots are consecutive), or the others. Each subset's invocations are dense: the
// subset's index-th slot is subset_slot(subset, index).
const uint SLOT_SUBSET_ALL = 0u;
const uint SLOT_SUBSET_SPARSE = 1u;
const uint SLOT_SUBSET_REMAINDER = 2u;
const uint SPARSE_SLOT_STRIDE = HK_SPARSE_SLOT_STRIDE;

uint subset_slot(uint subset, uint index) {
    if (subset == SLOT_SUBSET_SPARSE) {
        return index * SPARSE_SLOT_STRIDE;
    }
    if (subset == SLOT_SUBSET_REMAINDER) {
        return index + index / (SPARSE_SLOT_STRIDE - 1u) + 1u;
    }
    return index;
}

// Slots of subset `subset` among the first `slots`.
uint subset_size(uint subset, uint slots) {
    uint sparse = (slots + SPARSE_SLOT_STRIDE - 1u) / SPARSE_SLOT_STRIDE;
    return subset == SLOT_SUBSET_SPARSE ? sparse : subset == SLOT_SUBSET_REMAINDER ? slots - sparse : slots;
}

#ifndef HAIR_GEN_NO_WORKGROUP
#include "dispatch_order.glsl"

// This invocation's index in a one-strand-per-invocation dispatch (rows of DISPATCH_ROW
// workgroups of STRANDS_PER_GROUP), in the dispatch order (dispatch_order.glsl: on CPU devices
// each worker thread then draws strands from all over the hair, not one region of it).
uint invocation_index() {
    uvec3 group = ordered_workgroup_id();
    return (group.y * DISPATCH_ROW + group.x) * STRANDS_PER_GROUP + gl_LocalInvocationID.x;
}

// The slot of chunk 0 this invocation of a dispatch over subset `subset`
// (Generator::record_fused_subset_dispatch) generates; false past the subset's last.
bool invocation_subset_slot(uint subset, out uint slot) {
    slot = subset_slot(subset, invocation_index());
    return slot < chunk_size(0u);
}

// The slot, relative to chunk `chunk`'s window, of this invocation in a one-strand-per-
// invocation dispatch (generate.comp's strand-coherent variant and the fused kernels of
// render/shaders); false past the chunk's last slot.
bool invocation_slot(uint chunk, out uint local_slot) {
    local_slot = invocation_index();
    return local_slot < chunk_size(chunk);
}
#endif

#ifdef HK_VERTEX_STORES_INT64
// Two floats' bits as one 64-bit word, the first in the low half (little-endian: where the
// vec4 layout puts it).
uint64_t float_pair_bits(float first, float second) {
    return uint64_t(floatBitsToUint(first)) | (uint64_t(floatBitsToUint(second)) << 32);
}
#endif

// `slot` is relative to the bound chunk window. With HK_VERTEX_STORES_INT64 the vertex's eight
// floats go out as one store of four 64-bit words: on CPU devices (llvmpipe) a store at a
// per-invocation address is a loop over the SIMD lanes with a bounds check per component, and
// one loop of four components instead of two loops of four is cheaper for the same bytes
// (docs/compute-raster-notes.md).
void store_vertex(uint slot, uint k, StrandVertex v) {
#ifdef HK_VERTEX_STORES_INT64
    strand_vertex_words[slot * MAX_VERTICES + k] =
        u64vec4(float_pair_bits(v.position.x, v.position.y), float_pair_bits(v.position.z, v.width),
                float_pair_bits(v.tangent.x, v.tangent.y), float_pair_bits(v.tangent.z, v.tau));
#else
    uint base = (slot * MAX_VERTICES + k) * 2u;
    strand_vertices[base] = vec4(v.position, v.width);
    strand_vertices[base + 1u] = vec4(v.tangent, v.tau);
#endif
}
