#version 460
// OIT resolve: walk the pixel's list, keep the K nearest fragments sorted (k-buffer), blend
// the others and the pixel's overflow tail (fragments that found the pool full) order-
// independently (their premultiplied average weighted by their combined coverage), then
// composite front to back; the output is premultiplied and blended over the
// opaque image, and the nearest fragment's depth goes to the depth buffer (depth output).
#extension GL_GOOGLE_include_directive : require
#include "oit.glsl"

layout(push_constant) uniform ResolveParams {
    uint k;
} resolve;

layout(location = 0) out vec4 out_color;

void main() {
    uint pixel = uint(gl_FragCoord.y) * oit_counters.w + uint(gl_FragCoord.x);
    uint k = clamp(resolve.k, 1u, OIT_MAX_K);
    float depths[OIT_MAX_K];
    vec4 colors[OIT_MAX_K];
    uint count = 0u;
    vec4 tail_sum = vec4(0.0);
    float tail_transmittance = 1.0;
    uint base = pixel * oit_pixel_words;
    uint node = oit_heads[base];
    for (uint walked = 0u; node != OIT_END && walked < OIT_MAX_WALK && node < oit_counters.y; ++walked) {
        OitNode n = oit_load_node(node);
        float depth = uintBitsToFloat(n.depth);
        vec4 color = vec4(unpackHalf2x16(n.color_rg), unpackHalf2x16(n.color_ba));
        node = n.next;
        if (count == k) {
            if (depth >= depths[k - 1u]) {
                tail_sum += color;
                tail_transmittance *= 1.0 - color.a;
                continue;
            }
            // Evict the farthest kept fragment to the tail.
            tail_sum += colors[k - 1u];
            tail_transmittance *= 1.0 - colors[k - 1u].a;
            count -= 1u;
        }
        // Insertion into the sorted k-buffer.
        uint i = count;
        while (i > 0u && depths[i - 1u] > depth) {
            depths[i] = depths[i - 1u];
            colors[i] = colors[i - 1u];
            i -= 1u;
        }
        depths[i] = depth;
        colors[i] = color;
        count += 1u;
    }
    vec4 overflow = vec4(0.0);
    if (oit_pixel_words == OIT_PIXEL_WORDS) {
        uvec4 sums = uvec4(oit_tail_sum(base + 1u), oit_tail_sum(base + 2u), oit_tail_sum(base + 3u),
                           oit_tail_sum(base + 4u));
        overflow = vec4(sums) / OIT_TAIL_SCALE;
    }
    // Where every fragment overflowed, the tail's alpha-weighted mean depth stands for the
    // nearest one (the fill depth-tested them all against the occluders already).
    float nearest = count > 0u ? depths[0] : 1.0;
    if (overflow.a > 0.0) {
        if (count == 0u) {
            // (Below 1, the far plane, so it passes the depth test.)
            float mean_depth = float(oit_tail_sum(base + 6u)) / OIT_TAIL_SCALE / overflow.a;
            nearest = min(mean_depth, uintBitsToFloat(0x3f7fffffu));
        }
        tail_sum += overflow;
        tail_transmittance *= exp(-float(oit_tail_sum(base + 5u)) / OIT_DEPTH_SCALE);
    }
    vec3 result = vec3(0.0);
    float transmittance = 1.0;
    for (uint i = 0u; i < count; ++i) {
        result += transmittance * colors[i].rgb;
        transmittance *= 1.0 - colors[i].a;
    }
    if (tail_sum.a > 0.0) {
        result += transmittance * (tail_sum.rgb / tail_sum.a) * (1.0 - tail_transmittance);
        transmittance *= tail_transmittance;
    }
    out_color = vec4(result, 1.0 - transmittance);
    // The nearest hair becomes the pixel's depth (the depth test keeps a nearer occluder's);
    // a pixel without hair writes the far plane, which never passes.
    gl_FragDepth = nearest;
}
