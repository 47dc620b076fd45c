// Strand generation shared by the mesh path (strand.task/strand.mesh) and the compute path
// (lod.comp, generate.comp). It is the GPU port of hairmesh's CPU reference generator
// (hairmesh/src/reference.rs, style.rs, texture.rs): same layout, same hash, same formulas,
// same order. Keep the two in step; tests compare them.

#extension GL_EXT_control_flow_attributes : enable
#extension GL_KHR_shader_subgroup_ballot : enable
#extension GL_KHR_shader_subgroup_vote : enable

// Bindings, locations and limits from gen-gpu/src/contract.rs (generated at build time).
#include "hk_gen_contract.glsl"

// Specialization constants.
layout(constant_id = 0) const uint MANUAL_FILTERING = 0u; // 1: texelFetch + f32 lerps
layout(constant_id = 1) const uint CAPTURE = 0u;          // mesh path: also write the capture buffer
layout(constant_id = 2) const uint EXACT_CUBIC = 0u;      // 1: exact cubic instead of two quadratics
// 1: every vertex samples the textures (Filtering::Hardware / Manual); 0: strand-coherent
// evaluation from per-strand control data (below), and where a workgroup samples per vertex
// anyway it filters manually, so the variant never depends on the sampler's weight precision.
layout(constant_id = 3) const uint PER_VERTEX_FETCH = 0u;

const uint MAX_SEGMENTS_LOG2 = HK_MAX_SEGMENTS_LOG2;
const uint MAX_SEGMENTS = 1u << MAX_SEGMENTS_LOG2;
const uint MAX_VERTICES = MAX_SEGMENTS + 1u;
const uint STRAND_THREADS = 32u;

struct GenParams {
    mat4 view_proj;      // object space -> clip space
    vec4 eye;            // xyz: eye in object space; w: vertical resolution R
    vec4 projection;     // x: tan(fov_y / 2) (perspective); y: half view height (orthographic); z: 1 = orthographic; w: 1 = cull
    vec4 lod;            // x: enabled; y: strand alpha; z: vertex alpha; w: morph band lambda
    uvec4 counts;        // x: bundles; y: max segments log2 E; z: square sets; w: triangle sets
    vec4 normalization;  // xyz: origin; w: scale
    uvec4 layout_info;   // x: -; y: width; z: height; w: layers L
    vec4 style0;         // width, tip_width, root_fade, length_variation
    vec4 curl;           // radius, frequency, phase, -
    vec4 wave_frizz;     // wave amplitude, wave frequency, frizz amplitude, frizz frequency
    vec4 frizz_clump;    // frizz exponent, clump strength, clump exponent, twist
    vec4 stray;          // stray fraction, stray amplitude; z: wave coherence (clamped to 0..1); w: -
    uvec4 seed_info;     // x: style seed; y: triangle set base (index of the first triangle set); z, w: -
    vec4 viewport;       // x: width, y: height in pixels
    vec4 lod_error;      // x: style-aware vertex LOD's error bound epsilon in pixels (0: off); yzw: -
    vec4 head_field;     // xyz: the head field's grid origin; w: its cell (0: no field)
    vec4 head_margin;    // x: the margin strands keep from the head; yzw: -
};

struct Bundle {
    vec4 bounds_min;     // xyz, w: face size (strand LOD h)
    vec4 bounds_max;     // xyz, w: hair length (vertex LOD h)
    uvec4 info;          // x: strands N_i; y: bit 0 domain (0 square, 1 triangle), bits 1-3 root symmetry,
                         //    bits 4-10 tip layer (1..L);
                         // z: sample set; w: cell x (bits 0-13), y (14-27), orientation (28-30)
};

struct SampleSetInfo {
    uint offset;
    uint count;
};

struct BundleLod {
    uint strands;        // N'_i (0 when culled)
    uint level;          // e
    float gamma;         // morph weight of odd vertices
    float width_scale;   // min(1/L, N_i)
};

layout(std430, set = 0, binding = HK_BINDING_GEN_PARAMS) readonly buffer ParamsBuffer { GenParams params; };
layout(std430, set = 0, binding = HK_BINDING_BUNDLES) readonly buffer BundleBuffer { Bundle bundles[]; };
// Root samples as unorm16 pairs (hairmesh::roots::pack_sample).
layout(std430, set = 0, binding = HK_BINDING_ROOT_SAMPLES) readonly buffer SampleBuffer { uint samples[]; };
layout(std430, set = 0, binding = HK_BINDING_SAMPLE_SETS) readonly buffer SampleSetBuffer { SampleSetInfo sample_sets[]; };
layout(set = 0, binding = HK_BINDING_HAIR_MESH_TEXTURE) uniform sampler3D hair_mesh_tex;
// û in rgb, w in alpha (gen-gpu packs the asset's two layer textures into one at upload).
layout(set = 0, binding = HK_BINDING_U_TEXTURE) uniform sampler3D u_tex;
layout(set = 0, binding = HK_BINDING_V_TEXTURE) uniform sampler3D v_tex;
// The head's signed distances (hairmesh::head_field), one channel.
layout(set = 0, binding = HK_BINDING_HEAD_FIELD) uniform sampler3D head_field_tex;

#include "float_int.glsl"

// ---------------------------------------------------------------- hashing (style.rs)

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The per-strand part of strand_random's hash: computed once per strand where a strand's
// vertices are evaluated together.
uint strand_seed(uint bundle, uint strand) {
    return pcg_hash(pcg_hash(bundle ^ params.seed_info.x) + strand);
}

// strand_random(bundle, strand, k) from strand_seed(bundle, strand).
float seeded_random(uint seed, uint k) {
    return float(pcg_hash(seed + k)) * (1.0 / 4294967296.0);
}

float strand_random(uint bundle, uint strand, uint k) {
    return seeded_random(strand_seed(bundle, strand), k);
}

float bundle_delta(uint bundle) {
    return float(pcg_hash(bundle ^ 0x5bd1e995u)) * (1.0 / 4294967296.0);
}

// ---------------------------------------------------------------- textures (texture.rs)

// Trilinear fetch at continuous texel coordinates (texel centres at +0.5), clamp to edge.
vec4 fetch(sampler3D tex, vec3 coord) {
    vec3 size = vec3(textureSize(tex, 0));
    if (MANUAL_FILTERING == 0u && PER_VERTEX_FETCH == 1u) {
        return textureLod(tex, coord / size, 0.0);
    }
    vec3 f = clamp(coord - 0.5, vec3(0.0), size - 1.0);
    ivec3 i0 = floor_int3(f);
    ivec3 i1 = min(i0 + 1, textureSize(tex, 0) - 1);
    vec3 w = f - vec3(i0);
    vec4 c00 = mix(texelFetch(tex, ivec3(i0.x, i0.y, i0.z), 0), texelFetch(tex, ivec3(i1.x, i0.y, i0.z), 0), w.x);
    vec4 c10 = mix(texelFetch(tex, ivec3(i0.x, i1.y, i0.z), 0), texelFetch(tex, ivec3(i1.x, i1.y, i0.z), 0), w.x);
    vec4 c01 = mix(texelFetch(tex, ivec3(i0.x, i0.y, i1.z), 0), texelFetch(tex, ivec3(i1.x, i0.y, i1.z), 0), w.x);
    vec4 c11 = mix(texelFetch(tex, ivec3(i0.x, i1.y, i1.z), 0), texelFetch(tex, ivec3(i1.x, i1.y, i1.z), 0), w.x);
    return mix(mix(c00, c10, w.y), mix(c01, c11, w.y), w.z);
}

// One of the 8 symmetries of the unit square (hairmesh::lattice::SquareSymmetry): bit 0 swaps
// s and t, then bit 1 mirrors s, bit 2 mirrors t.
vec2 square_symmetry(uint code, vec2 st) {
    if ((code & 1u) != 0u) {
        st = st.yx;
    }
    if ((code & 2u) != 0u) {
        st.x = 1.0 - st.x;
    }
    if ((code & 4u) != 0u) {
        st.y = 1.0 - st.y;
    }
    return st;
}

// A cell's origin in the shared-vertex lattice from the bundle table's packed cell word
// (x in bits 0-13, y in 14-27; the orientation above is ignored).
ivec2 cell_origin(uint cell) {
    return ivec2(int(cell & 0x3fffu), int((cell >> 14u) & 0x3fffu));
}

// The bundle's cell in the shared-vertex lattice (texture.rs, TextureLayout::block_coord).
vec2 block_coord(uint bundle, vec2 st) {
    uint cell = bundles[bundle].info.w;
    return vec2(cell_origin(cell)) + 0.5 + square_symmetry(cell >> 28u, st);
}

// Where tau falls between the layers: the segment and the parameter inside it.
float curve_segment(float tau, out float local) {
    float layers = float(max(params.layout_info.w, 1u));
    float x = min(clamp(tau, 0.0, 1.0) * layers, layers);
    float segment = min(floor(x), layers - 1.0);
    local = x - segment;
    return segment;
}

// The two hair-mesh texture coordinates (slice axis, texel centres at +0.5) and the weight
// of the quadratic point at tau: the slices from z = 3 segment are B0, q_a, q_b, B3, and the
// quadratics' shared point m = (q_a + q_b)/2 is implicit, lerp(q_a, m, q) = lerp(q_a, q_b,
// q/2) (texture.rs, curve_position).
float quadratic_slices(float tau, out float za, out float zb) {
    float local;
    float z = 3.0 * curve_segment(tau, local) + 0.5;
    float q;
    if (local < 0.5) {
        q = 2.0 * local;
        za = z + q;
        zb = z + 1.0 + 0.5 * q;
    } else {
        q = 2.0 * local - 1.0;
        za = z + 1.0 + 0.5 * (1.0 + q);
        zb = z + 2.0 + q;
    }
    return q;
}

// The cubic from its control slices B0, q_a, q_b, B3 (texture.rs, curve_position_cubic):
// B1 = B0 + 4/3 (q_a - B0), B2 = B3 + 4/3 (q_b - B3).
vec3 cubic_point(vec3 b0, vec3 q_a, vec3 q_b, vec3 b3, float local) {
    vec3 b1 = b0 + (q_a - b0) * (4.0 / 3.0);
    vec3 b2 = b3 + (q_b - b3) * (4.0 / 3.0);
    float s = 1.0 - local;
    return b0 * (s * s * s) + b1 * (3.0 * s * s * local) + b2 * (3.0 * s * local * local) + b3 * (local * local * local);
}

// Object-space point of the curve surface: two trilinear fetches and a lerp per quadratic.
vec3 curve_position(uint bundle, vec2 st, float tau) {
    vec2 xy = block_coord(bundle, st);
    if (EXACT_CUBIC == 1u) {
        float local;
        float z = 3.0 * curve_segment(tau, local) + 0.5;
        vec3 p = cubic_point(fetch(hair_mesh_tex, vec3(xy, z)).xyz, fetch(hair_mesh_tex, vec3(xy, z + 1.0)).xyz,
                             fetch(hair_mesh_tex, vec3(xy, z + 2.0)).xyz, fetch(hair_mesh_tex, vec3(xy, z + 3.0)).xyz,
                             local);
        return params.normalization.xyz + p * params.normalization.w;
    }
    float za;
    float zb;
    float q = quadratic_slices(tau, za, zb);
    vec3 a = fetch(hair_mesh_tex, vec3(xy, za)).xyz;
    vec3 b = fetch(hair_mesh_tex, vec3(xy, zb)).xyz;
    return params.normalization.xyz + mix(a, b, q) * params.normalization.w;
}

// ---------------------------------------------------------------- roots (asset.rs)

vec2 root_parameter(uint bundle, uint strand) {
    Bundle b = bundles[bundle];
    SampleSetInfo set = sample_sets[b.info.z];
    vec2 p = unpackUnorm2x16(samples[set.offset + strand % max(set.count, 1u)]);
    uint symmetry = (b.info.y >> 1u) & 7u;
    if ((b.info.y & 1u) == 0u) {
        return square_symmetry(symmetry, p);
    }
    // Triangle: permute the barycentrics (roots.rs, TRIANGLE_PERMUTATIONS), then map to the square.
    vec3 l = vec3(1.0 - p.x - p.y, p.x, p.y);
    const uvec2 PERMUTATIONS[6] = uvec2[6](uvec2(1, 2), uvec2(2, 1), uvec2(0, 2), uvec2(2, 0), uvec2(0, 1), uvec2(1, 0));
    uvec2 perm = PERMUTATIONS[symmetry % 6u];
    p = vec2(l[perm.x], l[perm.y]);
    float denom = 1.0 - p.y;
    p.x = denom > 1e-12 ? clamp(p.x / denom, 0.0, 1.0) : 0.0;
    return p;
}

vec2 centre_parameter(uint bundle) {
    return (bundles[bundle].info.y & 1u) == 1u ? vec2(0.5, 1.0 / 3.0) : vec2(0.5, 0.5);
}

// ---------------------------------------------------------------- head collision (head_field.rs)

// The head field's signed distance at p (x) and its gradient (yzw): trilinear interpolation of
// the grid and that interpolant's derivative (HeadField::sample); false outside the grid.
bool head_field_sample(vec3 p, out vec4 distance_gradient) {
    ivec3 size = textureSize(head_field_tex, 0);
    vec3 f = (p - params.head_field.xyz) / params.head_field.w;
    distance_gradient = vec4(0.0);
    if (any(lessThan(f, vec3(0.0))) || any(greaterThan(f, vec3(size - 1)))) {
        return false;
    }
    ivec3 i0 = min(floor_int3(f), size - 1);
    ivec3 i1 = min(i0 + 1, size - 1);
    vec3 w = f - vec3(i0);
    float c000 = texelFetch(head_field_tex, ivec3(i0.x, i0.y, i0.z), 0).r;
    float c100 = texelFetch(head_field_tex, ivec3(i1.x, i0.y, i0.z), 0).r;
    float c010 = texelFetch(head_field_tex, ivec3(i0.x, i1.y, i0.z), 0).r;
    float c110 = texelFetch(head_field_tex, ivec3(i1.x, i1.y, i0.z), 0).r;
    float c001 = texelFetch(head_field_tex, ivec3(i0.x, i0.y, i1.z), 0).r;
    float c101 = texelFetch(head_field_tex, ivec3(i1.x, i0.y, i1.z), 0).r;
    float c011 = texelFetch(head_field_tex, ivec3(i0.x, i1.y, i1.z), 0).r;
    float c111 = texelFetch(head_field_tex, ivec3(i1.x, i1.y, i1.z), 0).r;
    float c00 = mix(c000, c100, w.x);
    float c10 = mix(c010, c110, w.x);
    float c01 = mix(c001, c101, w.x);
    float c11 = mix(c011, c111, w.x);
    float dx = mix(mix(c100 - c000, c110 - c010, w.y), mix(c101 - c001, c111 - c011, w.y), w.z);
    float dy = mix(c10 - c00, c11 - c01, w.z);
    float dz = mix(c01, c11, w.y) - mix(c00, c10, w.y);
    distance_gradient = vec4(mix(mix(c00, c10, w.y), mix(c01, c11, w.y), w.z), vec3(dx, dy, dz) / params.head_field.w);
    return true;
}

// Strand-level collision (HeadField::push_out): a styled vertex inside the head, or closer than
// the margin (grown by (1 - slope) cells where the grid blurs a thin part such as an ear), moves
// out along the field's gradient, step by step, each step halved until the field puts the
// vertex further out.
vec3 keep_out_of_head(vec3 p) {
    vec4 here;
    if (params.head_field.w <= 0.0 || !head_field_sample(p, here)) {
        return p;
    }
    vec3 q = p;
    for (uint i = 0u; i < HK_HEAD_PUSH_STEPS; ++i) {
        float slope = length(here.yzw);
        float goal = params.head_margin.x + (1.0 - min(slope, 1.0)) * params.head_field.w;
        if (here.x >= goal || !(slope > 1e-9)) {
            break;
        }
        vec3 step = here.yzw / slope * (goal - here.x);
        bool moved = false;
        for (uint h = 0u; h <= HK_HEAD_PUSH_HALVINGS; ++h) {
            vec4 next;
            if (head_field_sample(q + step, next) && next.x > here.x) {
                q += step;
                here = next;
                moved = true;
                break;
            }
            step *= 0.5;
        }
        if (!moved) {
            break;
        }
    }
    return q;
}

// ---------------------------------------------------------------- styling (style.rs)

float smoothstep_safe(float edge0, float edge1, float x) {
    if (edge1 <= edge0) {
        return x >= edge1 ? 1.0 : 0.0;
    }
    float t = clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// The fraction of the hair-mesh curve a strand covers (HairAsset::strand_point): its bundle's
// reach (tip layer / L: bundles of different lengths) times the style's length variation.
float length_scale(uint bundle, uint seed) {
    float tip = float((bundles[bundle].info.y >> 4u) & 0x7fu);
    float reach = tip / float(max(params.layout_info.w, 1u));
    return (1.0 - clamp(params.style0.w, 0.0, 1.0) * seeded_random(seed, 0u)) * reach;
}

vec3 frizz_noise(uint seed, float x) {
    float i = floor(x);
    float f = x - i;
    float blend = f * f * (3.0 - 2.0 * f);
    uint cell = uint(floor_int(i - 1048576.0 * floor(i / 1048576.0)));
    uint next = (cell + 1u) % 1048576u;
    vec3 a = vec3(seeded_random(seed, 16u + 3u * cell), seeded_random(seed, 17u + 3u * cell),
                  seeded_random(seed, 18u + 3u * cell)) * 2.0 - 1.0;
    vec3 b = vec3(seeded_random(seed, 16u + 3u * next), seeded_random(seed, 17u + 3u * next),
                  seeded_random(seed, 18u + 3u * next)) * 2.0 - 1.0;
    return mix(a, b, blend);
}

vec3 rotate_about(vec3 v, vec3 axis, float angle) {
    float s = sin(angle);
    float c = cos(angle);
    return v * c + cross(axis, v) * s + axis * dot(axis, v) * (1.0 - c);
}

// v / |v|, or `fallback` where that is not finite. One reciprocal and three products rather
// than four divisions: a division is the dearest arithmetic of a vertex on CPU devices, and
// the two differ by at most an ulp (the CPU ports do the same).
vec3 try_normalize(vec3 v, vec3 fallback) {
    float l = length(v);
    float inv = 1.0 / l;
    return (l > 0.0 && !isinf(inv)) ? v * inv : fallback;
}

// 1 / x for x a power of two, exactly and without a division (its exponent negated): a
// vertex's tau is k / 2^level, and a division per vertex is dear on CPU devices.
float power_of_two_reciprocal(float x) {
    return uintBitsToFloat(0x7f000000u - floatBitsToUint(x));
}

vec3 any_orthonormal(vec3 v) {
    // glam's any_orthonormal_vector (Frisvad / Duff et al.).
    float s = v.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + v.z);
    float b = v.x * v.y * a;
    return vec3(b, s + v.y * v.y * a, -v.y);
}

// try_normalize(v, any_orthonormal(axis)), the fallback made only where it is taken: as an
// argument it would cost every vertex a division (on CPU devices a branch that no SIMD lane
// takes is skipped).
vec3 normalize_or_orthonormal(vec3 v, vec3 axis) {
    float l = length(v);
    float inv = 1.0 / l;
    vec3 r = v * inv;
    if (!(l > 0.0 && !isinf(inv))) {
        r = any_orthonormal(axis);
    }
    return r;
}

// The strand index whose random numbers are a bundle's own (style.rs BUNDLE_RANDOM).
const uint BUNDLE_RANDOM = 0xffffffffu;

// style.rs Style::wave_random.
float wave_random(uint bundle, uint seed) {
    float own = seeded_random(seed, 2u);
    float c = params.stray.z;
    if (!(c > 0.0)) {
        return own;
    }
    c = min(c, 1.0);
    return own * (1.0 - c) + seeded_random(strand_seed(bundle, BUNDLE_RANDOM), 2u) * c;
}

// Whether style_apply reads the bundle centre's curve point: only twist and clumping do, so
// without them the centre is not evaluated (a third of a vertex's curve fetches and lerps).
bool style_uses_centre() {
    return params.frizz_clump.w != 0.0 || params.frizz_clump.y != 0.0;
}

// Whether style_apply reads the styling frame's fv and fw (and so v): curl (fv), frizz and
// the strays' frizz (fv, fw) and twist (fw). Wave alone moves a point along fu: without the
// others the frame is fu alone, and fv, fw are zero (what they would add is exactly zero).
bool style_uses_full_frame() {
    return params.curl.x != 0.0 || params.wave_frizz.z != 0.0 || params.stray.y != 0.0 || params.frizz_clump.w != 0.0;
}

// A strand's own random style values (style.rs): what style_apply needs of the strand rather
// than of the vertex, so a strand walked vertex by vertex (StrandStream) hashes them once.
struct StrandStyle {
    uint seed;           // strand_seed(bundle, strand): the frizz noise's
    bool stray;
    float curl_random;
    float wave_random;
};

StrandStyle strand_style(uint bundle, uint seed) {
    StrandStyle st;
    st.seed = seed;
    st.stray = seeded_random(seed, 3u) < params.stray.x;
    st.curl_random = seeded_random(seed, 1u);
    st.wave_random = wave_random(bundle, seed);
    return st;
}

// x^e, exactly x for the common e = 1 (pow is exp2(e log2 x): dear on CPU devices, and not
// exact).
float pow_exponent(float x, float e) {
    return e == 1.0 ? x : pow(x, e);
}

// p pulled toward its bundle's centre curve, by the clump strength times `shape` (tau^exponent)
// at the root fade (style.rs).
vec3 clump_point(vec3 p, vec3 centre, float shape, float fade) {
    return mix(p, centre, clamp(params.frizz_clump.y * shape * fade, 0.0, 1.0));
}

vec3 style_apply(StrandStyle st, float tau, vec3 position, vec3 centre, vec3 fu, vec3 fv, vec3 fw, float w) {
    float fade = smoothstep_safe(0.0, params.style0.z, tau);
    if (fade == 0.0) {
        return position;
    }
    bool stray = st.stray;
    const float TURN = 6.28318530717958647692;
    // Terms whose amplitude is zero add exactly nothing (the noise and the trigonometry are
    // finite), so they are skipped: transcendentals and hashes dominate generation on a
    // software rasterizer.
    vec3 d = vec3(0.0);
    if (params.curl.x != 0.0) {
        float curl_phase = TURN * (params.curl.y * w + params.curl.z + st.curl_random);
        d.xy = params.curl.x * vec2(cos(curl_phase), sin(curl_phase));
    }
    if (params.wave_frizz.x != 0.0) {
        float wave_phase = TURN * (params.wave_frizz.y * w + st.wave_random);
        d.x += params.wave_frizz.x * sin(wave_phase);
    }
    float frizz_amplitude = params.wave_frizz.z + (stray ? params.stray.y : 0.0);
    if (frizz_amplitude != 0.0) {
        d += frizz_noise(st.seed, w * params.wave_frizz.w) *
             (frizz_amplitude * pow_exponent(tau, max(params.frizz_clump.x, 0.0)));
    }
    vec3 p = position + (fu * d.x + fv * d.y + fw * d.z) * fade;
    if (params.frizz_clump.w != 0.0) {
        p = centre + rotate_about(p - centre, fw, TURN * params.frizz_clump.w * tau * fade);
    }
    if (params.frizz_clump.y != 0.0) {
        // The common exponent 1 takes a branch of its own, not pow_exponent's select: the
        // compiler flattens a conditional that small into a select, and llvmpipe then
        // evaluates pow (a log2 and an exp2) at every vertex, a twentieth of the generate pass
        // (measured). The stray test inside each side keeps both sides branches.
        if (params.frizz_clump.z == 1.0) {
            if (!stray) {
                p = clump_point(p, centre, tau, fade);
            }
        } else if (!stray) {
            p = clump_point(p, centre, pow(tau, max(params.frizz_clump.z, 0.0)), fade);
        }
    }
    return p;
}

// The styling frame from the interpolated u, v: fu = normalize(u), fw = normalize(u x v),
// fv = fw x fu (style.rs).
void styling_frame(vec3 u, vec3 v, out vec3 fu, out vec3 fv, out vec3 fw) {
    fu = try_normalize(u, vec3(1.0, 0.0, 0.0));
    fv = vec3(0.0);
    fw = vec3(0.0);
    if (style_uses_full_frame()) {
        fw = normalize_or_orthonormal(cross(fu, v), fu);
        fv = cross(fw, fu);
    }
}

// One styled strand point (HairAsset::strand_point), every value sampled from the textures.
vec3 strand_point(uint bundle, uint strand, vec2 root, float tau) {
    uint seed = strand_seed(bundle, strand);
    float t_curve = tau * length_scale(bundle, seed);
    vec3 position = curve_position(bundle, root, t_curve);
    if (tau <= 0.0) {
        return position;
    }
    vec3 centre = vec3(0.0);
    if (style_uses_centre()) {
        centre = curve_position(bundle, centre_parameter(bundle), t_curve);
    }
    vec2 xy = block_coord(bundle, root);
    vec3 z = vec3(xy, t_curve * float(params.layout_info.w) + 0.5);
    vec3 fu;
    vec3 fv;
    vec3 fw;
    vec4 u_w = fetch(u_tex, z);
    styling_frame(u_w.xyz, fetch(v_tex, z).xyz, fu, fv, fw);
    return keep_out_of_head(style_apply(strand_style(bundle, seed), tau, position, centre, fu, fv, fw, u_w.w));
}

float width_at(float tau) {
    return params.style0.x * (1.0 + (params.style0.y - 1.0) * clamp(tau, 0.0, 1.0));
}

// ---------------------------------------------------------------- LOD (reference.rs)

// Half the view's height in object units at distance d (reference.rs half_view).
float half_view(float d) {
    return params.projection.z > 0.5 ? params.projection.y : d * params.projection.x;
}

float detail_level(float h, float d, float alpha) {
    float half_height = half_view(d);
    if (!(half_height > 0.0) || !(alpha > 0.0)) {
        return 1.0;
    }
    float l = h * params.eye.w / (alpha * half_height);
    return isnan(l) ? 1.0 : clamp(l, 0.0, 1.0);
}

// Pixels per object unit at distance d (reference.rs pixels_per_unit); 0 when not measurable.
float pixels_per_unit(float d) {
    float p = params.eye.w / (2.0 * half_view(d));
    return (p > 0.0 && !isinf(p)) ? p : 0.0;
}

// The vertex-LOD x a periodic style term asks for (reference.rs style_term_level): amplitude
// and periods along the strand, at `pixels` per unit; NO_STYLE_LEVEL when nothing.
const float NO_STYLE_LEVEL = -1e30;
float style_term_level(float amplitude, float periods, float pixels, float error_pixels, float lambda) {
    float a = abs(amplitude) * pixels;
    float c = abs(periods);
    if (!(4.0 * a > error_pixels) || !(error_pixels > 0.0) || isinf(a) || isinf(c) || isnan(c)) {
        return NO_STYLE_LEVEL;
    }
    // Formula from a = eps/2 (n = c there), a ramp from 0 between eps/4 and eps/2.
    float x = 2.0 * a >= error_pixels ? log2(3.14159265358979 * c / acos(1.0 - error_pixels / a)) + lambda
                                      : (4.0 * a / error_pixels - 1.0) * (log2(c) + lambda);
    return (isnan(x) || isinf(x)) ? NO_STYLE_LEVEL : x;
}

// The vertex-LOD x the style asks for on a strand of length h at distance d (reference.rs
// style_level): curl, wave and frizz (with the strays' amplitude when there are strays).
float style_level(float h, float d, float lambda) {
    float error_pixels = params.lod_error.x;
    if (!(error_pixels > 0.0)) {
        return NO_STYLE_LEVEL;
    }
    float pixels = pixels_per_unit(d);
    float frizz = abs(params.wave_frizz.z) + (params.stray.x > 0.0 ? abs(params.stray.y) : 0.0);
    float x = style_term_level(params.curl.x, params.curl.y * h, pixels, error_pixels, lambda);
    x = max(x, style_term_level(params.wave_frizz.x, params.wave_frizz.y * h, pixels, error_pixels, lambda));
    return max(x, style_term_level(frizz, 0.5 * params.wave_frizz.w * h, pixels, error_pixels, lambda));
}

bool bundle_visible(uint bundle) {
    vec3 lo = bundles[bundle].bounds_min.xyz;
    vec3 hi = bundles[bundle].bounds_max.xyz;
    // Outside when all 8 corners are beyond one clip plane.
    mat4 m = params.view_proj;
    // Per plane: 1 while every corner so far is outside it.
    uvec4 out_xy = uvec4(1u);
    uvec2 out_z = uvec2(1u);
    for (uint c = 0u; c < 8u; ++c) {
        vec3 p = vec3((c & 1u) != 0u ? hi.x : lo.x, (c & 2u) != 0u ? hi.y : lo.y, (c & 4u) != 0u ? hi.z : lo.z);
        vec4 clip = m * vec4(p, 1.0);
        out_xy = min(out_xy, uvec4(bvec4(clip.x < -clip.w, clip.x > clip.w, clip.y < -clip.w, clip.y > clip.w)));
        out_z = min(out_z, uvec2(bvec2(clip.z < 0.0, clip.z > clip.w)));
    }
    return (out_xy.x | out_xy.y | out_xy.z | out_xy.w | out_z.x | out_z.y) == 0u;
}

BundleLod bundle_lod(uint bundle) {
    Bundle b = bundles[bundle];
    uint e_max = min(params.counts.y, MAX_SEGMENTS_LOG2);
    BundleLod l;
    if (params.projection.w > 0.5 && !bundle_visible(bundle)) {
        l.strands = 0u;
        l.level = 0u;
        l.gamma = 0.0;
        l.width_scale = 1.0;
        return l;
    }
    if (params.lod.x < 0.5) {
        l.strands = b.info.x;
        l.level = e_max;
        l.gamma = 0.0;
        l.width_scale = 1.0;
        return l;
    }
    float d = distance(params.eye.xyz, 0.5 * (b.bounds_min.xyz + b.bounds_max.xyz));
    float ls = detail_level(b.bounds_min.w, d, params.lod.y);
    float n = float(b.info.x);
    l.strands = uint(clamp(ceil(ls * n - bundle_delta(bundle)), 1.0, n));
    l.width_scale = ls > 0.0 ? min(1.0 / ls, n) : n;
    float lv = detail_level(b.bounds_max.w, d, params.lod.z);
    float x = log2(lv * float(1u << e_max));
    float lambda = max(params.lod.w, 1e-6);
    float styled = style_level(b.bounds_max.w, d, lambda);
    if (styled > x || isnan(x)) {
        x = styled;
    }
    uint level = isnan(x) ? 0u : uint(clamp(ceil(x), 0.0, float(e_max)));
    uint coarse = isnan(x - lambda) ? 0u : uint(clamp(ceil(x - lambda), 0.0, float(e_max)));
    l.level = level;
    l.gamma = level > coarse ? clamp(1.0 - (x - float(coarse)) / lambda, 0.0, 1.0) : 0.0;
    return l;
}

// ---------------------------------------------------------------- one strand per workgroup

struct StrandVertex {
    vec3 position;
    float width;
    vec3 tangent;
    float tau;
};

// Stages without workgroups (vertex pulling) define HAIR_GEN_NO_WORKGROUP and only use the
// strip expansion below.
#ifndef HAIR_GEN_NO_WORKGROUP
shared vec3 strand_positions[MAX_VERTICES];

// ---------------------------------------------------------------- strand-coherent evaluation
//
// A strand's root (s, t) is fixed, so every trilinear fetch it makes at (cell + st, z) is the
// bilinear blend of the same four texels of a slice, then a linear blend along z. The workgroup
// blends each slice once per strand (the strand's and its bundle centre's 1 + 3L curve slices,
// the L + 1 slices of u, v, w) into shared memory; every vertex is then arithmetic on those
// values. The blends are the manual filter's f32 lerps in the same order, so the strands match
// the per-vertex manual variant to f32 rounding (specialization constant 3 selects that
// variant, the reference).

const uint MAX_LAYERS = HK_MAX_LAYERS;
shared vec3 coherent_curve[2u * (1u + 3u * MAX_LAYERS)]; // strand slices, then centre slices
shared vec4 coherent_u_w[MAX_LAYERS + 1u];                 // xyz u, w w
shared vec3 coherent_v[MAX_LAYERS + 1u];

// The four texels at the corners of a cell (origin o) in slice z of `tex`.
struct CellCorners {
    vec4 t00;
    vec4 t10;
    vec4 t01;
    vec4 t11;
};

CellCorners cell_corners(sampler3D tex, ivec2 o, int z) {
    CellCorners k;
    k.t00 = texelFetch(tex, ivec3(o, z), 0);
    k.t10 = texelFetch(tex, ivec3(o.x + 1, o.y, z), 0);
    k.t01 = texelFetch(tex, ivec3(o.x, o.y + 1, z), 0);
    k.t11 = texelFetch(tex, ivec3(o + 1, z), 0);
    return k;
}

// The corners blended at cell weights w (the xy step of fetch(), its lerps in its order).
vec4 blend_corners(CellCorners k, vec2 w) {
    return mix(mix(k.t00, k.t10, w.x), mix(k.t01, k.t11, w.x), w.y);
}

// Where a strand's control data comes from: its bundle's cell and the blend weights of its
// root and of the bundle centre in that cell. Per strand, so the bundle table is read once.
struct StrandCell {
    uint key;      // the cell word's origin bits: equal keys, equal texels
    ivec2 origin;
    vec2 root;     // square_symmetry(orientation, root parameter)
    vec2 centre;   // square_symmetry(orientation, centre_parameter)
    // The subgroup fetches its cells' texels together (StrandStream): invocations 0-3 the
    // corners of one cell, 4-7 those of another (`fetch_origin` is the cell this invocation
    // fetches for, `second` whether its own cell is the other one).
    bool together;
    bool second;
    ivec2 fetch_origin;
};

StrandCell strand_cell(uint bundle, vec2 root) {
    uint cell = bundles[bundle].info.w;
    StrandCell c;
    c.key = cell & 0x0fffffffu;
    c.origin = cell_origin(cell);
    c.root = square_symmetry(cell >> 28u, root);
    c.centre = square_symmetry(cell >> 28u, centre_parameter(bundle));
    c.together = false;
    c.second = false;
    c.fetch_origin = c.origin;
    return c;
}

// Slice z of `tex` blended over bundle's cell at block parameter st (the xy step of fetch()).
vec4 cell_blend(sampler3D tex, uint bundle, vec2 st, int z) {
    StrandCell c = strand_cell(bundle, st);
    return blend_corners(cell_corners(tex, c.origin, z), c.root);
}

uint coherent_layers() {
    return min(max(params.layout_info.w, 1u), MAX_LAYERS);
}

// Every thread of the workgroup calls this for its strand, then barrier().
void strand_load_control(uint bundle, vec2 root, uint thread) {
    uint curve = 1u + 3u * coherent_layers();
    uint layer_slices = coherent_layers() + 1u;
    vec2 centre = centre_parameter(bundle);
    for (uint i = thread; i < 2u * curve + layer_slices; i += STRAND_THREADS) {
        if (i < 2u * curve) {
            vec2 st = i < curve ? root : centre;
            coherent_curve[i] = cell_blend(hair_mesh_tex, bundle, st, int(i % curve)).xyz;
        } else {
            int z = int(i - 2u * curve);
            coherent_u_w[z] = cell_blend(u_tex, bundle, root, z);
            coherent_v[z] = cell_blend(v_tex, bundle, root, z).xyz;
        }
    }
}

// One segment's control data: its four curve slices for the strand and the bundle centre and
// its two u, v, w layer slices, blended at the strand's root. Both coherent variants evaluate
// vertices from it; they differ in where it comes from (the workgroup's tables, or blends made
// by the invocation when tau enters the segment).
struct SegmentControl {
    int segment; // -1 before the first
    vec3 strand[4];
    vec3 centre[4];
    vec4 u_w[2];
    vec3 v[2];
};

// The segment's control data from the workgroup's tables (strand_load_control).
SegmentControl shared_segment(int segment) {
    SegmentControl c;
    c.segment = segment;
    int centre = int(1u + 3u * coherent_layers());
    for (int i = 0; i < 4; ++i) {
        c.strand[i] = coherent_curve[3 * segment + i];
        c.centre[i] = coherent_curve[centre + 3 * segment + i];
    }
    for (int i = 0; i < 2; ++i) {
        c.u_w[i] = coherent_u_w[segment + i];
        c.v[i] = coherent_v[segment + i];
    }
    return c;
}

// curve_position() on a segment's four slices.
vec3 window_curve_position(vec3 w[4], float t_curve) {
    vec3 p;
    float local;
    curve_segment(t_curve, local);
    if (EXACT_CUBIC == 1u) {
        p = cubic_point(w[0], w[1], w[2], w[3], local);
    } else {
        // The segment's two quadratics B0, q_a, m and m, q_b, B3 (m = (q_a + q_b) / 2), by de
        // Casteljau: what quadratic_slices' two filtered fetches give. Emulating those fetches
        // on the four slices (a floor, a clamp and two slice picks each) was about a tenth of
        // generation on lavapipe; here one select per control point picks the half.
        bool second = local >= 0.5;
        float q = second ? 2.0 * local - 1.0 : 2.0 * local;
        vec3 m = 0.5 * (w[1] + w[2]);
        vec3 p0 = second ? m : w[0];
        vec3 p1 = second ? w[2] : w[1];
        vec3 p2 = second ? w[3] : m;
        p = mix(mix(p0, p1, q), mix(p1, p2, q), q);
    }
    return params.normalization.xyz + p * params.normalization.w;
}

// strand_point() from the control data of the segment t_curve = tau * length_scale lies in.
vec3 control_strand_point(StrandStyle st, float tau, float t_curve, SegmentControl c) {
    vec3 position = window_curve_position(c.strand, t_curve);
    if (tau <= 0.0) {
        return position;
    }
    vec3 centre = vec3(0.0);
    if (style_uses_centre()) {
        centre = window_curve_position(c.centre, t_curve);
    }
    // The layer slices' linear filter between the segment's two (at the last layer f reaches
    // segment + 1: the second).
    float f = clamp(t_curve * float(params.layout_info.w), 0.0, float(coherent_layers())) - float(c.segment);
    vec4 u_w = mix(c.u_w[0], c.u_w[1], f);
    vec3 fu;
    vec3 fv;
    vec3 fw;
    styling_frame(u_w.xyz, mix(c.v[0], c.v[1], f), fu, fv, fw);
    return keep_out_of_head(style_apply(st, tau, position, centre, fu, fv, fw, u_w.w));
}

// strand_point() from the workgroup's control data (strand_load_control).
vec3 coherent_strand_point(uint bundle, uint strand, float tau) {
    uint seed = strand_seed(bundle, strand);
    float t_curve = tau * length_scale(bundle, seed);
    float local;
    return control_strand_point(strand_style(bundle, seed), tau, t_curve,
                                shared_segment(floor_int(curve_segment(t_curve, local))));
}

// Whether a workgroup evaluates its strand from control data: when a strand has a mesh
// workgroup of its own (vertex level >= 4, 17 vertices or more). Shorter strands have few
// vertices to share the control data's cost (and a mesh workgroup holds several of them), so
// they sample per vertex, filtering manually; both paths follow this rule.
bool strand_coherent(uint strands_in_group) {
    return PER_VERTEX_FETCH == 0u && strands_in_group == 1u;
}

vec3 seg_dir(vec3 a, vec3 b, vec3 fallback) {
    return try_normalize(b - a, fallback);
}

// The tangent (Eq. 6) at an end of a polyline from its end segment's direction and the
// direction across the end's two neighbours: the end segment mirrors t.
vec3 end_tangent(vec3 end_seg, vec3 t) {
    return try_normalize(2.0 * end_seg * dot(t, end_seg) - t, end_seg);
}

// The strand vertex k of 2^e segments from its full-detail position and tangent: morphing
// (Eq. 9-12) moves an odd vertex toward its neighbours' midpoint (prev, next) and blends every
// tangent toward the coarse polyline's (for an odd vertex the direction prev -> next, for an
// even one `coarse_even`); then tau and the width.
StrandVertex assemble_vertex(BundleLod l, uint k, uint segments, vec3 here, vec3 prev, vec3 next, vec3 full_tangent,
                             vec3 coarse_even) {
    StrandVertex v;
    v.position = here;
    v.tangent = full_tangent;
    if (l.gamma > 0.0 && segments >= 2u) {
        float g = l.gamma;
        vec3 coarse = coarse_even;
        if ((k & 1u) == 1u) {
            v.position = (1.0 - g) * here + g * 0.5 * (prev + next);
            coarse = try_normalize(next - prev, full_tangent);
        }
        v.tangent = try_normalize((1.0 - g) * full_tangent + g * coarse, full_tangent);
    }
    v.tau = float(k) * power_of_two_reciprocal(float(segments)); // k / segments, exactly
    v.width = width_at(v.tau) * l.width_scale;
    return v;
}

// Whether vertex k needs the coarse polyline's tangent (an even vertex while morphing).
bool needs_coarse_tangent(BundleLod l, uint k, uint segments) {
    return l.gamma > 0.0 && segments >= 2u && (k & 1u) == 0u;
}

// Phase 1: full-detail vertex k of a strand into shared memory at base + k, sampled from the
// textures, or (coherent) from the control data strand_load_control put in shared memory.
void strand_compute_vertex(uint bundle, uint strand, BundleLod l, uint base, uint k, bool from_control) {
    float tau = float(k) / float(1u << l.level);
    strand_positions[base + k] = from_control ? coherent_strand_point(bundle, strand, tau)
                                          : strand_point(bundle, strand, root_parameter(bundle, strand), tau);
}

// Tangent (Eq. 5-6) of vertex k of the polyline strand_positions[base + 0, base + stride, ...]
// with n points (k indexes that polyline).
vec3 polyline_tangent_of_group(uint base, uint k, uint n, uint stride) {
    vec3 first_seg = seg_dir(strand_positions[base], strand_positions[base + stride], vec3(0.0, 1.0, 0.0));
    if (n == 2u) {
        return first_seg;
    }
    if (k > 0u && k < n - 1u) {
        return seg_dir(strand_positions[base + (k - 1u) * stride], strand_positions[base + (k + 1u) * stride],
                       first_seg);
    }
    if (k == 0u) {
        return end_tangent(first_seg, seg_dir(strand_positions[base], strand_positions[base + 2u * stride], first_seg));
    }
    vec3 last = strand_positions[base + (n - 1u) * stride];
    vec3 last_seg = seg_dir(strand_positions[base + (n - 2u) * stride], last, first_seg);
    return end_tangent(last_seg, seg_dir(strand_positions[base + (n - 3u) * stride], last, first_seg));
}

// The morphed vertex k of the strand at strand_positions[base ...] with its tangent and width
// (after phase 1 wrote all its positions).
StrandVertex strand_vertex_of_group(uint bundle, uint strand, BundleLod l, uint base, uint k) {
    uint segments = 1u << l.level;
    vec3 full_tangent = polyline_tangent_of_group(base, k, segments + 1u, 1u);
    vec3 prev = vec3(0.0);
    vec3 next = vec3(0.0);
    vec3 coarse = vec3(0.0);
    if (l.gamma > 0.0 && segments >= 2u) {
        if ((k & 1u) == 1u) {
            prev = strand_positions[base + k - 1u];
            next = strand_positions[base + k + 1u];
        } else {
            coarse = polyline_tangent_of_group(base, k / 2u, segments / 2u + 1u, 2u);
        }
    }
    return assemble_vertex(l, k, segments, strand_positions[base + k], prev, next, full_tangent, coarse);
}

// ---------------------------------------------------------------- one strand per invocation
//
// The compute path's strand-coherent variant: one invocation generates a whole strand (no
// workgroup barrier, no shared memory; a software rasterizer's SIMD lanes run 8 strands side
// by side). Walking tau upward it blends, for each segment it enters, the four texels of the
// segment's four curve slices (strand and bundle centre) and of its two u, v, w layer slices:
// the blends strand_load_control makes, only where they are needed, so the strands are the
// workgroup variant's bit for bit.

// The corners of the strand's cell in slice z of `tex`. With cell.together (uniform) invocation
// i fetches corner i mod 4 of its fetch_origin and every invocation takes the four of its own
// cell from invocations 0-3 or 4-7: one texelFetch per subgroup where each invocation would
// make four (on a CPU device each texelFetch is a gather across the SIMD lanes).
CellCorners fetch_corners(sampler3D tex, StrandCell cell, int z) {
    if (!cell.together) {
        return cell_corners(tex, cell.origin, z);
    }
    uint corner = gl_SubgroupInvocationID & 3u;
    vec4 t = texelFetch(tex, ivec3(cell.fetch_origin + ivec2(int(corner & 1u), int(corner >> 1u)), z), 0);
    CellCorners first;
    first.t00 = subgroupBroadcast(t, 0u);
    first.t10 = subgroupBroadcast(t, 1u);
    first.t01 = subgroupBroadcast(t, 2u);
    first.t11 = subgroupBroadcast(t, 3u);
    CellCorners second;
    second.t00 = subgroupBroadcast(t, 4u);
    second.t10 = subgroupBroadcast(t, 5u);
    second.t01 = subgroupBroadcast(t, 6u);
    second.t11 = subgroupBroadcast(t, 7u);
    return cell.second ? second : first;
}

// Curve slice z blended at the strand's root and at its bundle centre: one set of corner
// texels for both.
void load_curve_slice(StrandCell cell, int z, out vec3 strand, out vec3 centre) {
    CellCorners k = fetch_corners(hair_mesh_tex, cell, z);
    strand = blend_corners(k, cell.root).xyz;
    centre = blend_corners(k, cell.centre).xyz;
}

// Layer slice z of u (xyz) with w (in u_w.w: one texture) and of v, blended at the strand's root.
void load_layer_slice(StrandCell cell, int z, out vec4 u_w, out vec3 v) {
    u_w = blend_corners(fetch_corners(u_tex, cell, z), cell.root);
    v = blend_corners(fetch_corners(v_tex, cell, z), cell.root).xyz;
}

void load_segment(StrandCell cell, int segment, inout SegmentControl c) {
    // Walking upward, a segment's first curve slice is the previous one's last and its first
    // layer slice the previous one's second: keep them. Constant indices only: a per-invocation
    // index into these arrays is lane-by-lane work on CPU devices.
    if (c.segment >= 0 && segment == c.segment + 1) {
        c.strand[0] = c.strand[3];
        c.centre[0] = c.centre[3];
        c.u_w[0] = c.u_w[1];
        c.v[0] = c.v[1];
    } else {
        load_curve_slice(cell, 3 * segment, c.strand[0], c.centre[0]);
        load_layer_slice(cell, segment, c.u_w[0], c.v[0]);
    }
    c.segment = segment;
    [[unroll]] for (int i = 1; i < 4; ++i) {
        load_curve_slice(cell, 3 * segment + i, c.strand[i], c.centre[i]);
    }
    load_layer_slice(cell, segment + 1, c.u_w[1], c.v[1]);
}

// A strand generated vertex by vertex in one invocation (StrandStream, strand_stream_step):
// the positions a vertex's tangent and morphing read (its neighbours two apart on either side,
// four at the ends) stay in a window of nine that shifts by one per vertex. Every index into it
// is a constant: CPU devices (llvmpipe) index a private array with a per-invocation index lane
// by lane, so a whole strand's positions in an array cost more than evaluating them.
// Invocations of a subgroup whose strands have the same vertex count call strand_stream_step
// (or strand_stream_point) together, with no break or return in between: their texel fetches
// may be the subgroup's together (StrandCell.together).
struct StrandStream {
    uint bundle;
    uint strand;
    uint seed;           // strand_seed(bundle, strand)
    float scale;         // length_scale(bundle, seed)
    StrandStyle style;   // strand_style(bundle, seed)
    vec2 root;           // root_parameter(bundle, strand)
    StrandCell cell;
    BundleLod lod;
    uint segments;       // 2^level
    bool from_control;   // strand-coherent (else sampled per vertex)
    SegmentControl control;
    vec3 window[9];      // window[8] is point pushed - 1, window[8 - i] point pushed - 1 - i
    uint pushed;         // points pushed (past the last one, pushes only shift)
    vec3 first_seg;      // direction of point 0 -> 1
    vec3 coarse_first_seg; // direction of point 0 -> 2
};

StrandStream strand_stream(uint bundle, uint strand, BundleLod l, bool from_control) {
    StrandStream s;
    s.bundle = bundle;
    s.strand = strand;
    s.seed = strand_seed(bundle, strand);
    s.scale = length_scale(bundle, s.seed);
    s.style = strand_style(bundle, s.seed);
    s.root = root_parameter(bundle, strand);
    s.cell = strand_cell(bundle, s.root);
    // When every invocation of the subgroup walks a strand of one of two cells with the same
    // vertex count and length scale, they enter the same segments at the same vertices, and the
    // subgroup fetches each segment's corner texels together (fetch_corners). Strands of a
    // bundle sit side by side in the slots, so a subgroup of 8 holds one or two bundles when
    // bundles have 8 strands or more (not with length variation, which parts the segments).
    // Invocations 0-7 fetch for the others, so every invocation must evaluate from control data
    // (subgroupAll: one sampling per vertex would never join the fetches).
    uint key = s.cell.key;
    uint first_key = subgroupBroadcast(key, 0u);
    uint second_key = subgroupBroadcast(key, 7u);
    s.cell.together = subgroupAll(from_control) && gl_SubgroupSize >= 8u && (subgroupBallot(true).x & 0xffu) == 0xffu &&
                      subgroupAll(key == first_key || key == second_key) && subgroupAllEqual(l.level) &&
                      subgroupAllEqual(s.scale);
    s.cell.second = key != first_key;
    uint fetch_key = gl_SubgroupInvocationID >= 4u && gl_SubgroupInvocationID < 8u ? second_key : first_key;
    s.cell.fetch_origin = cell_origin(fetch_key);
    s.lod = l;
    s.segments = 1u << l.level;
    s.from_control = from_control;
    s.control.segment = -1;
    [[unroll]] for (int i = 0; i < 9; ++i) {
        s.window[i] = vec3(0.0);
    }
    s.pushed = 0u;
    s.first_seg = vec3(0.0, 1.0, 0.0);
    s.coarse_first_seg = vec3(0.0, 1.0, 0.0);
    return s;
}

// Steps of a strand walk (strand_stream_step): one per point pushed, the last four only
// shifting the window.
uint strand_stream_steps(StrandStream s) {
    return s.segments + 5u;
}

// The curve segment full-detail point j lies in, or -1 past the strand's last point (the
// walk's last steps only shift the window).
int strand_stream_point_segment(StrandStream s, uint j) {
    if (j > s.segments) {
        return -1;
    }
    float tau = float(j) * power_of_two_reciprocal(float(s.segments));
    float local;
    return floor_int(curve_segment(tau * s.scale, local));
}

// Loads the control data of the curve segment point j lies in, unless the stream holds it
// already (strand-coherent streams only); returns the segment (strand_stream_point_segment).
int strand_stream_load_segment_of(inout StrandStream s, uint j) {
    int segment = strand_stream_point_segment(s, j);
    if (s.from_control && segment >= 0 && segment != s.control.segment) {
        load_segment(s.cell, segment, s.control);
    }
    return segment;
}

// Whether the walk has steps left (strand_stream_step).
bool strand_stream_walking(StrandStream s) {
    return s.pushed < strand_stream_steps(s);
}

// A walk goes segment by segment: an outer loop enters the curve segment of the next point
// (loading its control data: strand-coherent walks only) and an inner loop takes the steps
// whose points lie in it (strand_stream_within), reading the control data without writing it.
// On CPU devices (llvmpipe) every value a loop carries is written back under the SIMD lanes'
// mask at each turn: carried by the one loop over all steps, the segment's 38 control values
// were written back at every vertex; carried by the outer loop, once per segment (render's
// fused raster kernel
// walks its strands of 16 segments or more this way too, and enters segments step by step
// inside one loop where strands are short or walked in part: hair_raster.comp). Returns the
// segment entered (-1: the steps past the last point).
//
//     while (strand_stream_walking(s)) {
//         int segment = strand_stream_enter(s);
//         do {
//             if (strand_stream_step(s, v, k)) { ... vertex k ... }
//         } while (strand_stream_within(s, segment));
//     }
int strand_stream_enter(inout StrandStream s) {
    return strand_stream_load_segment_of(s, s.pushed);
}

// Whether the walk's next step still lies in `segment` (strand_stream_enter).
bool strand_stream_within(StrandStream s, int segment) {
    return strand_stream_walking(s) && strand_stream_point_segment(s, s.pushed) == segment;
}

// Full-detail point j of a walk entered at j's segment (strand_stream_enter): the control
// data only read.
vec3 strand_stream_walk_point(StrandStream s, uint j) {
    float tau = float(j) * power_of_two_reciprocal(float(s.segments)); // j / segments, exactly
    return s.from_control ? control_strand_point(s.style, tau, tau * s.scale, s.control)
                          : strand_point(s.bundle, s.strand, s.root, tau);
}

// Full-detail point j of the strand (unmorphed), outside a walk: loads its segment's control
// data where needed. j must not decrease from call to call.
vec3 strand_stream_point(inout StrandStream s, uint j) {
    strand_stream_load_segment_of(s, j);
    return strand_stream_walk_point(s, j);
}

// Pushes the walk's next point; with `evaluate` false a stand-in (zero) instead, for a
// consumer that needs no vertex within two points of it (strand_stream_step_needed).
void strand_stream_push_needed(inout StrandStream s, bool evaluate) {
    [[unroll]] for (int i = 0; i < 8; ++i) {
        s.window[i] = s.window[i + 1];
    }
    if (s.pushed <= s.segments) {
        s.window[8] = evaluate ? strand_stream_walk_point(s, s.pushed) : vec3(0.0);
    }
    s.pushed += 1u;
    if (s.pushed == 2u) {
        s.first_seg = seg_dir(s.window[7], s.window[8], vec3(0.0, 1.0, 0.0));
    } else if (s.pushed == 3u) {
        s.coarse_first_seg = seg_dir(s.window[6], s.window[8], vec3(0.0, 1.0, 0.0));
    }
}

// polyline_tangent_of_group's cases on a point and its neighbours (prev2 .. next2 are points
// k - 2 .. k + 2 of the polyline, where they exist).
vec3 window_tangent(uint k, uint n, vec3 first_seg, vec3 prev2, vec3 prev, vec3 here, vec3 next, vec3 next2) {
    if (n == 2u) {
        return first_seg;
    }
    if (k > 0u && k < n - 1u) {
        return seg_dir(prev, next, first_seg);
    }
    if (k == 0u) {
        return end_tangent(first_seg, seg_dir(here, next2, first_seg));
    }
    return end_tangent(seg_dir(prev, here, first_seg), seg_dir(prev2, here, first_seg));
}

// One step of the strand's walk: pushes its next point and, once the window holds vertex
// k = pushes - 5 amid its neighbours, returns true with that vertex (0, 1, ... 2^level, in
// order) and its index k, morphed, with tangent and width: what strand_vertex_of_group gives for
// the same strand.
// A walk's steps are one loop within each segment (strand_stream_enter): a loop per vertex with
// a loop of pushes inside it costs more on CPU devices, where every loop writes back the state
// it carries under the SIMD lanes' mask at each turn (docs/compute-raster-notes.md).
// The point it pushes is evaluated only if `evaluate` (else a stand-in:
// strand_stream_push_needed), for consumers that need only some of the vertices: a vertex's
// tangent and morphing read the points two on either side of it and the first three points
// (the end directions), so the vertices returned are exact wherever every point within two of
// them, and points 0-2, were evaluated (strand_stream_step evaluates all). The caller loads the
// control data of the points it evaluates (strand_stream_enter).
bool strand_stream_step_needed(inout StrandStream s, bool evaluate, out StrandVertex v, out uint k) {
    strand_stream_push_needed(s, evaluate);
    v.position = vec3(0.0);
    v.width = 0.0;
    v.tangent = vec3(0.0);
    v.tau = 0.0;
    k = 0u;
    if (s.pushed < 5u || s.pushed > s.segments + 5u) {
        return false;
    }
    // window[4 + d] is point k + d.
    k = s.pushed - 5u;
    vec3 full_tangent =
        window_tangent(k, s.segments + 1u, s.first_seg, s.window[2], s.window[3], s.window[4], s.window[5], s.window[6]);
    vec3 coarse = vec3(0.0);
    if (needs_coarse_tangent(s.lod, k, s.segments)) {
        // The coarse polyline is every other point: its neighbours are two apart.
        coarse = window_tangent(k / 2u, s.segments / 2u + 1u, s.coarse_first_seg, s.window[0], s.window[2], s.window[4],
                                s.window[6], s.window[8]);
    }
    v = assemble_vertex(s.lod, k, s.segments, s.window[4], s.window[3], s.window[5], full_tangent, coarse);
    return true;
}

// strand_stream_step_needed with every point evaluated.
bool strand_stream_step(inout StrandStream s, out StrandVertex v, out uint k) {
    return strand_stream_step_needed(s, true, v, k);
}

// Strands per compute workgroup in the one-strand-per-invocation variant.
const uint STRANDS_PER_GROUP = 32u;

// Strands one mesh workgroup draws at vertex level e: as many as fit the workgroup's output
// (66 vertices, 64 triangles, 33 shared positions): 16 at e = 0 down to 1 at e >= 4.
uint strands_per_mesh_group(uint level) {
    uint segments = 1u << level;
    return max(1u, min(66u / (2u * (segments + 1u)), 64u / (2u * segments)));
}
#endif

// Camera-facing strip corners of a strand vertex, in clip space. Strips narrower than a pixel
// are widened to one pixel and report the fraction they really cover (coverage AA: the
// fragment stage scales alpha by it instead of drawing thinner-than-a-pixel geometry).
// `strand_coverage` is the coverage of one of the strands this one stands for under strand LOD
// (its width divided by the LOD width scale): opaque mode lets only strands whose real strands
// are solid write depth, so LOD does not turn sub-pixel hair into an occluding sheet.
void strip_corners(StrandVertex v, float width_scale, out vec4 left, out vec4 right, out float coverage,
                   out float strand_coverage) {
    vec3 to_eye = params.projection.z > 0.5 ? params.eye.xyz : params.eye.xyz - v.position;
    vec3 side = normalize_or_orthonormal(cross(v.tangent, to_eye), v.tangent) * (0.5 * v.width);
    vec4 centre = params.view_proj * vec4(v.position, 1.0);
    left = params.view_proj * vec4(v.position - side, 1.0);
    right = params.view_proj * vec4(v.position + side, 1.0);
    coverage = 1.0;
    strand_coverage = 1.0;
    if (left.w > 0.0 && right.w > 0.0) {
        vec2 pixels = (right.xy / right.w - left.xy / left.w) * 0.5 * params.viewport.xy;
        float width_px = length(pixels);
        strand_coverage = min(1.0, width_px / max(width_scale, 1.0));
        if (width_px < 1.0) {
            float grow = 1.0 / max(width_px, 1e-3);
            left = centre + (left - centre) * grow;
            right = centre + (right - centre) * grow;
            coverage = width_px;
        }
    }
}

// What the pre-raster stages hand the fragment stage (locations 0-2), in object space.
struct StrandVaryings {
    vec4 position_tau;    // xyz position, w strand parameter
    vec4 tangent_random;  // xyz unit tangent, w per-strand random in [0, 1)
    vec4 coverage_side;   // x coverage in [0, 1], y -1 on the left edge, +1 on the right,
                          // z coverage of one real strand (before strand LOD widening)
};

StrandVaryings strand_varyings(StrandVertex v, uint bundle, uint strand, float coverage, float strand_coverage,
                               float side) {
    StrandVaryings o;
    o.position_tau = vec4(v.position, v.tau);
    o.tangent_random = vec4(v.tangent, strand_random(bundle, strand, 7u));
    o.coverage_side = vec4(coverage, side, strand_coverage, 0.0);
    return o;
}
