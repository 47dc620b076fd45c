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
    uint offsets[];            // exclusive prefix sum of lods[].strands
};
// The current chunk's window. Per slot: MAX_VERTICES x (vec4(position, width),
// vec4(tangent, tau)).
layout(std430, set = 0, binding = HK_BINDING_STRAND_VERTICES) buffer StrandVertexBuffer { vec4 strand_vertices[]; };
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

#ifndef HAIR_GEN_NO_WORKGROUP
// The slot, relative to chunk `chunk`'s window, of this invocation in a one-strand-per-
// invocation dispatch (generate.comp's strand-coherent variant and the fused kernels of
// render/shaders); false past the chunk's last slot.
bool invocation_slot(uint chunk, out uint local_slot) {
    uint group = gl_WorkGroupID.y * DISPATCH_ROW + gl_WorkGroupID.x;
    local_slot = group * STRANDS_PER_GROUP + gl_LocalInvocationID.x;
    return local_slot < chunk_size(chunk);
}
#endif

// `slot` is relative to the bound chunk window.
void store_vertex(uint slot, uint k, StrandVertex v) {
    uint base = (slot * MAX_VERTICES + k) * 2u;
    strand_vertices[base] = vec4(v.position, v.width);
    strand_vertices[base + 1u] = vec4(v.tangent, v.tau);
}
