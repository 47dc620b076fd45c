#version 460
// OIT fill: shade the fragment and append it to its pixel's list; no colour is written. A full
// pool drops the fragment and counts it (the image degrades, it never hangs or shows garbage).
#extension GL_GOOGLE_include_directive : require
#include "hair_fragment.glsl"
#include "oit.glsl"

layout(early_fragment_tests) in;

void main() {
    vec4 color = shade_hair_fragment();
    if (color.a <= 0.0) {
        return;
    }
    uint index = atomicAdd(oit_counters.x, 1u);
    if (index >= oit_counters.y) {
        atomicAdd(oit_counters.z, 1u);
        return;
    }
    uint pixel = uint(gl_FragCoord.y) * oit_counters.w + uint(gl_FragCoord.x);
    oit_nodes[index].depth = floatBitsToUint(gl_FragCoord.z);
    oit_nodes[index].color_rg = packHalf2x16(color.rg);
    oit_nodes[index].color_ba = packHalf2x16(color.ba);
    oit_nodes[index].next = atomicExchange(oit_heads[pixel], index);
}
