// Hair shading (Scheuermann 2004, after Kajiya-Kay 1989) as a function of explicit inputs, so
// fragment stages (hair.frag, hair_oit.frag) and compute passes (a software rasterizer's
// resolve, a volume raymarch) shade alike: a Kajiya-Kay diffuse term blended with a
// scaled-and-biased Lambert term, plus two shifted specular lobes: the primary (light colour)
// shifted toward the tip, the secondary (tinted by the hair colour, with sparkle from per-strand
// noise) shifted toward the root. The sample arrives in the character's object space and is
// shaded in world space. Needs lighting.glsl's buffers (the lights and their shadow maps).

#include "lighting.glsl"

// The light reaching a hair sample: the maps' (lighting.glsl), unless the includer defines
// HAIR_LIGHT_TRANSMITTANCE(i, p) (the compute rasterizer's shade pass adds volume shadows).
#ifndef HAIR_LIGHT_TRANSMITTANCE
#define HAIR_LIGHT_TRANSMITTANCE(i, p) light_transmittance(i, p)
#endif

// One point of a strand, in the character's object space.
struct HairSample {
    vec3 position;
    float tau;            // strand parameter: 0 at the root, 1 at the tip
    vec3 tangent;         // need not be normalized
    float strand_random;  // per-strand random in [0, 1)
    float coverage;       // the strand's pixel coverage (alpha before opacity)
    float occlusion;      // ambient occlusion: the light the hair around lets through (1 = none)
};

// How a character's hair is shaded (frame.rs `Shading`, minus the pre-raster bytes).
struct HairMaterial {
    mat4 model;              // object -> world
    vec3 eye;                // world-space eye
    uint light_count;
    vec4 hair_color;         // rgb base colour (linear); w: per-strand variation
    vec4 specular_shift;     // x primary shift, y secondary shift, z primary exponent, w secondary exponent
    vec4 specular_strength;  // x primary, y secondary, z ambient, w sparkle
    float opacity;           // of one strand (1 = opaque)
};

float hash(float x) {
    return fract(sin(x * 12.9898) * 43758.5453);
}

// sin(T, H)^exponent, the strand specular of Kajiya-Kay with a shifted tangent.
float strand_specular(vec3 tangent, vec3 h, float exponent) {
    float t_dot_h = dot(tangent, h);
    float sin_th = sqrt(max(0.0, 1.0 - t_dot_h * t_dot_h));
    float dir_atten = smoothstep(-1.0, 0.0, t_dot_h);
    return dir_atten * pow(sin_th, exponent);
}

// Light i's part of a hair sample's colour at world point p (tangent t, strip normal n, view
// direction v, shifted tangents t1, t2).
vec3 hair_light(uint i, vec3 p, vec3 t, vec3 n, vec3 v, vec3 t1, vec3 t2, vec3 base, float sparkle, HairMaterial m) {
    vec3 l = light_direction(i, p);
    vec3 h = normalize(l + v);
    float t_dot_l = dot(t, l);
    float kajiya = sqrt(max(0.0, 1.0 - t_dot_l * t_dot_l));
    float lambert = clamp(mix(0.25, 1.0, dot(n, l)), 0.0, 1.0);
    vec3 diffuse = base * mix(lambert, kajiya, 0.5);
    vec3 primary = vec3(m.specular_strength.x * strand_specular(t1, h, m.specular_shift.z));
    vec3 secondary = base * m.specular_strength.y * sparkle * strand_specular(t2, h, m.specular_shift.w);
    return lights[i].color.rgb * HAIR_LIGHT_TRANSMITTANCE(i, p) * (diffuse + primary + secondary);
}

// Premultiplied colour of one hair sample whose position and tangent are in world space (m's
// model matrix unused); alpha is its coverage times the strand opacity. The compute
// rasterizer's shade pass rebuilds world positions: an identity model matrix would still cost
// two matrix products per fragment there (a product by 0 or 1 is not folded away).
vec4 shade_hair_world(HairSample s, HairMaterial m) {
    vec3 p = s.position;
    vec3 t = normalize(s.tangent);
    vec3 v = normalize(m.eye - p);
    // A normal for the strip: the view direction made perpendicular to the strand.
    vec3 n = normalize(v - t * dot(t, v) + vec3(1e-6));

    vec3 base = m.hair_color.rgb * (1.0 + m.hair_color.w * (s.strand_random - 0.5));
    vec3 t1 = normalize(t + m.specular_shift.x * n);
    vec3 t2 = normalize(t + m.specular_shift.y * n);
    float sparkle = mix(1.0, hash(s.strand_random * 97.0 + floor(s.tau * 40.0)), m.specular_strength.w);

    vec3 color = base * m.specular_strength.z;
    // Light by light with constant indices (lighting.glsl).
#define HAIR_LIGHT_TURN(I) { color += hair_light(I, p, t, n, v, t1, t2, base, sparkle, m); }
    FOR_EACH_SCENE_LIGHT(m.light_count, HAIR_LIGHT_TURN)
#undef HAIR_LIGHT_TURN
    // Ambient occlusion darkens every term, as vkhr's volume AO does: the hair around a point
    // blocks its light from most directions, not only the ambient light's.
    color *= clamp(s.occlusion, 0.0, 1.0);
    float alpha = clamp(s.coverage, 0.0, 1.0) * m.opacity;
    return vec4(color * alpha, alpha);
}

// Premultiplied colour of one hair sample in the character's object space (shade_hair_world
// after m's model matrix).
vec4 shade_hair(HairSample s, HairMaterial m) {
    s.position = (m.model * vec4(s.position, 1.0)).xyz;
    s.tangent = mat3(m.model) * s.tangent;
    return shade_hair_world(s, m);
}
