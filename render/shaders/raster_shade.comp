#version 460
// Compute rasterizer, shade: per pixel, its K nearest fragments shaded with the triangle path's
// shade_hair — each one's world position rebuilt from the pixel centre and its view depth; its
// tangent, tau and strand random from its visibility word; its material from the frame's
// table — and composited front to back at its alpha (coverage times the strand opacity); what
// lies behind the K-th (the coverage word's optical depth beyond theirs) takes the K-th's
// colour. Written to the shaded buffer unpremultiplied (with the nearest's view depth; w < 0
// where no hair is): the resolve filters it and applies the pixel's alpha. With K = 1 this is
// the nearest fragment's colour. Pixels with fragments beyond their K slots are counted.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_buffer_reference : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "raster_common.glsl"
#include "dispatch_order.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// The pixel rectangle the frame's hair can cover (x0, y0, x1, y1; x1, y1 exclusive); slots K;
// device addresses of the buffers whose loads dominate, read through them when LOAD_BY_ADDRESS
// (raster_common.glsl; else through the bindings): CPU devices (llvmpipe) gather loads through
// a buffer reference with vector instructions, where a storage-buffer load of a divergent
// address is a loop over the SIMD lanes.
layout(push_constant) uniform Rect {
    uvec4 rect;
    uint k;
    uint flags;                      // bit 0: write final_depth (render/src/raster.rs SHADE_FINAL_DEPTH)
    uint64_t words_address;          // the pixel words
    uint64_t shadow_depth_address;
    uint64_t shadow_opacity_address;
    uint64_t occluder_depth_address;
} area;

layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer PixelWordsRef { uint64_t words[]; };
// With K = 1 a pixel's two words (the slot, then the coverage word) as one 16-byte element.
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer PixelPairsRef { u64vec2 pairs[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer FloatsRef { float values[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer Vec4sRef { vec4 values[]; };

#define SHADOW_DEPTH_LOAD(i) \
    (LOAD_BY_ADDRESS != 0u ? FloatsRef(area.shadow_depth_address).values[i] : shadow_depth[i])
#define SHADOW_OPACITY_LOAD(i) \
    (LOAD_BY_ADDRESS != 0u ? Vec4sRef(area.shadow_opacity_address).values[i] : shadow_opacity[i])
#define OCCLUDER_DEPTH_LOAD(i) \
    (LOAD_BY_ADDRESS != 0u ? FloatsRef(area.occluder_depth_address).values[i] : occluder_depth[i])

// Hair shading with volume shadows: the light through the character's own hair volume.
float shade_light_transmittance(uint i, vec3 p);
#define HAIR_LIGHT_TRANSMITTANCE(i, p) shade_light_transmittance(i, p)
#include "hair_shading.glsl"
#include "raster_frame.glsl"

layout(std430, set = 0, binding = HK_BINDING_VISIBILITY) readonly buffer PixelBuffer { uint64_t pixel_words[]; };
layout(std430, set = 0, binding = HK_BINDING_SHADED) writeonly buffer ShadedBuffer { vec4 shaded[]; };
// x: pixels whose fragments did not all fit their K slots.
layout(std430, set = 0, binding = HK_BINDING_RASTER_COUNTERS) buffer Counters { uint counters[]; };
// Per pixel the depth bits of its K-th nearest fragment (all ones: fewer than K; 0: the pixel is
// not opaque): what the next frame's raster tests to mark the segments that reached the image
// (hair_raster.comp).
layout(std430, set = 0, binding = HK_BINDING_RASTER_FINAL_DEPTH) writeonly buffer FinalDepthBuffer { uint final_depth[]; };
// The hair volumes (render/src/volume.rs), read for materials whose volume_info.y asks for AO
// or volume shadows: AO per voxel, mean direction and σ per voxel, bricks.
#include "volume_ao.glsl"
layout(std430, set = 0, binding = HK_BINDING_VOLUME) readonly buffer VolumeBuffer { vec4 volume[]; };
layout(std430, set = 0, binding = HK_BINDING_VOLUME_BRICKS) readonly buffer BrickBuffer { uint bricks[]; };
#include "volume_sample.glsl"

// ONLY_MATERIAL of a scene with more than one material.
const uint SEVERAL_MATERIALS = 0xffffffffu;
// The scene's only hair material (0), or SEVERAL_MATERIALS: with one, the per-fragment reload
// below is dead code, and the material's loads have a constant index.
layout(constant_id = HK_ONLY_MATERIAL_CONSTANT_ID) const uint ONLY_MATERIAL = SEVERAL_MATERIALS;

// scene.rs caps effects.oit_k at this.
const uint MAX_SLOTS = 16u;

// Orders s[i] <= s[j].
#define ORDER_SLOTS(i, j) \
    { uint64_t nearer = min(s[i], s[j]); s[j] = max(s[i], s[j]); s[i] = nearer; }

// A plain load of word i.
uint64_t load_pixel_word(uint i) {
    return LOAD_BY_ADDRESS != 0u ? PixelWordsRef(area.words_address).words[i] : pixel_words[i];
}

// The K > 1 slots of the pixel whose words start at `first`, sorted nearest first into `s` (the
// raster kernels leave them unordered): Batcher's odd-even merge sort of 4, 8 or 16 words
// (5, 19 or 63 compare-exchanges), the slots past K empty, with constant indices only so that
// the words stay in registers on CPU devices; the pixel's words are left as they are (nothing
// after this pass reads the slots: writing the sorted words back and reading them again were
// two scattered accesses per slot).
void sort_slots(uint first, uint k, out uint64_t s[MAX_SLOTS]) {
    [[unroll]] for (uint i = 0u; i < MAX_SLOTS; ++i) {
        s[i] = i < k ? load_pixel_word(first + i) : VISIBILITY_EMPTY;
    }
    if (k <= 4u) {
        ORDER_SLOTS(0, 1); ORDER_SLOTS(2, 3); ORDER_SLOTS(0, 2); ORDER_SLOTS(1, 3);
        ORDER_SLOTS(1, 2);
    } else if (k <= 8u) {
        ORDER_SLOTS(0, 1); ORDER_SLOTS(2, 3); ORDER_SLOTS(4, 5); ORDER_SLOTS(6, 7);
        ORDER_SLOTS(0, 2); ORDER_SLOTS(1, 3); ORDER_SLOTS(4, 6); ORDER_SLOTS(5, 7);
        ORDER_SLOTS(1, 2); ORDER_SLOTS(5, 6); ORDER_SLOTS(0, 4); ORDER_SLOTS(1, 5);
        ORDER_SLOTS(2, 6); ORDER_SLOTS(3, 7); ORDER_SLOTS(2, 4); ORDER_SLOTS(3, 5);
        ORDER_SLOTS(1, 2); ORDER_SLOTS(3, 4); ORDER_SLOTS(5, 6);
    } else {
        ORDER_SLOTS(0, 1); ORDER_SLOTS(2, 3); ORDER_SLOTS(4, 5); ORDER_SLOTS(6, 7);
        ORDER_SLOTS(8, 9); ORDER_SLOTS(10, 11); ORDER_SLOTS(12, 13); ORDER_SLOTS(14, 15);
        ORDER_SLOTS(0, 2); ORDER_SLOTS(1, 3); ORDER_SLOTS(4, 6); ORDER_SLOTS(5, 7);
        ORDER_SLOTS(8, 10); ORDER_SLOTS(9, 11); ORDER_SLOTS(12, 14); ORDER_SLOTS(13, 15);
        ORDER_SLOTS(1, 2); ORDER_SLOTS(5, 6); ORDER_SLOTS(9, 10); ORDER_SLOTS(13, 14);
        ORDER_SLOTS(0, 4); ORDER_SLOTS(1, 5); ORDER_SLOTS(2, 6); ORDER_SLOTS(3, 7);
        ORDER_SLOTS(8, 12); ORDER_SLOTS(9, 13); ORDER_SLOTS(10, 14); ORDER_SLOTS(11, 15);
        ORDER_SLOTS(2, 4); ORDER_SLOTS(3, 5); ORDER_SLOTS(10, 12); ORDER_SLOTS(11, 13);
        ORDER_SLOTS(1, 2); ORDER_SLOTS(3, 4); ORDER_SLOTS(5, 6); ORDER_SLOTS(9, 10);
        ORDER_SLOTS(11, 12); ORDER_SLOTS(13, 14); ORDER_SLOTS(0, 8); ORDER_SLOTS(1, 9);
        ORDER_SLOTS(2, 10); ORDER_SLOTS(3, 11); ORDER_SLOTS(4, 12); ORDER_SLOTS(5, 13);
        ORDER_SLOTS(6, 14); ORDER_SLOTS(7, 15); ORDER_SLOTS(4, 8); ORDER_SLOTS(5, 9);
        ORDER_SLOTS(6, 10); ORDER_SLOTS(7, 11); ORDER_SLOTS(2, 4); ORDER_SLOTS(3, 5);
        ORDER_SLOTS(6, 8); ORDER_SLOTS(7, 9); ORDER_SLOTS(10, 12); ORDER_SLOTS(11, 13);
        ORDER_SLOTS(1, 2); ORDER_SLOTS(3, 4); ORDER_SLOTS(5, 6); ORDER_SLOTS(7, 8);
        ORDER_SLOTS(9, 10); ORDER_SLOTS(11, 12); ORDER_SLOTS(13, 14);
    }
}

// Sorted slot i (uniform across the invocations): a select per slot, as a dynamic index into
// a private array is lane-by-lane work on CPU devices.
uint64_t sorted_slot(uint64_t s[MAX_SLOTS], uint i) {
    uint64_t word = VISIBILITY_EMPTY;
    [[unroll]] for (uint j = 0u; j < MAX_SLOTS; ++j) {
        if (j == i) {
            word = s[j];
        }
    }
    return word;
}

// The material of the fragment being shaded (for shade_light_transmittance).
RasterMaterial shading_material;

// The maps' light (occluders, and the hair unless the material's volume shadows it), times the
// transmittance of the character's hair volume from p toward light i (half a voxel on, so a
// fragment does not shadow itself).
float shade_light_transmittance(uint i, vec3 p) {
    vec2 maps = light_visibility(i, p);
    RasterMaterial m = shading_material;
    if ((m.volume_info.y & 2u) == 0u || !light_volume_shadows(i)) {
        return maps.x * maps.y;
    }
    vec3 origin = (m.world_to_voxel * vec4(p, 1.0)).xyz;
    vec3 direction = mat3(m.world_to_voxel) * light_direction(i, p);
    // A point light ends the path at the light.
    vec4 lv = lights[i].vector;
    float t1 = lv.w > 0.5 ? distance(lv.xyz, p) : 1e30;
    float t0 = 0.5 / max(length(direction), 1e-20);
    return maps.x * volume_transmittance(m.volume, m.volume_info.x, origin, direction, t0, t1, m.opacity.x);
}

// AO of material m's volume at world point p (1 without AO).
float ambient_occlusion(RasterMaterial m, vec3 p) {
    if ((m.volume_info.y & 1u) == 0u) {
        return 1.0;
    }
    return volume_ao_sample(m.volume, (m.world_to_voxel * vec4(p, 1.0)).xyz);
}

// The pixel's ray: its unit direction from the eye, over its cosine with the view direction
// (a point at view depth w lies w times this from the eye). Once per pixel, for all its
// fragments.
vec3 pixel_ray(vec2 ndc) {
    vec4 far_point = frame.inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 ray = normalize(far_point.xyz / far_point.w - frame.eye.xyz);
    return ray / max(dot(ray, frame.forward.xyz), 1e-6);
}

vec3 shade_fragment(VisibleFragment f, vec3 ray, RasterMaterial m) {
    vec3 position = frame.eye.xyz + ray * f.w;
    // Shaded at full coverage: compositing applies the alpha.
    HairSample s = HairSample(position, f.tau, f.tangent, f.random, 1.0, ambient_occlusion(m, position));
    shading_material = m;
    HairMaterial material = HairMaterial(mat4(1.0), frame.eye.xyz, uint(frame.eye.w), m.hair_color,
                                         m.specular_shift, m.specular_strength, 1.0);
    return shade_hair_world(s, material).rgb;
}

void main() {
    // With K > 1, tiles in the dispatch order (dispatch_order.glsl): on CPU devices each worker
    // thread shades tiles from all over the frame, not the top or the bottom of it. With one
    // fragment per pixel the work is light and even, and the tiles in their own order cost less.
    uvec2 xy = (VISIBILITY_SLOTS == 1u ? gl_GlobalInvocationID.xy : ORDERED_GLOBAL_INVOCATION_ID.xy) + area.rect.xy;
    if (xy.x >= area.rect.z || xy.y >= area.rect.w) {
        return;
    }
    uint pixel = xy.y * frame.size.x + xy.x;
    uint k = visibility_slots(area.k);
    uint first = pixel_word(pixel, k, 0u);
    // Slots fill in order (the first empty one is the farthest an insertion replaces), so an
    // empty first slot is an empty pixel.
    // With K = 1 nothing is sorted or written: both words come through the reference in one
    // 16-byte load (one address for both words on CPU devices, where each binding load is a loop
    // over the lanes).
    bool paired = k == 1u && LOAD_BY_ADDRESS != 0u;
    u64vec2 pair = paired ? PixelPairsRef(area.words_address).pairs[pixel] : u64vec2(0UL);
    uint64_t nearest = paired ? pair.x : pixel_words[first];
    if (nearest == VISIBILITY_EMPTY) {
        shaded[pixel] = vec4(0.0, 0.0, 0.0, -1.0);
        if ((area.flags & 1u) != 0u) {
            final_depth[pixel] = 0u;
        }
        return;
    }
    vec3 ray = pixel_ray((vec2(xy) + 0.5) / vec2(frame.size.xy) * 2.0 - 1.0);
    vec3 color = vec3(0.0);
    float transmittance = 1.0;
    vec3 last = vec3(0.0);
    float w = 0.0;
    // A pixel's fragments mostly share one material: it is read again only when it changes
    // (160 bytes, which CPU devices read lane by lane at a fragment's index). A scene's only
    // material is read at a constant index, once for all lanes there, and never again.
    uint material = ONLY_MATERIAL;
    RasterMaterial m;
    if (ONLY_MATERIAL != SEVERAL_MATERIALS) {
        m = frame.materials[ONLY_MATERIAL];
    }
    uint64_t sorted[MAX_SLOTS];
    if (k > 1u) {
        sort_slots(first, k, sorted);
    }
    for (uint i = 0u; i < k; ++i) {
        uint64_t word = paired ? pair.x : k > 1u ? sorted_slot(sorted, i) : pixel_words[first];
        if (word == VISIBILITY_EMPTY) {
            break;
        }
        VisibleFragment f = decode_visibility(word);
        if (i == 0u) {
            w = f.w;
        }
        if (ONLY_MATERIAL == SEVERAL_MATERIALS && f.material != material) {
            material = f.material;
            m = frame.materials[min(material, MAX_MATERIALS - 1u)];
        }
        float alpha = min(f.coverage * m.opacity.x, MAX_FRAGMENT_COVERAGE);
        last = shade_fragment(f, ray, m);
        color += transmittance * alpha * last;
        transmittance *= 1.0 - alpha;
    }
    // Everything behind the slots: the pixel's whole transmittance over the slots'.
    uint64_t cover = paired ? pair.y : pixel_words[first + k];
    float total = 1.0 - coverage_alpha(cover);
    float tail = clamp(1.0 - total / max(transmittance, 1e-6), 0.0, 1.0);
    // (Slots fill in order: the last holds a fragment when all do.)
    uint64_t farthest = paired ? pair.x : k > 1u ? sorted_slot(sorted, k - 1u) : pixel_words[first];
    // Counted once per subgroup: with one slot, nearly every pixel of dense hair has fragments
    // behind its nearest, and an atomic per pixel on the one counter cost the 100k-strand
    // close-up's shade pass about a fifth of its time on CPU devices.
    uvec4 overflowing = subgroupBallot(farthest != VISIBILITY_EMPTY && tail > 1.0 / 255.0);
    if (subgroupElect()) {
        uint count = subgroupBallotBitCount(overflowing);
        if (count > 0u) {
            atomicAdd(counters[0], count);
        }
    }
    // 0 where the pixel is not opaque: no strand order closes its tile (hair_raster.comp
    // marks nothing there).
    bool opaque = coverage_sum(cover) >= COVERAGE_LIMIT;
    if ((area.flags & 1u) != 0u) {
        final_depth[pixel] = !opaque ? 0u : farthest == VISIBILITY_EMPTY ? 0xffffffffu : uint(farthest >> DEPTH_SHIFT);
    }
    color += transmittance * tail * last;
    float alpha = 1.0 - transmittance * (1.0 - tail);
    shaded[pixel] = vec4(color / max(alpha, 1e-6), w);
}
