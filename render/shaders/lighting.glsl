// The scene's lights and their shadow maps, shared by the hair and the occluder shading. All in
// world space. A shadow-casting light has a deep opacity map (Yuksel & Keyser 2008): the nearest
// hair depth per texel and the opacity accumulated up to the end of each of three layers behind
// it; and the nearest occluder depth per texel, which shadows whatever lies behind it.

#include "hk_render_contract.glsl"
#include "float_int.glsl"

struct SceneLight {
    vec4 vector;      // xyz: direction toward the light (w = 0) or its position (w = 1)
    vec4 color;       // rgb radiance
    mat4 view_proj;   // world -> light clip space (orthographic)
    vec4 layer_ends;  // xyz: ends of the 3 opacity layers behind the nearest hair (world units)
    vec4 map;         // x: map size (0 = casts no shadow), y: first texel of its maps, z: occluder bias (world units)
    vec4 depth;       // x near, y far, z 1 = perspective (point light), else orthographic
};

layout(std430, set = 0, binding = HK_BINDING_SHADOW_DEPTH) readonly buffer ShadowDepth { float shadow_depth[]; };
layout(std430, set = 0, binding = HK_BINDING_SHADOW_OPACITY) readonly buffer ShadowOpacity { vec4 shadow_opacity[]; };
layout(std430, set = 0, binding = HK_BINDING_LIGHTS) readonly buffer Lights { SceneLight lights[]; };
layout(std430, set = 0, binding = HK_BINDING_OCCLUDER_DEPTH) readonly buffer OccluderDepth { float occluder_depth[]; };

// The maps' loads: an includer may read through a faster path (raster_shade.comp: buffer
// references, which CPU devices gather with vector instructions).
#ifndef SHADOW_DEPTH_LOAD
#define SHADOW_DEPTH_LOAD(i) shadow_depth[i]
#define SHADOW_OPACITY_LOAD(i) shadow_opacity[i]
#define OCCLUDER_DEPTH_LOAD(i) occluder_depth[i]
#endif

// The scene's light count, a specialization constant of every pipeline that shades (render's
// contract SCENE_LIGHTS_CONSTANT_ID; unspecialized: every light a scene may have).
layout(constant_id = HK_SCENE_LIGHTS_CONSTANT_ID) const uint SCENE_LIGHTS = 8u;

// Loops over the scene's lights written out, one turn per light: FOR_EACH_SCENE_LIGHT(count,
// TURN) expands to TURN(0u) ... TURN(7u), each turn to run only where its index is below both
// SCENE_LIGHTS (so the turns past it are dead code, removed before the device compiles the
// shader) and
// `count` (the frame's). lavapipe unrolls no loop as large as a light's shading, even of a
// constant count, and with a loop counter for index CPU devices (llvmpipe) load each light
// lane by lane (a bounds check per lane and component; a shadow lookup reads most of a
// 144-byte SceneLight), where a constant index loads once for all SIMD lanes; a loop inside a
// shader's loop also carries its values under the lanes' mask through every turn. Eight turns:
// render::contract::MAX_LIGHTS (asserted there).
#define FOR_EACH_SCENE_LIGHT(count, TURN) \
    if (0u < SCENE_LIGHTS && 0u < (count)) TURN(0u) \
    if (1u < SCENE_LIGHTS && 1u < (count)) TURN(1u) \
    if (2u < SCENE_LIGHTS && 2u < (count)) TURN(2u) \
    if (3u < SCENE_LIGHTS && 3u < (count)) TURN(3u) \
    if (4u < SCENE_LIGHTS && 4u < (count)) TURN(4u) \
    if (5u < SCENE_LIGHTS && 5u < (count)) TURN(5u) \
    if (6u < SCENE_LIGHTS && 6u < (count)) TURN(6u) \
    if (7u < SCENE_LIGHTS && 7u < (count)) TURN(7u)

// Direction toward light `i` from the world point p.
vec3 light_direction(uint i, vec3 p) {
    vec4 lv = lights[i].vector;
    return lv.w > 0.5 ? normalize(lv.xyz - p) : normalize(lv.xyz);
}

// Whether the hair's own volume shadows it from light `i` (effects.volume_shadows and the
// light's cast_shadows; render/src/volume.rs) instead of the deep opacity map's hair layers.
bool light_volume_shadows(uint i) {
    return lights[i].depth.w > 0.5;
}

// What a lookup in one light's maps needs, read from its SceneLight once per lookup rather
// than once per texel (CPU devices load each field lane by lane).
struct MapLookup {
    vec4 depth;         // the light's depth parameters (map_linear_depth)
    float bias;         // occluder bias (world units)
    vec3 ends;          // ends of the opacity layers
    vec3 inv_widths;    // 1 / the layers' widths
};

// World distance from the light of a depth-buffer value of its maps.
float map_linear_depth(MapLookup m, float z) {
    vec4 d = m.depth;
    return d.z > 0.5 ? d.x * d.y / (d.y - z * (d.y - d.x)) : d.x + z * (d.y - d.x);
}

// Fraction of the light reaching a point at world distance `depth` from it past the occluders
// (x) and through the hair (y) in front of it, by texel `index` of its maps alone. The opacity
// at d behind the texel's nearest hair interpolates (0, 0), (ends.x, o.x), (ends.y, o.y),
// (ends.z, o.z) linearly and stays o.z beyond: a sum of clamped ramps, without branches.
vec2 texel_visibility(MapLookup m, uint index, float depth) {
    if (depth - map_linear_depth(m, OCCLUDER_DEPTH_LOAD(index)) > m.bias) {
        return vec2(0.0, 1.0);
    }
    float d = depth - map_linear_depth(m, SHADOW_DEPTH_LOAD(index));
    vec3 o = SHADOW_OPACITY_LOAD(index).xyz;
    vec3 ramps = clamp((vec3(d) - vec3(0.0, m.ends.xy)) * m.inv_widths, 0.0, 1.0);
    float opacity = dot(ramps, vec3(o.x, o.y - o.x, o.z - o.y));
    return vec2(1.0, exp(-1.5 * opacity));
}

// Fraction of light `i` reaching the world point p past the occluders (x) and through the hair
// (y) in front of it, from its maps (1 where it has none): each of the four texels around p
// answers for p's depth, and their answers are blended bilinearly (percentage-closer filtering;
// a single texel's answer shows the texels as stair steps along shadow edges).
vec2 light_visibility(uint i, vec3 p) {
    vec4 map = lights[i].map;
    float size = map.x;
    if (size < 0.5) {
        return vec2(1.0);
    }
    vec4 clip = lights[i].view_proj * vec4(p, 1.0);
    if (clip.w <= 0.0) {
        return vec2(1.0);
    }
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) {
        return vec2(1.0);
    }
    MapLookup m;
    m.depth = lights[i].depth;
    m.bias = map.z;
    m.ends = lights[i].layer_ends.xyz;
    // (The scene validates the ends as increasing; never a division by zero.)
    m.inv_widths = 1.0 / max(m.ends - vec3(0.0, m.ends.xy), vec3(1e-20));
    float depth = map_linear_depth(m, ndc.z);
    vec2 st = uv * size - 0.5;
    vec2 f = fract(st);
    ivec2 t0 = floor_int2(st);
    int last = floor_int(size) - 1;
    uint first = uint(map.y);
    vec2 v = vec2(0.0);
    for (int k = 0; k < 4; ++k) {
        ivec2 o = ivec2(k & 1, k >> 1);
        uvec2 texel = uvec2(clamp(t0 + o, ivec2(0), ivec2(last)));
        vec2 w = mix(1.0 - f, f, vec2(o));
        v += w.x * w.y * texel_visibility(m, first + texel.y * uint(size) + texel.x, depth);
    }
    return v;
}

// Fraction of light `i` reaching the world point p through the hair and occluders in front of it.
float light_transmittance(uint i, vec3 p) {
    vec2 v = light_visibility(i, p);
    return v.x * v.y;
}
