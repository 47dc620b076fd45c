#version 460
// Compute rasterizer, tiles: after the front strands, per 8×8 tile the farthest of its pixels'
// threshold depths (their K-th nearest, or farther) when every pixel of the tile is opaque (its
// coverage at the limit), else all ones. A later fragment strictly behind it can neither enter
// a pixel's slots nor add coverage (the pixels are at the limit), so the rest of the strands
// skip such columns and the image stays exactly what drawing every fragment gives. A second word per tile holds
// the farthest over the 2×2 tiles it is the top left of: a column's test is then one load
// (on CPU devices each lane's load is a scalar load; four per column were a sixth of the rest
// phase's time). A third holds the farthest over the 3×3 tiles it is the top left of: a whole
// segment's test (strand_raster.glsl segment_behind_tiles). Two stages: the own words from the
// pixels, then the squares' from the own words. Only the pixels of the hair's screen rectangle
// are cleared each frame; the tiles read just those.
#extension GL_GOOGLE_include_directive : require
#include "raster_common.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = HK_BINDING_VISIBILITY) readonly buffer PixelBuffer { uint64_t pixel_words[]; };
layout(std430, set = 0, binding = HK_BINDING_RASTER_TILES) buffer TileBuffer { uint tile_depth[]; };

// render/src/raster.rs TilePush.
layout(push_constant) uniform TileParams {
    uint width;
    uint height;
    uint tiles_x;
    uint tiles_y;
    uint k;
    uint stage; // 0: each tile's own word; 1: its squares' words from the own words
    uint pad1;
    uint pad2;
    // The pixels the frame cleared (x0, y0, x1, y1; exclusive ends): the hair's screen
    // rectangle. The words outside it are stale.
    uvec4 rect;
} tiles;

// The farthest threshold depth bits of tile (x, y) if all its pixels are opaque, else all ones;
// 0 for a tile outside the grid (no column reaches it). A tile not wholly inside the cleared
// rectangle counts as open, whatever its stale words say: the rectangle's margin (wider than
// a tile) holds no hair, so no tile that could close is lost, and none is read for nothing.
uint tile_farthest(uint tx, uint ty) {
    if (tx >= tiles.tiles_x || ty >= tiles.tiles_y) {
        return 0u;
    }
    uvec2 origin = uvec2(tx, ty) * 8u;
    uvec2 end = min(origin + 8u, uvec2(tiles.width, tiles.height));
    if (any(lessThan(origin, tiles.rect.xy)) || any(greaterThan(end, tiles.rect.zw))) {
        return 0xffffffffu;
    }
    uint k = visibility_slots(tiles.k);
    uint farthest = 0u;
    // Tiles over the image's edge count only their pixels inside it.
    for (uint y = origin.y; y < min(origin.y + 8u, tiles.height); ++y) {
        for (uint x = origin.x; x < min(origin.x + 8u, tiles.width); ++x) {
            uint first = pixel_word(y * tiles.width + x, k, 0u);
            bool opaque = coverage_sum(pixel_words[first + k]) >= COVERAGE_LIMIT;
            if (!opaque) {
                return 0xffffffffu;
            }
            farthest = max(farthest, uint(pixel_words[threshold_word(first, k)] >> DEPTH_SHIFT));
        }
    }
    return farthest;
}

// Stage 1: tile (x, y)'s own word (stage 0), 0 outside the grid (no column reaches it).
uint own_word(uint tx, uint ty) {
    if (tx >= tiles.tiles_x || ty >= tiles.tiles_y) {
        return 0u;
    }
    return tile_depth[RASTER_TILE_WORDS * (ty * tiles.tiles_x + tx)];
}

void main() {
    uint tile = gl_GlobalInvocationID.x;
    if (tile >= tiles.tiles_x * tiles.tiles_y) {
        return;
    }
    uvec2 t = uvec2(tile % tiles.tiles_x, tile / tiles.tiles_x);
    if (tiles.stage == 0u) {
        tile_depth[RASTER_TILE_WORDS * tile] = tile_farthest(t.x, t.y);
        return;
    }
    uint own = own_word(t.x, t.y);
    uint square = own;
    // The 2×2 square's other three.
    for (uint n = 1u; n < 4u && square != 0xffffffffu; ++n) {
        square = max(square, own_word(t.x + (n & 1u), t.y + (n >> 1u)));
    }
    // Then the 3×3 square's other five (the row and the column after the 2×2 square).
    uint wide = square;
    for (uint n = 0u; n < 5u && wide != 0xffffffffu; ++n) {
        uvec2 o = n < 3u ? uvec2(n, 2u) : uvec2(2u, n - 3u);
        wide = max(wide, own_word(t.x + o.x, t.y + o.y));
    }
    tile_depth[RASTER_TILE_WORDS * tile + 1u] = square;
    tile_depth[RASTER_TILE_WORDS * tile + 2u] = wide;
}
