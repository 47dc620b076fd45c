// Writing fragments into the compute rasterizer's per-pixel words (layout in
// raster_common.glsl): the strand raster kernels (strand_raster.glsl) and the volume raymarch
// (volume_march.comp) share it.

#include "raster_common.glsl"

// Visibility and coverage words of each pixel.
layout(std430, set = 0, binding = HK_BINDING_VISIBILITY) buffer PixelBuffer { uint64_t pixel_words[]; };

// The plain (non-atomic) load of word i: an includer may read through a faster path
// (strand_raster.glsl: a buffer reference).
#ifndef PIXEL_WORD_LOAD
#define PIXEL_WORD_LOAD(i) pixel_words[i]
#endif

// Inserts visibility word `v` among the K nearest of the pixel whose words start at `first`,
// from the nearest slot on: a displaced word moves to the next slot.
void insert_visibility(uint first, uint k, uint64_t v) {
    for (uint i = 0u; i < k; ++i) {
        if (v >= PIXEL_WORD_LOAD(first + i)) {
            continue;
        }
        uint64_t held = atomicMin(pixel_words[first + i], v);
        if (held == VISIBILITY_EMPTY) {
            break;
        }
        v = max(v, held);
    }
}

// Adds `add` fixed-point units of optical depth to coverage word `cover`, unless it already
// reached COVERAGE_LIMIT (a plain load first: opaque pixels skip the atomic).
void add_coverage(uint cover, uint add) {
    if (add > 0u && ~PIXEL_WORD_LOAD(cover) < uint64_t(COVERAGE_LIMIT)) {
        atomicAdd(pixel_words[cover], ~uint64_t(add) + 1UL);
    }
}
