#version 460
// Deep opacity maps, stored strands: one invocation rasterizes one slot of a strand buffer in
// gen-gpu's layout into the maps (shadow_raster.glsl), as hair_raster_stored.comp does into the
// visibility buffer.
#extension GL_GOOGLE_include_directive : require
#define HAIR_GEN_NO_WORKGROUP
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#include "dispatch_order.glsl"
#include "shadow_raster.glsl"
#include "strand_raster.glsl"

layout(local_size_x = 32) in;

StrandVertex stored_vertex(uint slot, uint k) {
    uint base = (slot * MAX_VERTICES + k) * 2u;
    StrandVertex v;
    v.position = strand_vertices[base].xyz;
    v.width = strand_vertices[base].w;
    v.tangent = strand_vertices[base + 1u].xyz;
    v.tau = strand_vertices[base + 1u].w;
    return v;
}

void main() {
    // In the dispatch order (dispatch_order.glsl).
    uint slot = ORDERED_GLOBAL_INVOCATION_ID.x;
    if (slot >= raster.slots) {
        return;
    }
    uint n = min(strand_info[slot].z, MAX_VERTICES);
    RasterVertex previous = raster_vertex(stored_vertex(slot, 0u));
    for (uint k = 1u; k < n; ++k) {
        RasterVertex next = raster_vertex(stored_vertex(slot, k));
        raster_segment(previous, next, 0u, 0.0);
        previous = next;
    }
}
