#version 460
// Compute rasterizer, stored strands: one invocation rasterizes one slot of a strand buffer in
// gen-gpu's layout (an artist's groom uploaded once; or strands the compute path generated),
// with the same segment rasterization as the fused kernel.
#extension GL_GOOGLE_include_directive : require
#define HAIR_GEN_NO_WORKGROUP
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#include "dispatch_order.glsl"
#include "strand_raster.glsl"

layout(local_size_x = 32) in;

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer StrandVerticesRef { vec4 values[]; };

// Through the reference when LOAD_BY_ADDRESS: a gather on CPU devices, where the binding's load
// at a per-invocation address is a loop over the SIMD lanes.
vec4 load_stored(uint i) {
    return LOAD_BY_ADDRESS != 0u ? StrandVerticesRef(raster.vertices_address).values[i] : strand_vertices[i];
}

StrandVertex stored_vertex(uint slot, uint k) {
    uint base = (slot * MAX_VERTICES + k) * 2u;
    vec4 position_width = load_stored(base);
    vec4 tangent_tau = load_stored(base + 1u);
    StrandVertex v;
    v.position = position_width.xyz;
    v.width = position_width.w;
    v.tangent = tangent_tau.xyz;
    v.tau = tangent_tau.w;
    return v;
}

void main() {
    // The phase's slots, one per invocation (StoredStrands::record_compute).
    // In the dispatch order (dispatch_order.glsl).
    uint slot = subset_slot(raster.phase, ORDERED_GLOBAL_INVOCATION_ID.x);
    if (slot >= raster.slots) {
        return;
    }
    uvec4 info = strand_info[slot];
    uint n = min(info.z, MAX_VERTICES);
    float random = strand_random(info.x, info.y, 7u);
    RasterVertex previous = raster_vertex(stored_vertex(slot, 0u));
    for (uint k = 1u; k < n; ++k) {
        RasterVertex next = raster_vertex(stored_vertex(slot, k));
        raster_segment(previous, next, raster.material, random);
        previous = next;
    }
}
