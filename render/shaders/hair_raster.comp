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

// What the kernel draws of each strand (render/src/raster.rs FusedStrands): the generated
// strands, or (HK_FUSED_STRANDS_STRAIGHT, benchmarks) each as a straight line from its root to
// its tip.
layout(constant_id = HK_FUSED_STRANDS_CONSTANT_ID) const uint FUSED_STRANDS = 0u;

// Per slot the segments of its strand marked this frame (raster_split.comp cleared them).
layout(std430, set = 0, binding = HK_BINDING_RASTER_MARKS) buffer MarkBuffer { uint marks[]; };

// `marks` (bit i * 32 / segments of segment i, set by a frame whose strand may have had another
// vertex level) as whole segments at `bits` = 32 / segments bits each: every bit of a segment
// set when any of its bits is, so that each segment lands in exactly one phase (the front
// walks these, the rest the others) whatever level marked it.
uint whole_segments(uint marks, uint bits) {
    uint any = marks;
    for (uint shift = 1u; shift < bits; shift <<= 1u) {
        any |= any >> shift;
    }
    // Bit s * bits now holds the OR over segment s's bits; keep those and spread them.
    uint starts = bits == 32u ? 1u : bits == 16u ? 0x00010001u : bits == 8u ? 0x01010101u
                : bits == 4u ? 0x11111111u : bits == 2u ? 0x55555555u : 0xffffffffu;
    any &= starts;
    for (uint shift = 1u; shift < bits; shift <<= 1u) {
        any |= any << shift;
    }
    return any;
}

// The mask bits of segment i of `segments` (a power of two <= 32): its 32 / segments bits, so
// that a strand with every segment marked has all 32.
uint segment_bits(uint i, uint segments) {
    uint bits = 32u / segments;
    return bits == 32u ? 0xffffffffu : ((1u << bits) - 1u) << (i * bits);
}

// Whether point j of a strand walk of `segments` segments is needed when the segments in
// `walk` are walked (bit i * 32 / segments of segment i): it lies within two points of a
// vertex of a walked segment (segments j - 3 .. j + 2), it is one of the first three (the end
// directions every tangent may fall back on), or it is point 4 or segments - 4 and the first
// or the last segment is walked (under LOD morphing the coarse polyline's end tangents at
// vertices 0 and segments read them); strand_stream_step_needed.
bool point_needed(uint walk, uint j, uint segments) {
    if (walk == 0xffffffffu || j <= 2u) {
        return true;
    }
    if ((j == 4u && (walk & segment_bits(0u, segments)) != 0u) ||
        (j + 4u == segments && (walk & segment_bits(segments - 1u, segments)) != 0u)) {
        return true;
    }
    uint bits = 32u / segments;
    uint lo = (j - 3u) * bits;
    if (lo >= 32u) {
        return false;
    }
    uint hi = min(j + 3u, segments) * bits;
    uint range = (hi >= 32u ? 0xffffffffu : (1u << hi) - 1u) & ~((1u << lo) - 1u);
    return (walk & range) != 0u;
}

// The strand a bundle's local slot j draws (NO_STRAND: none) in the phase whose strand part is
// `part` (render/src/raster.rs RasterPhase), over the bundle's n live strands, m of whose slots
// are sparse (every SPARSE_SLOT_STRIDE-th of all): its sparse slots take its first m strands in
// part 0 (the front phase; their roots are a blue-noise subset of its root set, as any prefix
// of it is) and the next m in part 1; its other slots the strands after the `part` fronts drawn
// before them, in order. Over the phases of a frame every strand is drawn once.
const uint NO_STRAND = 0xffffffffu;
uint front_first_strand(uint j, uint offset, uint n, uint part) {
    uint r = (SPARSE_SLOT_STRIDE - offset % SPARSE_SLOT_STRIDE) % SPARSE_SLOT_STRIDE;
    uint sparse = n > r ? (n - r + SPARSE_SLOT_STRIDE - 1u) / SPARSE_SLOT_STRIDE : 0u;
    uint strand;
    if (j >= r && (j - r) % SPARSE_SLOT_STRIDE == 0u) {
        strand = part * sparse + (j - r) / SPARSE_SLOT_STRIDE;
    } else {
        uint before = j > r ? (j - r + SPARSE_SLOT_STRIDE - 1u) / SPARSE_SLOT_STRIDE : 0u;
        strand = max(part, 1u) * sparse + j - before;
    }
    return strand < n ? strand : NO_STRAND;
}

// Vertex k of the strand being walked (0, 1, ... in order): draws the segment from `previous` to
// `next` where `walk` asks for it (every segment without a slot order; with one, the segment's
// bit is what a fragment marks), then `next` becomes `previous`.
void walk_to(inout RasterVertex previous, RasterVertex next, uint k, uint segments, uint walk, float random) {
    if (SLOT_ORDER != 0u && k > 0u) {
        segment_bit = segment_bits(k - 1u, segments);
    }
    if (k > 0u && (SLOT_ORDER == 0u || (walk & segment_bit) != 0u)) {
        raster_segment(previous, next, raster.material, random);
    }
    previous = next;
}

void main() {
    // The phase's slots, one per invocation: from the character's slot order with the strand's
    // marks (dispatched with its arguments, raster_split.comp), or the phase's slot subset,
    // walking every segment (Generator::record_fused_subset_dispatch). `walk`: the segments to
    // walk (bit i * 32 / segments of segment i).
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
    BundleLod l = lods[bundle];
    uint strand = front_first_strand(slot - offsets[bundle], offsets[bundle], l.strands, raster.strand_part);
    if (strand == NO_STRAND) {
        return;
    }
    // Every strand from its control data, short ones too: the generator samples strands of
    // fewer than 17 vertices per vertex (so its compute and mesh paths agree), which equals this
    // to f32 rounding and costs more (a crowd under LOD is faster this way).
    StrandStream s = strand_stream(bundle, strand, l, PER_VERTEX_FETCH == 0u);
    float random = seeded_random(s.seed, 7u);
    if (SLOT_ORDER != 0u && walk != 0xffffffffu) {
        // The order entry's marks: the front walks the marked segments, the rest the others.
        uint marked = whole_segments(walk, 32u / s.segments);
        walk = raster.phase == SLOT_SUBSET_SPARSE ? marked : ~marked;
    }
    RasterVertex previous;
    if (FUSED_STRANDS == HK_FUSED_STRANDS_STRAIGHT) {
        // For benchmarks (FusedStrands::Straight; CPU port raster::straight_strand): the straight
        // line from the hair-mesh curve's point at the root to its point at the strand's length,
        // split into the strand's vertices and walked like any strand, so that generation is two
        // control-point loads and a lerp per vertex. Each invocation fetches its own texels (the
        // subgroup-wide fetches need every invocation at the same load).
        s.cell.together = false;
        load_segment(s.cell, 0, s.control);
        vec3 root = params.normalization.xyz + s.control.strand[0] * params.normalization.w;
        load_segment(s.cell, int(coherent_layers()) - 1, s.control);
        vec3 tip = params.normalization.xyz + s.control.strand[3] * params.normalization.w;
        vec3 direction = try_normalize(tip - root, vec3(0.0, 1.0, 0.0));
        for (uint k = 0u; k <= s.segments; ++k) {
            StrandVertex v;
            v.tau = float(k) * power_of_two_reciprocal(float(s.segments)); // k / segments, exactly
            v.position = mix(root, tip, v.tau * s.scale);
            v.tangent = direction;
            v.width = width_at(v.tau) * l.width_scale;
            walk_to(previous, raster_vertex(v), k, s.segments, walk, random);
        }
    } else if (SLOT_ORDER == 0u && s.segments >= 16u) {
        // Strands of 16 segments or more walked whole (no slot order) go curve segment by
        // curve segment: an outer loop enters each (loading its control data) and an inner loop
        // takes its steps. On CPU devices (llvmpipe) every value a loop carries is written back
        // under the SIMD lanes' mask at each turn; the inner loop only reads the segment's 38
        // control values, so they are written back once per curve segment instead of at every
        // vertex (docs/compute-raster-notes.md). Strands of a few segments, as in a crowd under
        // LOD, enter a curve segment every step or two, which is slower that way, so they and
        // the slot order's walks keep the one loop below.
        while (strand_stream_walking(s)) {
            int segment = strand_stream_enter(s);
            do {
                StrandVertex v;
                uint k;
                if (strand_stream_step(s, v, k)) {
                    walk_to(previous, raster_vertex(v), k, s.segments, walk, random);
                }
            } while (strand_stream_within(s, segment));
        }
    } else {
        // One loop entering each curve segment at the step that reaches it.
        for (uint step = 0u; step < strand_stream_steps(s); ++step) {
            // With a slot order, only the points the walked segments' vertices read are
            // evaluated (their control data loaded by the whole subgroup when it fetches
            // together).
            bool needed = SLOT_ORDER == 0u || point_needed(walk, s.pushed, s.segments);
            bool enter = needed;
            if (SLOT_ORDER != 0u && s.cell.together) {
                enter = subgroupAny(needed);
            }
            if (enter) {
                strand_stream_enter(s);
            }
            StrandVertex v;
            uint k;
            if (strand_stream_step_needed(s, needed, v, k)) {
                walk_to(previous, raster_vertex(v), k, s.segments, walk, random);
            }
        }
    }
    // One writer per slot in each phase; a strand of both phases adds the rest's to the
    // front's.
    if (SLOT_ORDER != 0u && segment_marks != 0u) {
        marks[slot] |= segment_marks;
    }
}
