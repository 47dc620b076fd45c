#version 460
// Deep opacity maps, fused generation: one invocation generates a strand in the light's view
// (as hair_raster.comp does in the camera's) and rasterizes it into the maps (shadow_raster.glsl).
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#include "shadow_raster.glsl"
#include "strand_raster.glsl"

layout(local_size_x = 32) in;

void main() {
    uint group = gl_WorkGroupID.y * DISPATCH_ROW + gl_WorkGroupID.x;
    uint slot = group * STRANDS_PER_GROUP + gl_LocalInvocationID.x;
    if (slot >= chunk_size(0u)) {
        return;
    }
    uint bundle = slot_bundle(slot);
    uint strand = slot - offsets[bundle];
    BundleLod l = lods[bundle];
    uint segments = 1u << l.level;
    bool from_control = PER_VERTEX_FETCH == 0u;
    vec2 root = root_parameter(bundle, strand);
    SegmentControl c;
    c.segment = -1;
    uint seed = strand_seed(bundle, strand);
    float scale = length_scale(seed);
    for (uint k = 0u; k <= segments; ++k) {
        float tau = float(k) / float(segments);
        thread_positions[k] = from_control ? thread_strand_point(bundle, seed, scale, root, tau, c)
                                           : strand_point(bundle, strand, root, tau);
    }
    RasterVertex previous = raster_vertex(strand_vertex_of_thread(bundle, strand, l, 0u, 0u));
    for (uint k = 1u; k <= segments; ++k) {
        RasterVertex next = raster_vertex(strand_vertex_of_thread(bundle, strand, l, 0u, k));
        raster_segment(previous, next, 0u, 0.0);
        previous = next;
    }
}
