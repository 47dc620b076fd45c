#version 460
// Opaque mode's hair depth prepass: only fragments the strand covers fully ("solid") write
// depth. A sub-pixel strand is drawn one pixel wide with alpha = its coverage; letting it write
// depth would hide every strand behind it, so thin hair would look sparser than it is. The
// colour pass then blends every fragment in front of (or at) the nearest solid one.
#extension GL_GOOGLE_include_directive : require
#include "hk_gen_contract.glsl"

layout(location = HK_LOCATION_COVERAGE_SIDE) in vec4 v_coverage_side;

#include "shading_constants.glsl"

// Coverage from which a fragment counts as solid (strands at least a pixel wide reach 1).
const float SOLID_COVERAGE = 0.999;

void main() {
    // The real strands' coverage (z), not the LOD-widened strip's (x): see strip_corners.
    if (clamp(v_coverage_side.z, 0.0, 1.0) * shading.hair_opacity.x < SOLID_COVERAGE) {
        discard;
    }
}
