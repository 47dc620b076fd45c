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
    uint slot;
    if (!invocation_slot(0u, slot)) {
        return;
    }
    uint bundle = slot_bundle(slot);
    uint strand = slot - offsets[bundle];
    BundleLod l = lods[bundle];
    StrandStream s = strand_stream(bundle, strand, l, PER_VERTEX_FETCH == 0u);
    RasterVertex previous;
    // One loop with one call site of strand_stream_step (each is a whole inlined copy of
    // generation), entering each segment at the step that reaches it: here a loop per segment
    // (strand_stream_enter) is slower on the close-ups, where the column walk's state
    // outweighs the control data it keeps out of the inner loop.
    for (uint step = 0u; step < strand_stream_steps(s); ++step) {
        strand_stream_enter(s);
        StrandVertex v;
        uint k;
        if (strand_stream_step(s, v, k)) {
            RasterVertex next = raster_vertex(v);
            if (k > 0u) {
                raster_segment(previous, next, 0u, 0.0);
            }
            previous = next;
        }
    }
}
