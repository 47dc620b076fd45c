// The fragment-stage side of hair shading: a strand pipeline's varyings (gen-gpu's contract)
// and the Shading push constants become shade_hair's explicit inputs.

#include "hk_gen_contract.glsl"

layout(location = HK_LOCATION_POSITION_TAU) in vec4 v_position_tau;
layout(location = HK_LOCATION_TANGENT_RANDOM) in vec4 v_tangent_random;
layout(location = HK_LOCATION_COVERAGE_SIDE) in vec4 v_coverage_side;

#include "shading_constants.glsl"
#include "hair_shading.glsl"

HairSample hair_sample_from_varyings() {
    return HairSample(v_position_tau.xyz, v_position_tau.w, v_tangent_random.xyz, v_tangent_random.w,
                      v_coverage_side.x, 1.0);
}

HairMaterial hair_material_from_push_constants() {
    return HairMaterial(shading.model, shading.eye.xyz, uint(shading.eye.w), shading.hair_color,
                        shading.specular_shift, shading.specular_strength, shading.hair_opacity.x);
}

// This fragment's premultiplied colour.
vec4 shade_hair_fragment() {
    return shade_hair(hair_sample_from_varyings(), hair_material_from_push_constants());
}
