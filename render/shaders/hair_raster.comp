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
    // The phase's slots, one per invocation (Generator::record_fused_subset_dispatch).
    uint slot;
    if (!invocation_subset_slot(raster.phase, slot)) {
        return;
    }
    uint bundle = slot_bundle(slot);
    uint strand = slot - offsets[bundle];
    BundleLod l = lods[bundle];
    // Every strand from its control data, short ones too: the generator samples strands of
    // fewer than 17 vertices per vertex (so its compute and mesh paths agree), which equals this
    // to f32 rounding and costs more (measured: the LOD'd crowd 15 % faster this way).
    StrandStream s = strand_stream(bundle, strand, l, PER_VERTEX_FETCH == 0u);
    float random = seeded_random(s.seed, 7u);
    RasterVertex previous;
    // One loop with one call site of strand_stream_step (each is a whole inlined copy of
    // generation), entering each segment at the step that reaches it: here a loop per segment
    // (strand_stream_enter) measured 1-2 % slower on the close-ups, where the column walk's
    // state outweighs the control data it keeps out of the inner loop.
    for (uint step = 0u; step < strand_stream_steps(s); ++step) {
        strand_stream_enter(s);
        StrandVertex v;
        uint k;
        if (strand_stream_step(s, v, k)) {
            RasterVertex next = raster_vertex(v);
            if (k > 0u) {
                raster_segment(previous, next, raster.material, random);
            }
            previous = next;
        }
    }
}
