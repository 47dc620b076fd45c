// The compute rasterizer's per-pixel buffers, shared by the raster kernels (hair_raster.comp,
// hair_raster_stored.comp), the tile, shade and resolve passes. The CPU port is
// render/src/raster.rs (`cpu`); keep the two in step (tests compare them).
//
// Per pixel 64-bit words side by side, cleared to all ones: K visibility words (the K nearest
// fragments; K = 1 in opaque and blended scenes, the scene's oit_k with OIT), then the coverage
// word, then with K > 1 the threshold word (pixel_stride: K + 1 words for K = 1, else K + 2).
//
// Visibility words (visibility_write.glsl): with K = 1 the slot keeps the nearest word
// (atomicMin). With K > 1 the slots hold the K nearest words in no particular order (the shade
// pass sorts them) and the threshold word an upper bound of the farthest of them: a word at
// or beyond it is not among the K nearest. Either way the slots end holding the K smallest
// words whatever the order strands arrive in.
//   bits 42-63  view depth w: the float's bits >> 9 (w > 0, so the sign bit is 0): 14 mantissa
//               bits, a relative depth resolution of 2^-14 (60 µm at 1 m)
//   bits 32-41  material index (the character's hair material; at most 1024 per frame)
//   bits 23-31, 14-22  world-space tangent, octahedral, 9 bits each
//   bits 9-13   strand parameter tau, 5 bits
//   bits 4-8    per-strand random, 5 bits
//   bits 0-3    the fragment's coverage in 15ths (at least 1): OIT composites with it
// Coverage word, stored complemented (~sum, so the clear to all ones is a zero sum; a fragment
// subtracts its increment, ~s - i = ~(s + i)). Its low 32 bits: the optical depth
// d = -ln(1 - a) of every fragment's alpha a (coverage times the strand opacity) in fixed point,
// so the pixel's alpha 1 - exp(-sum) keeps the density of sub-pixel hair (1 - prod(1 - a_i),
// what blending every fragment gives). Nothing is added once the sum reaches COVERAGE_LIMIT,
// and it is read as min(sum, COVERAGE_LIMIT): a fragment is only skipped when the sum already
// is at the limit, so the result is the same in any order. A pixel at the limit reads as
// opaque (coverage_alpha). (The sum stays far below 2^32: it
// never carries into the high half.) Its high 32 bits, with K > 1: how many of the K slots
// have been claimed (visibility_write.glsl `claim_and_cover`), counted by the same atomic that
// adds the claimant's coverage.

#ifndef HK_RASTER_COMMON_GLSL
#define HK_RASTER_COMMON_GLSL

#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "hk_render_contract.glsl"
#include "float_int.glsl"

// How the compute rasterizer's raster and shade kernels read the buffers they only load from
// (pixel words, occlusion tiles, scene depth, shadow maps, stored vertices): 1 through the
// device addresses in their push constants (buffer references), 0 through their bindings
// (render/src/raster.rs `LoadPath`). A specialization constant rather than a test of the
// address: with the choice made at run time both loads stayed in the code, and llvmpipe ran
// the binding's lane-by-lane loop (a bounds check per lane) under an empty mask besides the
// reference's gather at every pixel test.
layout(constant_id = HK_LOAD_BY_ADDRESS_CONSTANT_ID) const uint LOAD_BY_ADDRESS = 0u;

// The visibility slots per pixel (K) of the frames the kernel runs in (render/src/raster.rs
// `ComputeRaster::new`), or 0 where the kernel takes K from its push constants (any K: the
// tests' stored-strand kernels). A constant K gives the loops over a pixel's slots a known trip
// count and leaves out the code of the other case (docs/compute-raster-notes.md).
layout(constant_id = HK_VISIBILITY_SLOTS_CONSTANT_ID) const uint VISIBILITY_SLOTS = 0u;

// K: the specialized one, else `pushed` (the push constants').
uint visibility_slots(uint pushed) {
    return VISIBILITY_SLOTS != 0u ? VISIBILITY_SLOTS : pushed;
}

const uint64_t VISIBILITY_EMPTY = 0xffffffffffffffffUL;
const float COVERAGE_SCALE = 256.0;          // fixed-point units per unit of optical depth
// Optical depth 4.5 (render/src/contract.rs COVERAGE_LIMIT): dense hair reaches it after a few
// fragments; the rest skip their atomic, and the occlusion tiles close over it.
const uint COVERAGE_LIMIT = HK_COVERAGE_LIMIT;
const float MAX_FRAGMENT_COVERAGE = 0.999;    // a solid fragment adds -ln(0.001) = 6.9
const uint MAX_MATERIALS = 1024u;
const uint DEPTH_SHIFT = 42u;
// Words per occlusion tile (raster_tiles.comp): its own farthest depth, its 2×2 square's, its
// 3×3 square's.
const uint RASTER_TILE_WORDS = HK_RASTER_TILE_WORDS;

// Interleaved gradient noise (Jimenez 2014): a fixed threshold in [0, 1) per pixel. In the
// transition band between a character's strands and its volume, the volume draws the pixels
// below its fraction and the strands the others: as the fraction follows the character's size
// smoothly, pixels switch one by one, with no frame where the whole character pops.
float transition_dither(uvec2 xy) {
    return fract(52.9829189 * fract(dot(vec2(xy) + 0.5, vec2(0.06711056, 0.00583715))));
}

// 64-bit words per pixel with K slots (render/src/raster.rs `pixel_stride`).
uint pixel_stride(uint k) {
    return k == 1u ? 2u : k + 2u;
}

// Word i of pixel p with K slots (word K is the coverage word, K + 1 the threshold word).
uint pixel_word(uint pixel, uint k, uint i) {
    return pixel * pixel_stride(k) + i;
}

// The word that bounds the pixel's K nearest from above (K = 1: the slot itself), for the
// pixel whose words start at `first`.
uint threshold_word(uint first, uint k) {
    return k == 1u ? first : first + k + 1u;
}

vec2 oct_wrap(vec2 v) {
    return (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
}

// A unit vector as two 9-bit octahedral coordinates.
uint encode_tangent(vec3 t) {
    vec3 n = t / max(abs(t.x) + abs(t.y) + abs(t.z), 1e-20);
    vec2 e = n.z >= 0.0 ? n.xy : oct_wrap(n.xy);
    uvec2 q = uvec2(floor_int2(clamp(round((e * 0.5 + 0.5) * 511.0), 0.0, 511.0)));
    return (q.x << 9u) | q.y;
}

vec3 decode_tangent(uint bits) {
    vec2 e = vec2(float((bits >> 9u) & 511u), float(bits & 511u)) / 511.0 * 2.0 - 1.0;
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) {
        n.xy = oct_wrap(n.xy);
    }
    return normalize(n);
}

// The attribute bits of a fragment but its coverage (bits 4-41).
uint64_t visibility_attributes(uint material, vec3 tangent, float tau, float random) {
    uint q_tau = uint(floor_int(clamp(round(tau * 31.0), 0.0, 31.0)));
    uint q_random = uint(floor_int(clamp(floor(random * 32.0), 0.0, 31.0)));
    return (uint64_t(material & (MAX_MATERIALS - 1u)) << 32) | (uint64_t(encode_tangent(tangent)) << 14)
         | uint64_t((q_tau << 9u) | (q_random << 4u));
}

// The coverage bits of a fragment of coverage c > 0: 1..15.
uint coverage_bits(float c) {
    return uint(floor_int(clamp(round(c * 15.0), 1.0, 15.0)));
}

// The depth bits of a visibility word (bits 42-63), as a 32-bit value.
uint visibility_depth_bits(float w) {
    return floatBitsToUint(w) >> 9u;
}

uint64_t visibility_word(uint depth_bits, uint64_t attributes) {
    return (uint64_t(depth_bits) << DEPTH_SHIFT) | attributes;
}

struct VisibleFragment {
    float w;          // view depth
    uint material;
    vec3 tangent;     // world space, unit
    float tau;
    float random;
    float coverage;   // in 15ths
};

VisibleFragment decode_visibility(uint64_t word) {
    VisibleFragment f;
    // The middle of the dropped bits' range.
    f.w = uintBitsToFloat((uint(word >> DEPTH_SHIFT) << 9u) | 256u);
    f.material = uint(word >> 32) & (MAX_MATERIALS - 1u);
    f.tangent = decode_tangent(uint(word >> 14) & 0x3ffffu);
    f.tau = float(uint(word >> 9) & 31u) / 31.0;
    f.random = (float(uint(word >> 4) & 31u) + 0.5) / 32.0;
    f.coverage = float(uint(word) & 15u) / 15.0;
    return f;
}

// The coverage increment of a fragment of alpha `a` (0 when it adds nothing).
uint coverage_increment(float a) {
    return uint(max(floor_int(-log(1.0 - min(a, MAX_FRAGMENT_COVERAGE)) * COVERAGE_SCALE + 0.5), 0));
}

// The optical-depth sum of a coverage word (its low half, complemented).
uint coverage_sum(uint64_t word) {
    return ~uint(word);
}

// How many slots of the pixel have been claimed, from its coverage word (its high half,
// complemented).
uint claimed_slots(uint64_t word) {
    return ~uint(word >> 32);
}

// The alpha of a pixel's coverage word: 1 - exp(-sum), and opaque at the limit (a pixel there
// holds at least that much hair, in dense hair far more: its alpha lies between 1 - 1.1 % and
// 1, nearer 1, and no background shows through dense hair).
float coverage_alpha(uint64_t word) {
    uint sum = coverage_sum(word);
    return sum >= COVERAGE_LIMIT ? 1.0 : 1.0 - exp(-float(sum) / COVERAGE_SCALE);
}

#endif
