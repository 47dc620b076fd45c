// Buffers written by the compute path (and by the mesh path in capture mode).

struct DrawArgs {
    uint vertex_count;
    uint instance_count;
    uint first_vertex;
    uint first_instance;
};

layout(std430, set = 0, binding = 8) buffer LodBuffer { BundleLod lods[]; };
layout(std430, set = 0, binding = 9) buffer OffsetBuffer {
    uint total_strands;
    uint total_vertices;
    uint dispatch_x;
    uint dispatch_y;
    uint dispatch_z;
    uint pad0;
    uint pad1;
    uint pad2;
    DrawArgs draw;
    uint offsets[];      // exclusive prefix sum of lods[].strands
};
// Per strand slot: MAX_VERTICES x (vec4(position, width), vec4(tangent, tau)).
layout(std430, set = 0, binding = 10) buffer StrandVertexBuffer { vec4 strand_vertices[]; };
// Per strand slot: (bundle, strand index, vertex count, level).
layout(std430, set = 0, binding = 11) buffer StrandInfoBuffer { uvec4 strand_info[]; };

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

void store_vertex(uint slot, uint k, StrandVertex v) {
    uint base = (slot * MAX_VERTICES + k) * 2u;
    strand_vertices[base] = vec4(v.position, v.width);
    strand_vertices[base + 1u] = vec4(v.tangent, v.tau);
}
