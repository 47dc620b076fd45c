#version 460
#extension GL_GOOGLE_include_directive : require
#include "hk_gen_contract.glsl"
#include "hk_render_contract.glsl"
// Deep opacity map, opacity pass: every hair fragment adds its opacity to each layer whose end
// lies beyond it, measured from the nearest hair depth of its texel (additive blending into an
// RGBA32F target: x, y, z = cumulative opacity up to the end of layers 1, 2, 3).
layout(location = HK_LOCATION_COVERAGE_SIDE) in vec4 v_coverage_side;
layout(location = 0) out vec4 out_opacity;

layout(push_constant) uniform Layers {
    layout(offset = HK_FRAGMENT_PUSH_OFFSET) vec4 ends;   // xyz: layer ends (world units); w: map size
    uvec4 map;                       // x: first texel of this light's maps in the depth buffer
    vec4 depth;                      // x near, y far, z 1 = perspective (else orthographic)
} layers;

// World distance from the light of a depth-buffer value.
float linear_depth(float z) {
    float n = layers.depth.x;
    float f = layers.depth.y;
    return layers.depth.z > 0.5 ? n * f / (f - z * (f - n)) : n + z * (f - n);
}

layout(std430, set = 0, binding = HK_BINDING_SHADOW_DEPTH) readonly buffer ShadowDepth { float shadow_depth[]; };

// Opacity of one strand fragment before coverage.
const float STRAND_OPACITY = 0.5;

void main() {
    uint index = layers.map.x + uint(gl_FragCoord.y) * uint(layers.ends.w) + uint(gl_FragCoord.x);
    float d = linear_depth(gl_FragCoord.z) - linear_depth(shadow_depth[index]);
    float a = clamp(v_coverage_side.x, 0.0, 1.0) * STRAND_OPACITY;
    out_opacity = vec4(d <= layers.ends.x ? a : 0.0, d <= layers.ends.y ? a : 0.0, d <= layers.ends.z ? a : 0.0, 0.0);
}
