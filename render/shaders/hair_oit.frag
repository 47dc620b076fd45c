#version 460
// OIT fill: shade the fragment and append it to its pixel's list; no colour is written. With the
// pool full the fragment joins its pixel's overflow tail (oit.glsl), which the resolve blends
// behind the pixel's K nearest as it does the list's farther fragments, and is counted: the image
// degrades toward order-independent blending, it never loses hair, hangs or shows garbage.
#extension GL_GOOGLE_include_directive : require
#include "hair_fragment.glsl"
#include "oit.glsl"

layout(early_fragment_tests) in;

void main() {
    vec4 color = shade_hair_fragment();
    if (color.a <= 0.0) {
        return;
    }
    uint pixel = uint(gl_FragCoord.y) * oit_counters.w + uint(gl_FragCoord.x);
    uint base = pixel * oit_pixel_words;
    uint index = atomicAdd(oit_counters.x, 1u);
    if (index >= oit_counters.y) {
        atomicAdd(oit_counters.z, 1u);
        if (oit_pixel_words != OIT_PIXEL_WORDS) {
            return;  // no tail at this output size: dropped, counted
        }
        // Subtracting from the complemented words adds to their sums; plain loads first, so a
        // saturated tail takes no atomics.
        if (oit_tail_sum(base + 4u) < OIT_TAIL_ALPHA_LIMIT) {
            uvec4 q = uvec4(clamp(color, 0.0, 1.0) * OIT_TAIL_SCALE + 0.5);
            atomicAdd(oit_heads[base + 1u], ~q.r + 1u);
            atomicAdd(oit_heads[base + 2u], ~q.g + 1u);
            atomicAdd(oit_heads[base + 3u], ~q.b + 1u);
            atomicAdd(oit_heads[base + 4u], ~q.a + 1u);
            uint depth = uint(clamp(color.a, 0.0, 1.0) * gl_FragCoord.z * OIT_TAIL_SCALE + 0.5);
            atomicAdd(oit_heads[base + 6u], ~depth + 1u);
        }
        if (oit_tail_sum(base + 5u) < OIT_TAIL_DEPTH_LIMIT) {
            uint tau = uint(-log(1.0 - min(color.a, 0.999)) * OIT_DEPTH_SCALE + 0.5);
            atomicAdd(oit_heads[base + 5u], ~tau + 1u);
        }
        return;
    }
    OitNode n;
    n.depth = floatBitsToUint(gl_FragCoord.z);
    n.color_rg = packHalf2x16(color.rg);
    n.color_ba = packHalf2x16(color.ba);
    n.next = atomicExchange(oit_heads[base], index);
    oit_store_node(index, n);
}
