// Per-pixel linked lists of hair fragments (order-independent transparency, as TressFX): the
// fill pass appends shaded fragments; the resolve pass keeps the nearest K sorted and blends the
// rest order-independently.

#include "hk_render_contract.glsl"

const uint OIT_END = 0xffffffffu;
const uint OIT_MAX_K = 16u;
// A list is never walked further than this, whatever the pool holds (no hang on any input).
const uint OIT_MAX_WALK = 4096u;

struct OitNode {
    uint next;
    uint depth;   // float bits
    uint color_rg;   // premultiplied linear colour, two halves per word (8 bits would band in the darks)
    uint color_ba;
};

layout(std430, set = 0, binding = HK_BINDING_OIT_HEADS) coherent buffer OitHeads { uint oit_heads[]; };
layout(std430, set = 0, binding = HK_BINDING_OIT_NODES) buffer OitNodes { OitNode oit_nodes[]; };
// x: next free node; y: pool size; z: fragments dropped because the pool was full; w: width.
layout(std430, set = 0, binding = HK_BINDING_OIT_COUNTERS) coherent buffer OitCounters { uvec4 oit_counters; };
