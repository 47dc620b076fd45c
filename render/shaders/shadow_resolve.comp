#version 460
// Deep opacity maps through the compute rasterizer, last step: one light's opacity layers from
// the fixed-point sums hair_shadow*.comp accumulated into the float vec4s lighting.glsl reads
// (in place: the same four words per texel).
#extension GL_GOOGLE_include_directive : require
#include "hk_render_contract.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = HK_BINDING_SHADOW_OPACITY) buffer ShadowOpacity { uint shadow_opacity_words[]; };

layout(push_constant) uniform ResolveParams {
    uint first_texel;
    uint texels;
    float inverse_scale;  // 1 / SHADOW_OPACITY_SCALE
} resolve;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= resolve.texels) {
        return;
    }
    uint base = (resolve.first_texel + i) * 4u;
    for (uint layer = 0u; layer < 4u; ++layer) {
        float value = float(shadow_opacity_words[base + layer]) * resolve.inverse_scale;
        shadow_opacity_words[base + layer] = floatBitsToUint(value);
    }
}
