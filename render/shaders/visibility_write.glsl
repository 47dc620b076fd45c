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

// Compare-and-swap attempts of one insertion (K > 1). An attempt fails only when another
// insertion into the same pixel succeeded between its loads and its swap, which a handful of
// concurrent invocations cannot make happen this often.
const uint MAX_INSERT_ATTEMPTS = 64u;

// Inserts visibility word `v` among the K nearest of the pixel whose words start at `first`.
// K = 1: an atomic minimum. K > 1: the slots are unordered; `v` replaces the farthest of them
// with a compare-and-swap (one atomic, where keeping them sorted moved every farther word one
// slot on, an atomic each), then lowers the threshold word to the farthest of the others and
// `v`. Slots only ever decrease, so the farthest found by the loads is the slots' current
// farthest when its swap succeeds (if another insertion changed that slot meanwhile, the swap
// fails and the slots are read again), and the threshold stays at or above the slots'
// farthest. The slots end holding the K smallest words in any arrival order.
void insert_visibility(uint first, uint k, uint64_t v) {
    if (k == 1u) {
        if (v < PIXEL_WORD_LOAD(first)) {
            atomicMin(pixel_words[first], v);
        }
        return;
    }
    for (uint attempt = 0u; attempt < MAX_INSERT_ATTEMPTS; ++attempt) {
        uint64_t farthest = 0UL;
        uint64_t second = 0UL;
        uint at = 0u;
        for (uint i = 0u; i < k; ++i) {
            // A retry reads through the binding: loads through a readonly buffer reference may
            // be hoisted out of this loop by the compiler and would see the same words again.
            uint64_t w = attempt == 0u ? PIXEL_WORD_LOAD(first + i) : pixel_words[first + i];
            if (w > farthest) {
                second = farthest;
                farthest = w;
                at = i;
            } else if (w > second) {
                second = w;
            }
        }
        if (v >= farthest) {
            // Not among the K nearest. If the threshold word (an upper bound) lies beyond the
            // full slots' farthest, which claim_and_cover's fills leave it at, lower it: later
            // fragments are rejected by its plain load instead of this scan.
            if (attempt == 0u && farthest != VISIBILITY_EMPTY && farthest < PIXEL_WORD_LOAD(first + k + 1u)) {
                atomicMin(pixel_words[first + k + 1u], farthest);
            }
            return;
        }
        if (atomicCompSwap(pixel_words[first + at], farthest, v) == farthest) {
            // While the slots are filling (another empty one left) the bound is all ones, the
            // cleared threshold: the atomic would change nothing.
            uint64_t bound = max(second, v);
            if (bound != VISIBILITY_EMPTY) {
                atomicMin(pixel_words[first + k + 1u], bound);
            }
            return;
        }
    }
}

// Adds `add` fixed-point units of optical depth to coverage word `cover`, unless it already
// reached COVERAGE_LIMIT (a plain load first: opaque pixels skip the atomic).
void add_coverage(uint cover, uint add) {
    if (add > 0u && coverage_sum(PIXEL_WORD_LOAD(cover)) < COVERAGE_LIMIT) {
        atomicAdd(pixel_words[cover], ~uint64_t(add) + 1UL);
    }
}

// One claimed slot in the coverage word's high half.
const uint64_t CLAIM_UNIT = 1UL << 32;

// K > 1, while the pixel's slots are filling (`cover_word`, a plain load of its coverage word,
// counts fewer than K claimed): claims the next slot and adds `add` units of coverage in one
// atomic, then fills the claimed slot if it is still empty — where scanning the K slots for
// the farthest cost K loads and a compare-and-swap besides the coverage's atomic. Slot n is
// claimed once, by the n-th claim; a claim past K, or of a slot that an insertion already
// filled (insert_visibility's first empty one), inserts `v` the general way. Slots only leave
// the empty state, so the filled ones still form a prefix and the K nearest end in them.
void claim_and_cover(uint first, uint k, uint64_t v, uint add) {
    uint64_t before = atomicAdd(pixel_words[first + k], ~(CLAIM_UNIT + uint64_t(add)) + 1UL);
    uint slot = claimed_slots(before);
    if (slot < k && atomicCompSwap(pixel_words[first + slot], VISIBILITY_EMPTY, v) == VISIBILITY_EMPTY) {
        return;
    }
    insert_visibility(first, k, v);
}
