// Hair shading shared by the opaque and the OIT fragment stages (Scheuermann 2004, after
// Kajiya-Kay 1989): a Kajiya-Kay diffuse term blended with a scaled-and-biased Lambert term,
// plus two shifted specular lobes: the primary (light colour) shifted toward the tip, the
// secondary (tinted by the hair colour, with sparkle from per-strand noise) shifted toward the
// root. The strands arrive in the character's object space and are shaded in world space.

layout(location = 0) in vec4 v_position_tau;
layout(location = 1) in vec4 v_tangent_random;
layout(location = 2) in vec4 v_coverage_side;

#include "shading_constants.glsl"

#include "lighting.glsl"

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
    vec3 p = (shading.model * vec4(v_position_tau.xyz, 1.0)).xyz;
    float tau = v_position_tau.w;
    vec3 t = normalize(mat3(shading.model) * v_tangent_random.xyz);
    float strand_rand = v_tangent_random.w;
    vec3 v = normalize(shading.eye.xyz - p);
    // A normal for the strip: the view direction made perpendicular to the strand.
    vec3 n = normalize(v - t * dot(t, v) + vec3(1e-6));

    vec3 base = shading.hair_color.rgb * (1.0 + shading.hair_color.w * (strand_rand - 0.5));
    vec3 t1 = normalize(t + shading.specular_shift.x * n);
    vec3 t2 = normalize(t + shading.specular_shift.y * n);
    float sparkle = mix(1.0, hash(strand_rand * 97.0 + floor(tau * 40.0)), shading.specular_strength.w);

    vec3 color = base * shading.specular_strength.z;
    uint light_count = uint(shading.eye.w);
    for (uint i = 0u; i < light_count; ++i) {
        vec3 l = light_direction(i, p);
        vec3 h = normalize(l + v);
        float t_dot_l = dot(t, l);
        float kajiya = sqrt(max(0.0, 1.0 - t_dot_l * t_dot_l));
        float lambert = clamp(mix(0.25, 1.0, dot(n, l)), 0.0, 1.0);
        vec3 diffuse = base * mix(lambert, kajiya, 0.5);
        vec3 primary = vec3(shading.specular_strength.x * strand_specular(t1, h, shading.specular_shift.z));
        vec3 secondary = base * shading.specular_strength.y * sparkle * strand_specular(t2, h, shading.specular_shift.w);
        color += lights[i].color.rgb * light_transmittance(i, p) * (diffuse + primary + secondary);
    }
    float alpha = clamp(v_coverage_side.x, 0.0, 1.0) * shading.hair_opacity.x;
    return vec4(color * alpha, alpha);
}
