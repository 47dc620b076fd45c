#version 460
// Compute rasterizer, fused generation: one invocation generates a strand (gen-gpu's
// strand-coherent evaluation, as generate.comp) and rasterizes its segments into the visibility
// and coverage buffers; no strand buffer in between. Dispatched over the live strand slots with
// the LOD pass's indirect arguments (Generator::prepare_fused).
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#define RASTER_MARKS
#include "strand_raster.glsl"
#include "raster_slots.glsl"

layout(local_size_x = 32) in;

// Per slot the segments of its strand marked this frame (raster_split.comp cleared them).
layout(std430, set = 0, binding = HK_BINDING_RASTER_MARKS) buffer MarkBuffer { uint marks[]; };

void main() {
    // The phase's slots, one per invocation: from the character's slot order with the segments
    // to walk (dispatched with its arguments, raster_split.comp), or the phase's slot subset,
    // walking every segment (Generator::record_fused_subset_dispatch).
    uint slot;
    uint walk = 0xffffffffu;
    if (SLOT_ORDER != 0u && (raster.flags & RASTER_FLAG_SLOT_ORDER) != 0u) {
        if (!ordered_slot(raster.phase == SLOT_SUBSET_SPARSE, invocation_index(), slot, walk)) {
            return;
        }
    } else if (!invocation_subset_slot(raster.phase, slot)) {
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
            // Segment k - 1's bits: its 32 / segments of the mask (segments is a power of two
            // <= 32), so that a strand with every segment marked has all 32.
            if (SLOT_ORDER != 0u && k > 0u) {
                uint bits = 32u / s.segments;
                segment_bit = bits == 32u ? 0xffffffffu : ((1u << bits) - 1u) << ((k - 1u) * bits);
            }
            if (k > 0u && (SLOT_ORDER == 0u || (walk & segment_bit) != 0u)) {
                raster_segment(previous, next, raster.material, random);
            }
            previous = next;
        }
    }
    // One writer per slot in each phase; a strand of both phases adds the rest's to the
    // front's.
    if (SLOT_ORDER != 0u && segment_marks != 0u) {
        marks[slot] |= segment_marks;
    }
}
