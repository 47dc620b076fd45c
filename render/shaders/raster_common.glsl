// The compute rasterizer's per-pixel buffers, shared by the raster kernels (hair_raster.comp,
// hair_raster_stored.comp) and the resolve (raster_resolve.frag). The CPU port is
// render/src/raster_cpu.rs; keep the two in step (tests compare them).
//
// Per pixel two 64-bit words side by side (one cache line serves both), cleared to all ones:
// word 2p the visibility word, word 2p + 1 the coverage word.
//
// Visibility word: the nearest fragment wins an atomicMin, so the order strands arrive in never
// matters.
//   bits 40-63  view depth w: the float's bits >> 7 (w > 0, so the sign bit is 0): 16 mantissa
//               bits, a relative depth resolution of 2^-16 (15 µm at 1 m)
//   bits 30-39  material index (the character's hair material; at most 1024 per frame)
//   bits 21-29, 12-20  world-space tangent, octahedral, 9 bits each
//   bits 6-11   strand parameter tau, 6 bits
//   bits 0-5    per-strand random, 6 bits
// Coverage word, stored complemented (~sum, so the clear to all ones is a zero sum; a fragment
// subtracts its increment, ~s - i = ~(s + i)): the optical depth d = -ln(1 - c) of every
// fragment's coverage c in fixed point, so alpha = 1 - exp(-sum) keeps the density of sub-pixel
// hair (1 - prod(1 - c_i), what blending every fragment would give). Nothing is added once the
// sum reaches COVERAGE_LIMIT, and the resolve reads min(sum, COVERAGE_LIMIT): a fragment is only
// skipped when the sum already is at the limit, so the result is the same in any order.

#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "hk_render_contract.glsl"

const uint64_t VISIBILITY_EMPTY = 0xffffffffffffffffUL;
const float COVERAGE_SCALE = 256.0;          // fixed-point units per unit of optical depth
// Optical depth 12 (alpha 1 - 6e-6): dense hair reaches it after a few fragments, and the rest
// skip their atomic.
const uint COVERAGE_LIMIT = 3072u;
const float MAX_FRAGMENT_COVERAGE = 0.999;    // a solid fragment adds -ln(0.001) = 6.9
const uint MAX_MATERIALS = 1024u;

vec2 oct_wrap(vec2 v) {
    return (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
}

// A unit vector as two 9-bit octahedral coordinates.
uint encode_tangent(vec3 t) {
    vec3 n = t / max(abs(t.x) + abs(t.y) + abs(t.z), 1e-20);
    vec2 e = n.z >= 0.0 ? n.xy : oct_wrap(n.xy);
    uvec2 q = uvec2(clamp(round((e * 0.5 + 0.5) * 511.0), 0.0, 511.0));
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

// The 40 attribute bits of a fragment.
uint64_t visibility_attributes(uint material, vec3 tangent, float tau, float random) {
    uint q_tau = uint(clamp(round(tau * 63.0), 0.0, 63.0));
    uint q_random = uint(clamp(floor(random * 64.0), 0.0, 63.0));
    return (uint64_t(material & (MAX_MATERIALS - 1u)) << 30) | (uint64_t(encode_tangent(tangent)) << 12)
         | uint64_t((q_tau << 6u) | q_random);
}

// The depth bits of a visibility word (bits 40-63), as a 32-bit value.
uint visibility_depth_bits(float w) {
    return floatBitsToUint(w) >> 7u;
}

uint64_t visibility_word(uint depth_bits, uint64_t attributes) {
    return (uint64_t(depth_bits) << 40) | attributes;
}

struct VisibleFragment {
    float w;          // view depth
    uint material;
    vec3 tangent;     // world space, unit
    float tau;
    float random;
};

VisibleFragment decode_visibility(uint64_t word) {
    VisibleFragment f;
    // The middle of the dropped bits' range.
    f.w = uintBitsToFloat((uint(word >> 40) << 7u) | 64u);
    f.material = uint(word >> 30) & (MAX_MATERIALS - 1u);
    f.tangent = decode_tangent(uint(word >> 12) & 0x3ffffu);
    f.tau = float(uint(word >> 6) & 63u) / 63.0;
    f.random = (float(uint(word) & 63u) + 0.5) / 64.0;
    return f;
}

// The coverage increment of a fragment (0 when it adds nothing).
uint coverage_increment(float coverage) {
    return uint(-log(1.0 - min(coverage, MAX_FRAGMENT_COVERAGE)) * COVERAGE_SCALE + 0.5);
}

// The alpha of a coverage sum (the complemented coverage word, ~word).
float coverage_alpha(uint64_t sum) {
    return 1.0 - exp(-float(min(sum, uint64_t(COVERAGE_LIMIT))) / COVERAGE_SCALE);
}
