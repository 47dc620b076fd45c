#version 460
// Compute rasterizer, fused generation: one invocation generates a strand (gen-gpu's
// strand-coherent evaluation, as generate.comp) and rasterizes its segments into the visibility
// and coverage buffers; no strand buffer in between. Dispatched over the live strand slots with
// the LOD pass's indirect arguments (Generator::prepare_fused).
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
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
    if (!in_phase(strand, l.strands)) {
        return;
    }
    uint segments = 1u << l.level;
    // Every strand from its control data, short ones too: the generator samples strands of
    // fewer than 17 vertices per vertex (so its compute and mesh paths agree), which equals this
    // to f32 rounding and costs more (measured: the LOD'd crowd 15 % faster this way).
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
    float random = seeded_random(seed, 7u);
    RasterVertex previous = raster_vertex(strand_vertex_of_thread(bundle, strand, l, 0u, 0u));
    for (uint k = 1u; k <= segments; ++k) {
        RasterVertex next = raster_vertex(strand_vertex_of_thread(bundle, strand, l, 0u, k));
        raster_segment(previous, next, raster.material, random);
        previous = next;
    }
}
