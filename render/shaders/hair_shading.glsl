// Hair shading shared by the opaque and the OIT fragment stages (Scheuermann 2004, after
// Kajiya-Kay 1989): a Kajiya-Kay diffuse term blended with a scaled-and-biased Lambert term,
// plus two shifted specular lobes: the primary (light colour) shifted toward the tip, the
// secondary (tinted by the hair colour, with sparkle from per-strand noise) shifted toward the
// root. Everything is in the character's object space (the host moves eye and lights there).

layout(location = 0) in vec4 v_position_tau;
layout(location = 1) in vec4 v_tangent_random;
layout(location = 2) in vec4 v_coverage_side;

const uint MAX_LIGHTS = 2u;

// Bytes 0-15 belong to the pre-raster stages (gen-gpu's FRAGMENT_PUSH_OFFSET).
layout(push_constant) uniform Shading {
    layout(offset = 16) vec4 eye;            // xyz eye; w: number of lights
    vec4 light_vector[MAX_LIGHTS];           // xyz: direction toward the light (w = 0) or position (w = 1)
    vec4 light_color[MAX_LIGHTS];            // rgb radiance
    vec4 hair_color;                         // rgb base colour; w: per-strand variation
    vec4 specular_shift;                     // x primary shift, y secondary shift, z primary exponent, w secondary exponent
    vec4 specular_strength;                  // x primary, y secondary, z ambient, w sparkle
    vec4 hair_opacity;                       // x: opacity of one strand (1 = opaque)
    mat4 light_view_proj;                    // object space -> shadow light clip space (orthographic)
    vec4 shadow;                             // xyz: ends of the 3 opacity layers (light depth units); w: map size, 0 = no shadows
} shading;

// Deep opacity map of the shadow-casting light (Yuksel & Keyser 2008): the nearest hair depth
// per texel and the opacity accumulated up to the end of each of three layers behind it.
layout(std430, set = 0, binding = 15) readonly buffer ShadowDepth { float shadow_depth[]; };
layout(std430, set = 0, binding = 16) readonly buffer ShadowOpacity { vec4 shadow_opacity[]; };

// Fraction of the light reaching p through the hair in front of it.
float shadow_transmittance(vec3 p) {
    float size = shading.shadow.w;
    if (size < 0.5) {
        return 1.0;
    }
    vec4 clip = shading.light_view_proj * vec4(p, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) {
        return 1.0;
    }
    uvec2 texel = uvec2(uv * size);
    uint index = texel.y * uint(size) + texel.x;
    float d = ndc.z - shadow_depth[index];
    vec3 ends = shading.shadow.xyz;
    vec4 o = shadow_opacity[index];
    float opacity;
    if (d <= 0.0) {
        opacity = 0.0;
    } else if (d < ends.x) {
        opacity = o.x * d / ends.x;
    } else if (d < ends.y) {
        opacity = mix(o.x, o.y, (d - ends.x) / (ends.y - ends.x));
    } else if (d < ends.z) {
        opacity = mix(o.y, o.z, (d - ends.y) / (ends.z - ends.y));
    } else {
        opacity = o.z;
    }
    return exp(-1.5 * opacity);
}

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

// Premultiplied colour of this fragment; alpha is the strand's pixel coverage (coverage AA).
vec4 shade_hair() {
    vec3 p = v_position_tau.xyz;
    float tau = v_position_tau.w;
    vec3 t = normalize(v_tangent_random.xyz);
    float strand_rand = v_tangent_random.w;
    vec3 v = normalize(shading.eye.xyz - p);
    // A normal for the strip: the view direction made perpendicular to the strand.
    vec3 n = normalize(v - t * dot(t, v) + vec3(1e-6));

    vec3 base = shading.hair_color.rgb * (1.0 + shading.hair_color.w * (strand_rand - 0.5));
    vec3 t1 = normalize(t + shading.specular_shift.x * n);
    vec3 t2 = normalize(t + shading.specular_shift.y * n);
    float sparkle = mix(1.0, hash(strand_rand * 97.0 + floor(tau * 40.0)), shading.specular_strength.w);

    vec3 color = base * shading.specular_strength.z;
    uint lights = min(uint(shading.eye.w), MAX_LIGHTS);
    // The first light casts the shadow.
    float shadowed = shadow_transmittance(p);
    for (uint i = 0u; i < lights; ++i) {
        vec4 lv = shading.light_vector[i];
        vec3 l = lv.w > 0.5 ? normalize(lv.xyz - p) : normalize(lv.xyz);
        vec3 h = normalize(l + v);
        float t_dot_l = dot(t, l);
        float kajiya = sqrt(max(0.0, 1.0 - t_dot_l * t_dot_l));
        float lambert = clamp(mix(0.25, 1.0, dot(n, l)), 0.0, 1.0);
        vec3 diffuse = base * mix(lambert, kajiya, 0.5);
        vec3 primary = vec3(shading.specular_strength.x * strand_specular(t1, h, shading.specular_shift.z));
        vec3 secondary = base * shading.specular_strength.y * sparkle * strand_specular(t2, h, shading.specular_shift.w);
        float transmittance = i == 0u ? shadowed : 1.0;
        color += shading.light_color[i].rgb * transmittance * (diffuse + primary + secondary);
    }
    float alpha = clamp(v_coverage_side.x, 0.0, 1.0) * shading.hair_opacity.x;
    return vec4(color * alpha, alpha);
}
