#version 460
// Compute rasterizer, tiles: after the front strands, per 8×8 tile the farthest of its pixels'
// last-slot (K-th nearest) depths when every pixel of the tile is opaque (its coverage at the
// limit), else all ones. A later fragment strictly behind it can neither enter a pixel's slots
// nor add coverage (the pixels are at the limit), so the rest of the strands skip such columns
// and the image stays exactly what drawing every fragment gives.
#extension GL_GOOGLE_include_directive : require
#include "raster_common.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = HK_BINDING_VISIBILITY) readonly buffer PixelBuffer { uint64_t pixel_words[]; };
layout(std430, set = 0, binding = HK_BINDING_RASTER_TILES) writeonly buffer TileBuffer { uint tile_depth[]; };

layout(push_constant) uniform TileParams {
    uint width;
    uint height;
    uint tiles_x;
    uint tiles_y;
    uint k;
} tiles;

void main() {
    uint tile = gl_GlobalInvocationID.x;
    if (tile >= tiles.tiles_x * tiles.tiles_y) {
        return;
    }
    uvec2 origin = uvec2(tile % tiles.tiles_x, tile / tiles.tiles_x) * 8u;
    uint farthest = 0u;
    // Tiles over the image's edge count only their pixels inside it.
    for (uint y = origin.y; y < min(origin.y + 8u, tiles.height) && farthest != 0xffffffffu; ++y) {
        for (uint x = origin.x; x < min(origin.x + 8u, tiles.width); ++x) {
            uint first = pixel_word(y * tiles.width + x, tiles.k, 0u);
            bool opaque = ~pixel_words[first + tiles.k] >= uint64_t(COVERAGE_LIMIT);
            if (!opaque) {
                farthest = 0xffffffffu;
                break;
            }
            farthest = max(farthest, uint(pixel_words[first + tiles.k - 1u] >> DEPTH_SHIFT));
        }
    }
    tile_depth[tile] = farthest;
}
