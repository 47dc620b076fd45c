// Deep opacity maps through the compute rasterizer (hair_shadow.comp: fused generation;
// hair_shadow_stored.comp: stored strands): the strand raster's segment walker in the light's
// view, each covered texel going to shadow_fragment instead of a visibility buffer. Two modes,
// as the triangle path's two passes (shadow_depth.frag, shadow_opacity.frag):
//   SHADOW_MODE_DEPTH    the nearest hair depth per texel: an atomic minimum of the Vulkan depth's
//                        bits (non-negative floats order as their bits), cleared to 1.0;
//   SHADOW_MODE_OPACITY  every fragment adds coverage × STRAND_OPACITY to each layer whose end
//                        lies beyond it (measured from the texel's nearest hair), in fixed point
//                        (integer atomics: the same sums in any order); shadow_resolve.comp turns
//                        them into the float layers lighting.glsl reads.
// The CPU port is render/src/raster.rs (`cpu::shadow_strand`).
#define SHADOW_RASTER

#include "hk_render_contract.glsl"

const uint SHADOW_MODE_DEPTH = 0u;
const uint SHADOW_MODE_OPACITY = 1u;
// Opacity of one strand fragment before coverage (shadow_opacity.frag's).
const float STRAND_OPACITY = 0.5;
// Fixed-point units per unit of opacity.
const float SHADOW_OPACITY_SCALE = 4096.0;
// Nothing is added to a layer holding this much (opacity 4096: its transmittance exp(-1.5 × 4096)
// is 0 long before), so no sum can wrap around however dense the hair; a plain load first, so
// saturated texels skip their atomics. Racing adds overshoot it by a few fragments at most.
const uint SHADOW_OPACITY_LIMIT = 1u << 24;

layout(push_constant) uniform ShadowRasterParams {
    mat4 model;            // object -> world (the shared walker's tangents; unused by the maps)
    uint slots;            // stored strands: slots in the bound chunk window
    uint mode;             // SHADOW_MODE_DEPTH or SHADOW_MODE_OPACITY
    uint first_texel;      // this light's first texel in the atlas buffers
    float max_half_width;  // pixels (texels): wider strands are drawn this wide
    vec4 ends;             // xyz: layer ends (world units); w: map size (texels per side)
    vec4 depth;            // x near, y far, z 1 = perspective (else orthographic)
} raster;

// The atlas's nearest hair depth per texel (float bits, written with atomicMin) and its opacity
// layers in fixed point (4 words per texel: layers 1-3 and one unused, as the float vec4s
// shadow_resolve.comp writes over them).
layout(std430, set = 0, binding = HK_BINDING_SHADOW_DEPTH) buffer ShadowDepthBits { uint shadow_depth_bits[]; };
layout(std430, set = 0, binding = HK_BINDING_SHADOW_OPACITY) buffer ShadowOpacitySums { uint shadow_opacity_sums[]; };

// World distance from the light of a depth-buffer value.
float shadow_linear_depth(float z) {
    float n = raster.depth.x;
    float f = raster.depth.y;
    return raster.depth.z > 0.5 ? n * f / (f - z * (f - n)) : n + z * (f - n);
}

void shadow_fragment(uint pixel, float coverage, float ndc_z) {
    if (!(coverage > 0.0)) {
        return;
    }
    uint texel = raster.first_texel + pixel;
    if (raster.mode == SHADOW_MODE_DEPTH) {
        uint bits = floatBitsToUint(max(ndc_z, 0.0));
        if (bits < shadow_depth_bits[texel]) {
            atomicMin(shadow_depth_bits[texel], bits);
        }
        return;
    }
    float d = shadow_linear_depth(ndc_z) - shadow_linear_depth(uintBitsToFloat(shadow_depth_bits[texel]));
    uint add = uint(max(floor_int(min(coverage, 1.0) * STRAND_OPACITY * SHADOW_OPACITY_SCALE + 0.5), 0));
    if (add == 0u) {
        return;
    }
    for (uint layer = 0u; layer < 3u; ++layer) {
        uint word = texel * 4u + layer;
        if (d <= raster.ends[layer] && shadow_opacity_sums[word] < SHADOW_OPACITY_LIMIT) {
            atomicAdd(shadow_opacity_sums[word], add);
        }
    }
}
