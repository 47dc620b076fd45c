// The hair fragment stages' push constants (frame.rs `Shading`), shared by the opaque, OIT and
// depth-prepass stages.
// Bytes before HK_FRAGMENT_PUSH_OFFSET belong to the pre-raster stages (gen-gpu's contract).
#include "hk_gen_contract.glsl"
layout(push_constant) uniform Shading {
    layout(offset = HK_FRAGMENT_PUSH_OFFSET) mat4 model;          // the character's object -> world transform
    vec4 eye;                                // xyz world eye; w: number of lights
    vec4 hair_color;                         // rgb base colour (linear); w: per-strand variation
    vec4 specular_shift;                     // x primary shift, y secondary shift, z primary exponent, w secondary exponent
    vec4 specular_strength;                  // x primary, y secondary, z ambient, w sparkle
    vec4 hair_opacity;                       // x: opacity of one strand (1 = opaque)
    // The character's hair volume (render/src/volume.rs): object -> voxel coordinates are
    // (p - volume_box.xyz) * volume_box.w; volume_grid: voxels per axis, first voxel;
    // volume_info: x first brick, y bit 0 AO, bit 1 volume shadows (0: neither).
    vec4 volume_box;
    uvec4 volume_grid;
    uvec4 volume_info;
} shading;
