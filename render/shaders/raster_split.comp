#version 460
// Compute rasterizer, before a character's raster phases: its strands in drawing order
// (raster_slots.glsl) from the marks of the last frame that drew it — per strand slot a mask of
// the segments with a fragment at or in front of their pixel's K-th nearest depth
// (hair_raster.comp) — and each part's indirect dispatch; then the marks are cleared for this
// frame's raster to set. The front part: every strand with marked segments, walking those;
// when fewer strands are marked than the sparse subset holds (no history, or hair too thin to
// hide much), every SPARSE_SLOT_STRIDE-th slot besides, walking all of its segments. The rest:
// every other strand, walking the segments the front part does not (its entry carries the
// same marks: hair_raster.comp reads them at the strand's vertex level this frame). One workgroup, in slot
// order, as gen-gpu's scan: each invocation counts a contiguous run of slots, one scans the
// 256 counts, each writes its run (two barriers whatever the slot count; the order, and so the
// drawing, is the same in every run).
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#include "raster_slots.glsl"

layout(local_size_x = 256) in;

// Per slot its strand's marked segments (hair_raster.comp).
layout(std430, set = 0, binding = HK_BINDING_RASTER_MARKS) buffer MarkBuffer { uint marks[]; };

// render/src/raster.rs SplitPush.
layout(push_constant) uniform SplitParams {
    uint history; // 1: the marks are the last frame's; 0: none (the sparse slots go first)
} split;

shared uint marked_before[256];
shared uint sparse_before[256];
shared uint whole_before[256]; // slots whose every segment is marked (no rest entry)
shared uint marked_total;
shared uint sparse_total;
shared bool with_sparse;

uint marked(uint slot) {
    return split.history != 0u ? marks[slot] : 0u;
}

// A sparse slot with no marks: drawn whole in the front part when the sparse subset joins it.
bool sparse_unmarked(uint slot, uint m) {
    return m == 0u && slot % SPARSE_SLOT_STRIDE == 0u;
}

// Whether a slot goes to the rest part: not drawn whole in the front.
bool in_rest(bool both, uint slot, uint m) {
    return m != 0xffffffffu && !(both && sparse_unmarked(slot, m));
}

DispatchArgs dispatch_over(uint strands) {
    uint groups = (strands + STRANDS_PER_GROUP - 1u) / STRANDS_PER_GROUP;
    DispatchArgs d;
    d.x = min(groups, DISPATCH_ROW);
    d.y = (groups + DISPATCH_ROW - 1u) / DISPATCH_ROW;
    d.z = 1u;
    return d;
}

void main() {
    uint t = gl_LocalInvocationID.x;
    uint slots = chunk_size(0u);
    uint run = (slots + 255u) / 256u;
    uint begin = min(t * run, slots);
    uint end = min(begin + run, slots);
    uint marked_count = 0u;
    uint sparse_count = 0u;
    uint whole_count = 0u;
    for (uint slot = begin; slot < end; ++slot) {
        uint m = marked(slot);
        marked_count += m != 0u ? 1u : 0u;
        sparse_count += sparse_unmarked(slot, m) ? 1u : 0u;
        whole_count += m == 0xffffffffu ? 1u : 0u;
    }
    marked_before[t] = marked_count;
    sparse_before[t] = sparse_count;
    whole_before[t] = whole_count;
    barrier();
    if (t == 0u) {
        uint marked_carry = 0u;
        uint sparse_carry = 0u;
        uint whole_carry = 0u;
        for (uint j = 0u; j < 256u; ++j) {
            uint m = marked_before[j];
            uint s = sparse_before[j];
            uint w = whole_before[j];
            marked_before[j] = marked_carry;
            sparse_before[j] = sparse_carry;
            whole_before[j] = whole_carry;
            marked_carry += m;
            sparse_carry += s;
            whole_carry += w;
        }
        bool both = marked_carry * SPARSE_SLOT_STRIDE < slots;
        marked_total = marked_carry;
        sparse_total = both ? sparse_carry : 0u;
        with_sparse = both;
        front_count = marked_total + sparse_total;
        rest_count = slots - sparse_total - whole_carry;
        front_dispatch = dispatch_over(front_count);
        rest_dispatch = dispatch_over(rest_count);
    }
    barrier();
    bool both = with_sparse;
    // Front: the marked strands, then (with the sparse subset) the sparse unmarked ones. Rest:
    // every slot but those, in slot order.
    uint marked_at = marked_before[t];
    uint sparse_at = marked_total + (both ? sparse_before[t] : 0u);
    uint rest_at = marked_total + sparse_total + (begin - (both ? sparse_before[t] : 0u) - whole_before[t]);
    for (uint slot = begin; slot < end; ++slot) {
        uint m = marked(slot);
        if (m != 0u) {
            ordered_slots[marked_at++] = uvec2(slot, m);
        } else if (both && sparse_unmarked(slot, m)) {
            ordered_slots[sparse_at++] = uvec2(slot, 0xffffffffu);
        }
        if (in_rest(both, slot, m)) {
            ordered_slots[rest_at++] = uvec2(slot, m);
        }
        marks[slot] = 0u;
    }
}
