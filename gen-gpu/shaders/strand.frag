#version 460
#extension GL_GOOGLE_include_directive : require
#include "hk_gen_contract.glsl"
// gen-gpu's own fragment stage for strands (tests, demo, benchmarks): a brown base varied per
// strand, lit by a fixed Kajiya-Kay diffuse term so the strand direction is visible. The
// renderer brings its own hair shading through the same inputs.
layout(location = HK_LOCATION_POSITION_TAU) in vec4 v_position_tau;
layout(location = HK_LOCATION_TANGENT_RANDOM) in vec4 v_tangent_random;
layout(location = HK_LOCATION_COVERAGE_SIDE) in vec4 v_coverage_side;
layout(location = 0) out vec4 out_color;

void main() {
    vec3 tangent = normalize(v_tangent_random.xyz);
    vec3 base = vec3(0.33, 0.2, 0.11) * (0.75 + 0.5 * v_tangent_random.w);
    vec3 light = normalize(vec3(0.4, 0.8, 0.45));
    float sin_tl = sqrt(max(0.0, 1.0 - pow(dot(tangent, light), 2.0)));
    out_color = vec4(base * (0.35 + 0.9 * sin_tl) * (0.6 + 0.4 * v_position_tau.w), 1.0);
}
