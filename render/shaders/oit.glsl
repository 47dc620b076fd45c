// Per-pixel linked lists of hair fragments (order-independent transparency, as TressFX): the
// fill pass appends shaded fragments; the resolve pass keeps the nearest K sorted and blends the
// rest order-independently. Fragments that find the node pool full go to their pixel's overflow
// tail instead, blended with the rest.

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference_uvec2 : require
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

// Per pixel OIT_PIXEL_WORDS words: the list's head, then the overflow tail — the premultiplied
// colour and alpha of the fragments that found the pool full and their alpha-weighted depth
// (OIT_TAIL_SCALE units), and their optical depth Σ −ln(1 − α) (OIT_DEPTH_SCALE units), summed
// in any order. Each tail word holds
// the bitwise complement of its sum, so the clear's all-ones fill (OIT_END heads) zeroes them.
// (frame.rs OIT_PIXEL_WORDS)
const uint OIT_PIXEL_WORDS = 7u;
const float OIT_TAIL_SCALE = 65536.0;
const float OIT_DEPTH_SCALE = 4096.0;
// The sums stop growing there (an alpha sum of 16,384 opaque fragments; transmittance e^−32),
// far from wrapping around.
const uint OIT_TAIL_ALPHA_LIMIT = 1u << 30;
const uint OIT_TAIL_DEPTH_LIMIT = 32u * 4096u;
layout(std430, set = 0, binding = HK_BINDING_OIT_HEADS) coherent buffer OitHeads { uint oit_heads[]; };
layout(std430, set = 0, binding = HK_BINDING_OIT_NODES) buffer OitNodes { OitNode oit_nodes[]; };
// The node pool through its device address, where it is larger than a storage-buffer binding
// may be (lavapipe's 128 MiB: 8 M nodes, where a close-up of 100k strands makes 50 M fragments).
layout(buffer_reference, std430, buffer_reference_align = 16) buffer OitNodesRef { OitNode nodes[]; };
// x: next free node; y: pool size; z: fragments that found the pool full; w: width. Then words per
// pixel of oit_heads: OIT_PIXEL_WORDS, or 1 (no overflow tail: the output is too large for it);
// then the pool's device address (0: the pool is the binding).
layout(std430, set = 0, binding = HK_BINDING_OIT_COUNTERS) coherent buffer OitCounters {
    uvec4 oit_counters;
    uint oit_pixel_words;
    uint oit_pad;
    uvec2 oit_nodes_address;
};

bool oit_nodes_referenced() {
    return oit_nodes_address != uvec2(0u);
}

// Copies a node field by field: glslang writes a whole-struct store into a buffer reference with
// mismatched types (invalid SPIR-V).
#define OIT_COPY_NODE(to, from) \
    { to.next = from.next; to.depth = from.depth; to.color_rg = from.color_rg; to.color_ba = from.color_ba; }

void oit_store_node(uint i, OitNode n) {
    if (oit_nodes_referenced()) {
        OIT_COPY_NODE(OitNodesRef(oit_nodes_address).nodes[i], n);
    } else {
        OIT_COPY_NODE(oit_nodes[i], n);
    }
}

OitNode oit_load_node(uint i) {
    OitNode n;
    if (oit_nodes_referenced()) {
        OIT_COPY_NODE(n, OitNodesRef(oit_nodes_address).nodes[i]);
    } else {
        OIT_COPY_NODE(n, oit_nodes[i]);
    }
    return n;
}

// The sum held in tail word `w` (the complement of the word).
uint oit_tail_sum(uint w) {
    return ~oit_heads[w];
}
