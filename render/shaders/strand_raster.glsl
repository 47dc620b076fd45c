// Segment rasterization of the compute rasterizer (after hair_gen.glsl, which declares the
// frame's GenParams: view_proj, viewport). One invocation rasterizes a whole strand, segment by
// segment: each segment is clipped to the view volume in clip space, then walked along its
// screen-space major axis one pixel column (or row) at a time, two per turn; across it, every
// pixel the strand's footprint [m - h, m + h] overlaps gets that overlap as its coverage (a box
// filter across the strand: a sub-pixel strand spreads its width over one or two pixels instead
// of being widened to a pixel). Columns are half-open at the segment's end, so consecutive segments
// of a strand never cover a column twice. The CPU port is render/src/raster.rs (`cpu`).
//
// With SHADOW_RASTER defined, the includer (the deep opacity map kernels, hair_shadow*.comp)
// declares its own `raster` push constants (at least `model` and `max_half_width`) and
// `void shadow_fragment(uint pixel, float coverage, float ndc_z)`, which every covered pixel
// goes to instead of the visibility buffer (no tiles, no phases).

#ifdef SHADOW_RASTER
#include "raster_common.glsl"
#else
#extension GL_EXT_buffer_reference : require
#include "raster_common.glsl"

// The occluders' Vulkan depth per pixel (1 = none), read when raster.flags bit 0 is set.
layout(std430, set = 0, binding = HK_BINDING_SCENE_DEPTH) readonly buffer SceneDepthBuffer { float scene_depth[]; };
// Per 8×8 tile three words (raster_tiles.comp, after the front strands): the farthest depth
// bits of its pixels' threshold words (raster_common.glsl) if every pixel is opaque and its
// slots full, else all ones — a column behind it cannot change any pixel of the tile —, then
// the same over the 2×2 and the 3×3 tiles it is the top left of, for columns that reach into
// the next tiles and for whole segments (segment_behind_tiles).
layout(std430, set = 0, binding = HK_BINDING_RASTER_TILES) readonly buffer TileBuffer { uint tile_depth[]; };

layout(push_constant) uniform RasterParams {
    mat3 model;           // object -> world, its linear part: tangents are stored in world space
    uint material;        // the character's material index
    uint slots;           // stored strands: slots in the bound chunk window
    uint flags;           // bit 0: hide fragments behind scene_depth
    float max_half_width; // pixels: wider strands are drawn this wide (bounds the work per segment)
    uint phase;           // the slot subset drawn: SLOT_SUBSET_ALL, _SPARSE (front) or _REMAINDER (rest)
    uint tiles_x;         // tiles per row of tile_depth
    uint k;               // visibility slots per pixel
    float opacity;        // of one strand (its material's)
    float volume_fraction; // transition band: pixels whose dither is below it are the volume's
    uint strand_part;     // fused generation: the phase's part of each bundle's strands (front_first_strand)
    // Device addresses of pixel_words, tile_depth and scene_depth, for the plain loads when
    // LOAD_BY_ADDRESS (raster_common.glsl; else unused): CPU devices (llvmpipe) gather loads
    // through a buffer reference with vector instructions, where a storage-buffer load of a
    // divergent address is a loop over the SIMD lanes.
    uint64_t words_address;
    uint64_t tiles_address;
    uint64_t scene_depth_address;
    // Stored strands: the device address of the bound chunk's vertices (likewise).
    uint64_t vertices_address;
    // Fused generation: the device address of the last frame's depths (RASTER_MARKS below).
    uint64_t final_depth_address;
} raster;

// Whether the kernel can take its slots from a slot order and mark segments (scenes with
// K > 1; raster_split.comp): else the code for it is left out (VISIBILITY_SLOTS below).
const uint SLOT_ORDER = uint(VISIBILITY_SLOTS != 1u);

// raster.flags: bit 0 (above); bit 1: the slots come from the character's slot order
// (raster_split.comp: the strands visible last frame as the front phase, the others as the
// rest) instead of the phase's slot subset; bit 2: mark the segments that reach the image
// (RASTER_MARKS below).
const uint RASTER_FLAG_SLOT_ORDER = 2u;
const uint RASTER_FLAG_MARK = 4u;
// raster.flags bit 3: the phase skips what lies behind the occlusion tiles made before it (the
// rest, and a second front eighth: render/src/raster.rs RasterPhase::tile_culled).
const uint RASTER_FLAG_TILES = 8u;

bool tile_culled() {
    return (raster.flags & RASTER_FLAG_TILES) != 0u;
}

layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer PixelWordsRef { uint64_t words[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer TileWordsRef { uint words[]; };
// With K = 1 a pixel's two words (the slot, then the coverage word) as one 16-byte element.
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer PixelPairsRef { u64vec2 pairs[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer SceneDepthRef { float depth[]; };

// visibility_write.glsl's plain loads, through the reference when LOAD_BY_ADDRESS.
#define PIXEL_WORD_LOAD(i) (LOAD_BY_ADDRESS != 0u ? PixelWordsRef(raster.words_address).words[i] : pixel_words[i])
#include "visibility_write.glsl"

#ifdef RASTER_MARKS
// The fused-generation kernel marks each segment one of whose fragments lies at or in front of
// its pixel's K-th nearest depth of the last frame (the front phase) or comes nearer than the
// pixel's K-th nearest so far (the rest phase) — a segment that reached the image — and the
// next frame draws the marked segments first (raster_split.comp): their fragments are most
// pixels' nearest, so the occlusion tiles made after them close nearly at the image's depths
// and the rest skips more. Which segments are marked changes only the order of drawing, never
// the image.
layout(std430, set = 0, binding = HK_BINDING_RASTER_FINAL_DEPTH) readonly buffer FinalDepthBuffer { uint final_depth[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer FinalDepthRef { uint depth[]; };

uint load_final_depth(uint pixel) {
    return LOAD_BY_ADDRESS != 0u ? FinalDepthRef(raster.final_depth_address).depth[pixel] : final_depth[pixel];
}

// The bits of the segment being walked (hair_raster.comp), and the bits of this invocation's
// strand's segments marked so far.
uint segment_bit = 0u;
uint segment_marks = 0u;

// Marks the segment being walked for a fragment at `pixel` (its depth bits; whether it adds
// coverage; whether it comes nearer than the pixel's K-th nearest so far) when the pixel was
// opaque at the end of the last frame (final depth 0: not opaque, where no order makes tiles
// close) and the fragment reached its image — at or in front of its K-th nearest depth then
// (the front phase), nearer than the front phase's (the rest) — or adds to its coverage.
void mark_segment(uint pixel, uint depth_bits, bool adds, bool nearer) {
    bool front = raster.phase == SLOT_SUBSET_SPARSE;
    if (front || adds || nearer) {
        uint last = load_final_depth(pixel);
        if (last != 0u && (adds || (front ? depth_bits <= last : nearer))) {
            segment_marks |= segment_bit;
        }
    }
}
#endif

uint64_t load_pixel_word(uint i) {
    return PIXEL_WORD_LOAD(i);
}

uint load_tile_word(uint i) {
    return LOAD_BY_ADDRESS != 0u ? TileWordsRef(raster.tiles_address).words[i] : tile_depth[i];
}

float load_scene_depth(uint pixel) {
    return LOAD_BY_ADDRESS != 0u ? SceneDepthRef(raster.scene_depth_address).depth[pixel] : scene_depth[pixel];
}

// Which strands a dispatch draws: all of them, or in phases with a tile pass before each but the
// first: a front subset spread over the whole hair, then the rest, skipping the columns that
// lie behind opaque tiles (with fused generation and no slot order a second front subset in
// between, tile-culled too). The phases are gen-gpu's slot subsets (every eighth slot, then the
// others: SLOT_SUBSET_SPARSE, SLOT_SUBSET_REMAINDER: raster.phase), each dispatched over its
// own slots, and for fused generation a part of each bundle's strands (raster.strand_part).

#endif

const uint TILE_SIZE = 8u;

// Whether segments are clipped to the view volume's depth (0 <= z <= w): 0 when the host found
// the character's bounds wholly inside it with a margin for rounding (render/src/raster.rs
// `DepthClipping`), as in nearly every frame; then the clipping that would keep every segment
// whole is not compiled, and the strand loop carries no vertex's clip-space position and side
// from one segment to the next (on CPU devices eight values per SIMD lane that it spilled).
// The kernels' output is the same either way for such bounds.
layout(constant_id = HK_DEPTH_CLIPPING_CONSTANT_ID) const uint DEPTH_CLIPPING = 1u;

// A strand vertex ready for rasterization.
struct RasterVertex {
    vec4 clip;         // clip-space position
    vec4 side;         // clip-space offset of the strand's half width (linear, so it interpolates)
    vec3 tangent;      // world space
    float tau;
    // Its projection (project_vertex), meaningful in front of the eye: pixel position, half
    // width in pixels (at most max_half_width), 1 / w and NDC z.
    vec2 screen;
    float half_width;
    float inv_w;
    float z;
};

// Half the strand's width in pixels at a clip-space point (first-order projection of `side`;
// inv_w = 1 / clip.w).
float half_width_pixels(vec4 clip, vec4 side, float inv_w) {
    vec2 d = (side.xy - clip.xy * (side.w * inv_w)) * inv_w;
    return length(d * 0.5 * params.viewport.xy);
}

// One reciprocal of w for the whole projection: on CPU devices a division is the dearest
// arithmetic of the walk (the CPU port multiplies in the same order).
RasterVertex project_vertex(RasterVertex r) {
    r.inv_w = 1.0 / r.clip.w;
    r.screen = (r.clip.xy * r.inv_w * 0.5 + 0.5) * params.viewport.xy;
    r.half_width = min(half_width_pixels(r.clip, r.side, r.inv_w), raster.max_half_width);
    r.z = r.clip.z * r.inv_w;
    return r;
}

RasterVertex raster_vertex(StrandVertex v) {
    RasterVertex r;
    // The strip's side direction (strip_corners): across the strand, facing the eye.
    vec3 to_eye = params.projection.z > 0.5 ? params.eye.xyz : params.eye.xyz - v.position;
    vec3 side = normalize_or_orthonormal(cross(v.tangent, to_eye), v.tangent) * (0.5 * v.width);
    r.clip = params.view_proj * vec4(v.position, 1.0);
    r.side = params.view_proj * vec4(side, 0.0);
    r.tangent = mat3(raster.model) * v.tangent;
    r.tau = v.tau;
    // Projected once here for the vertex's two segments.
    return project_vertex(r);
}

// The point at t between a and b, not projected (project_vertex).
RasterVertex mix_vertex(RasterVertex a, RasterVertex b, float t) {
    RasterVertex r;
    r.clip = mix(a.clip, b.clip, t);
    r.side = mix(a.side, b.side, t);
    r.tangent = mix(a.tangent, b.tangent, t);
    r.tau = mix(a.tau, b.tau, t);
    return r;
}

// Keeps the part of [t0, t1] where da + t (db - da) >= 0.
void clip_range(float da, float db, inout float t0, inout float t1) {
    if (da < 0.0 && db < 0.0) {
        t1 = -1.0;
    } else if (da < 0.0) {
        t0 = max(t0, da / (da - db));
    } else if (db < 0.0) {
        t1 = min(t1, da / (da - db));
    }
}

// One column's fragment attributes, encoded only when one of its pixels needs them (most
// fragments of dense hair lie behind the pixel's nearest one and need none).
struct ColumnAttributes {
    uint depth_bits;
    bool encoded;
    uint64_t word;
    vec3 tangent;
    float tau;
    uint material;
    float random;
};

#ifndef SHADOW_RASTER
// Plain loads first: a fragment behind the pixel's threshold word (its K-th nearest), or adding
// to a pixel whose hair is already opaque, skips its atomics (on CPU devices an atomic is a
// loop over the SIMD lanes; most fragments of dense hair take neither).
void raster_fragment(uint pixel, float coverage, float ndc_z, inout ColumnAttributes a) {
    if (!(coverage > 0.0)) {
        return;
    }
    if (raster.volume_fraction > 0.0) {
        uint width = uint(params.viewport.x);
        if (transition_dither(uvec2(pixel % width, pixel / width)) < raster.volume_fraction) {
            return;
        }
    }
    if ((raster.flags & 1u) != 0u && !(ndc_z < load_scene_depth(pixel))) {
        return;
    }
    uint k = visibility_slots(raster.k);
    uint first = pixel_word(pixel, k, 0u);
    // The test reads the pixel's coverage word and its threshold word; with K = 1 they sit side
    // by side and come through the reference in one 16-byte load (on CPU devices one address and
    // bounds check for both words, which llvmpipe still gathers one 64-bit word at a time;
    // with an even K the same pairing of words K and K + 1 gains nothing).
    uint64_t cover;
    uint64_t threshold;
    if (k == 1u && LOAD_BY_ADDRESS != 0u) {
        u64vec2 pair = PixelPairsRef(raster.words_address).pairs[pixel];
        threshold = pair.x;
        cover = pair.y;
    } else {
        cover = load_pixel_word(first + k);
        threshold = load_pixel_word(threshold_word(first, k));
    }
    // add_coverage's test, with the increment (a logarithm: dear on CPU devices) computed only
    // for pixels not yet opaque.
    uint add = coverage_sum(cover) < COVERAGE_LIMIT ? coverage_increment(coverage * raster.opacity) : 0u;
#ifdef RASTER_MARKS
    if (SLOT_ORDER != 0u && (raster.flags & RASTER_FLAG_MARK) != 0u && (segment_marks & segment_bit) != segment_bit) {
        mark_segment(pixel, a.depth_bits, add > 0u, a.depth_bits <= uint(threshold >> DEPTH_SHIFT));
    }
#endif
    if (a.depth_bits <= uint(threshold >> DEPTH_SHIFT)) {
        if (!a.encoded) {
            a.word = visibility_word(a.depth_bits, visibility_attributes(a.material, a.tangent, a.tau, a.random));
            a.encoded = true;
        }
        uint64_t v = a.word | uint64_t(coverage_bits(coverage));
        if (k > 1u && claimed_slots(cover) < k) {
            claim_and_cover(first, k, v, add);
            return;
        }
        insert_visibility(first, k, v);
    }
    if (add > 0u) {
        atomicAdd(pixel_words[first + k], ~uint64_t(add) + 1UL);
    }
}

#endif

#ifndef SHADOW_RASTER
// Margins of segment_behind_tiles's box, in pixels, and of its depth, in depth-bit units: the
// columns compute their positions, widths and depths in their own order (and the compiler may
// contract them differently), so the box is widened and the depth lowered past any rounding.
const float SEGMENT_BOX_MARGIN = 1.0 / 64.0;
const uint SEGMENT_DEPTH_MARGIN = 2u;

// Whether every column of a segment lies behind the occlusion tiles (the rest phase): the box
// of the pixels its columns first..last can cover (across them, the centre line at the end
// columns widened by the wider end's half footprint h_max: the centre line is straight and the
// half footprint interpolates between the ends) fits in a square of up to 3×3 tiles whose word
// (raster_tiles.comp) lies in front of the segment's nearest depth (1 / the larger 1 / w of
// its ends: w is linear along it). Each column would then fail the column test, so the walk is
// skipped whole — the same image — for one load instead of a tile load per column. Eight
// strands walk in lock step on CPU devices and skip together only when all eight are hidden:
// the 3×3 tiles (24 pixels) take in the 12-pixel segments of the 100k-strand close-up, and a
// box no wider than one or two tiles reads its own or its 2×2 square's tighter word. A box of
// no pixel (a footprint wholly off the screen across it) covers nothing either.
bool segment_behind_tiles(int first, int last, float a_major, float a_minor, float inv_d_major, float d_minor,
                          float h_max, float max_inv_w, bool x_major, int size_minor) {
    float m_first = a_minor + (float(first) + 0.5 - a_major) * inv_d_major * d_minor;
    float m_last = a_minor + (float(last) + 0.5 - a_major) * inv_d_major * d_minor;
    float reach = h_max + SEGMENT_BOX_MARGIN;
    int lo = max(floor_int(min(m_first, m_last) - reach), 0);
    int hi = min(floor_int(max(m_first, m_last) + reach), size_minor - 1);
    if (lo > hi) {
        return true;
    }
    uvec2 b0 = uvec2(x_major ? ivec2(first, lo) : ivec2(lo, first)) / TILE_SIZE;
    uvec2 b1 = uvec2(x_major ? ivec2(last, hi) : ivec2(hi, last)) / TILE_SIZE;
    uint span = max(b1.x - b0.x, b1.y - b0.y);
    if (span > 2u) {
        return false;
    }
    uint behind = load_tile_word(RASTER_TILE_WORDS * (b0.y * raster.tiles_x + b0.x) + span);
    uint nearest = visibility_depth_bits(1.0 / max_inv_w);
    // (A word of all ones, a tile not closed, lies in front of nothing.)
    return nearest > SEGMENT_DEPTH_MARGIN && nearest - SEGMENT_DEPTH_MARGIN > behind;
}
#endif

#ifndef SHADOW_RASTER
// The larger 1 / w of columns c0 and c1 of a segment (its ends' 1 / w, the columns' centres
// i + 0.5 along the major axis from a_major), computed as the walk computes each column's:
// 1 / w is linear along the segment, so no column between them lies nearer.
float columns_nearest_inv_w(int c0, int c1, float a_major, float inv_d_major, float inv_wp, float inv_wq) {
    float at_c0 = mix(inv_wp, inv_wq, (float(c0) + 0.5 - a_major) * inv_d_major);
    float at_c1 = mix(inv_wp, inv_wq, (float(c1) + 0.5 - a_major) * inv_d_major);
    return max(at_c0, at_c1);
}
#endif

// One column of a segment's walk: its fragments' attributes and the pixels across it that its
// footprint [m - h, m + h] overlaps, j0..j1 (none when j1 < j0: past the segment's last column,
// or behind the occlusion tiles).
struct WalkColumn {
    ColumnAttributes attributes;
    float m;
    float h;
    float z;
    int j0;
    int j1;
};

// Column i of a segment (`within`: i is one of its columns; else the column has no pixels).
WalkColumn walk_column(int i, bool within, float a_major, float inv_d_major, float a_minor, float d_minor, float hp,
                       float hq, float stretch, float inv_wp, float inv_wq, float zp, float zq, RasterVertex p,
                       RasterVertex q, uint material, float random, bool x_major, int size_minor) {
    WalkColumn c;
    float t = (float(i) + 0.5 - a_major) * inv_d_major;
    c.m = a_minor + t * d_minor;
    c.h = mix(hp, hq, t) * stretch;
    float inv_w = mix(inv_wp, inv_wq, t);
    c.z = mix(zp, zq, t);
    // The view depth, and the perspective-correct weight of q for the attributes.
    float w = 1.0 / inv_w;
    float tq = t * inv_wq * w;
    c.attributes.depth_bits = visibility_depth_bits(w);
    c.attributes.encoded = false;
    c.attributes.tangent = mix(p.tangent, q.tangent, tq);
    c.attributes.tau = mix(p.tau, q.tau, tq);
    c.attributes.material = material;
    c.attributes.random = random;
    c.j0 = max(floor_int(c.m - c.h), 0);
    c.j1 = within ? min(floor_int(c.m + c.h), size_minor - 1) : -1;
#ifndef SHADOW_RASTER
    if (tile_culled() && c.j0 <= c.j1) {
        // The column's end pixels' tiles (and the two others of their square when it spans
        // two tiles): strictly behind all of them, it changes nothing.
        uvec2 e0 = uvec2(x_major ? ivec2(i, c.j0) : ivec2(c.j0, i)) / TILE_SIZE;
        // (tile_depth holds depth bits, as attributes.depth_bits.)
        uvec2 e1 = uvec2(x_major ? ivec2(i, c.j1) : ivec2(c.j1, i)) / TILE_SIZE;
        if (all(lessThanEqual(e1 - e0, uvec2(1u)))) {
            // One load: the tile's own word, or its 2×2 square's when the column reaches
            // into the next tiles (each lane's load is a scalar load on CPU devices).
            uint behind = load_tile_word(RASTER_TILE_WORDS * (e0.y * raster.tiles_x + e0.x) + (e0 == e1 ? 0u : 1u));
            if (c.attributes.depth_bits > behind) {
                c.j1 = -1;
            }
        }
    }
#endif
    return c;
}

// The fragment of column c (column i of the walk) at pixel j across it.
void column_fragment(int i, int j, inout WalkColumn c, uint major_step, uint minor_step) {
    float coverage = min(c.m + c.h, float(j + 1)) - max(c.m - c.h, float(j));
    uint pixel = uint(i) * major_step + uint(j) * minor_step;
#ifdef SHADOW_RASTER
    shadow_fragment(pixel, coverage, c.z);
#else
    raster_fragment(pixel, coverage, c.z, c.attributes);
#endif
}

void raster_segment(RasterVertex a, RasterVertex b, uint material, float random) {
    RasterVertex p = a;
    RasterVertex q = b;
    if (DEPTH_CLIPPING != 0u) {
        // Vulkan's view volume in depth: 0 <= z <= w (x and y are clipped per pixel below).
        float t0 = 0.0;
        float t1 = 1.0;
        clip_range(a.clip.z, b.clip.z, t0, t1);
        clip_range(a.clip.w - a.clip.z, b.clip.w - b.clip.z, t0, t1);
        if (!(t0 < t1)) {
            return;
        }
        // Nearly every segment lies within the view volume's depth and keeps its ends'
        // projections (made once per vertex); a clipped one projects its clipped ends.
        if (t0 > 0.0 || t1 < 1.0) {
            p = project_vertex(mix_vertex(a, b, t0));
            q = project_vertex(mix_vertex(a, b, t1));
        }
        if (!(p.clip.w > 1e-20) || !(q.clip.w > 1e-20)) {
            return;
        }
    }
    vec2 size = params.viewport.xy;
    vec2 sp = p.screen;
    vec2 sq = q.screen;
    float hp = p.half_width;
    float hq = q.half_width;
    vec2 d = sq - sp;
    float len = length(d);
    if (!(len > 1e-6) || !(hp + hq > 0.0)) {
        return;
    }
    bool x_major = abs(d.x) >= abs(d.y);
    float a_major = x_major ? sp.x : sp.y;
    float a_minor = x_major ? sp.y : sp.x;
    float d_major = x_major ? d.x : d.y;
    float d_minor = x_major ? d.y : d.x;
    int size_major = floor_int(x_major ? size.x : size.y);
    int size_minor = floor_int(x_major ? size.y : size.x);
    // Pixel (major i, minor j) is i * major_step + j * minor_step.
    uint width = uint(floor_int(size.x));
    uint major_step = x_major ? 1u : width;
    uint minor_step = x_major ? width : 1u;
    // Pixel centres i + 0.5 in [lo, hi): half-open, so a strand's segments share no column.
    float lo = min(a_major, a_major + d_major);
    float hi = max(a_major, a_major + d_major);
    int first = max(floor_int(ceil(lo - 0.5)), 0);
    int last = min(floor_int(ceil(hi - 0.5)) - 1, size_major - 1);
    // A footprint of perpendicular width 2h spans 2h * len / |d_major| along the minor axis.
    // Products by reciprocals made once per segment, not divisions per column.
    float inv_d_major = 1.0 / d_major;
    float stretch = len * abs(inv_d_major);
    float inv_wp = p.inv_w;
    float inv_wq = q.inv_w;
#ifndef SHADOW_RASTER
    if (tile_culled() && first <= last) {
        float h_max = max(hp, hq) * stretch;
        if (segment_behind_tiles(first, last, a_major, a_minor, inv_d_major, d_minor, h_max, max(inv_wp, inv_wq),
                                 x_major, size_minor)) {
            return;
        }
        // Then its ends a tile's length of columns at a time, each against its own box and its
        // own nearest depth (1 / w is linear along the segment: the larger 1 / w of the
        // chunk's end columns, as the walk computes them), while they lie behind the tiles: a
        // segment that comes out of the hair's surface is walked only where it does.
        while (last - first >= int(TILE_SIZE)) {
            int end = first + int(TILE_SIZE) - 1;
            float nearest = columns_nearest_inv_w(first, end, a_major, inv_d_major, inv_wp, inv_wq);
            if (!segment_behind_tiles(first, end, a_major, a_minor, inv_d_major, d_minor, h_max, nearest, x_major,
                                      size_minor)) {
                break;
            }
            first = end + 1;
        }
        while (last - first >= int(TILE_SIZE)) {
            int start = last - int(TILE_SIZE) + 1;
            float nearest = columns_nearest_inv_w(start, last, a_major, inv_d_major, inv_wp, inv_wq);
            if (!segment_behind_tiles(start, last, a_major, a_minor, inv_d_major, d_minor, h_max, nearest, x_major,
                                      size_minor)) {
                break;
            }
            last = start - 1;
        }
    }
#endif
    float zp = p.z;
    float zq = q.z;
    // Two columns per turn, their pixels side by side in one inner loop: on CPU devices
    // (llvmpipe) each turn of a loop costs the SIMD group its mask bookkeeping and writes back
    // every value the loop carries under the lanes' mask, and the inner loop takes as many
    // turns as the group's widest column — once per pair of columns now (four columns per turn
    // are no better: docs/compute-raster-notes.md). Which fragments are drawn and
    // the image are the same: only their order within a segment changes, and the visibility
    // and coverage words do not depend on the order.
    for (int i = first; i <= last; i += 2) {
        WalkColumn c0 = walk_column(i, true, a_major, inv_d_major, a_minor, d_minor, hp, hq, stretch, inv_wp, inv_wq, zp,
                                    zq, p, q, material, random, x_major, size_minor);
        WalkColumn c1 = walk_column(i + 1, i + 1 <= last, a_major, inv_d_major, a_minor, d_minor, hp, hq, stretch, inv_wp,
                                    inv_wq, zp, zq, p, q, material, random, x_major, size_minor);
        int widest = max(c0.j1 - c0.j0, c1.j1 - c1.j0);
        for (int d = 0; d <= widest; ++d) {
            if (c0.j0 + d <= c0.j1) {
                column_fragment(i, c0.j0 + d, c0, major_step, minor_step);
            }
            if (c1.j0 + d <= c1.j1) {
                column_fragment(i + 1, c1.j0 + d, c1, major_step, minor_step);
            }
        }
    }
}
