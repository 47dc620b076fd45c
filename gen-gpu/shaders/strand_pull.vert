#version 460
// Compute path, raster: vertex pulling of generated strands as camera-facing strips. Six
// vertices per segment, triangles (2k, 2k+1, 2k+2) and (2k+2, 2k+1, 2k+3) as in strand.mesh;
// segments past a strand's vertex count are clipped away.
#extension GL_GOOGLE_include_directive : require
#define HAIR_GEN_NO_WORKGROUP
#include "hair_gen.glsl"
#include "hair_outputs.glsl"

// Opaque mode draws the same strands twice (a depth prepass, then colour with LESS_OR_EQUAL):
// both pipelines must compute bit-identical positions.
invariant gl_Position;

layout(location = HK_LOCATION_POSITION_TAU) out vec4 v_position_tau;
layout(location = HK_LOCATION_TANGENT_RANDOM) out vec4 v_tangent_random;
layout(location = HK_LOCATION_COVERAGE_SIDE) out vec4 v_coverage_side;

const uint CORNER[6] = uint[6](0u, 1u, 2u, 2u, 1u, 3u);

// Bytes 0-15 of the push constants belong to the pre-raster stages, 16+ to the fragment stage.
layout(push_constant) uniform ChunkParams {
    uint chunk;
} chunk_params;


void main() {
    // Relative to the bound chunk window.
    uint slot = uint(gl_InstanceIndex);
    uint segment = uint(gl_VertexIndex) / 6u;
    uint corner = CORNER[uint(gl_VertexIndex) % 6u];
    uvec4 info = strand_info[slot];
    if (segment + 1u >= info.z) {
        gl_Position = vec4(0.0, 0.0, -1.0, 1.0);
        v_position_tau = vec4(0.0);
        v_tangent_random = vec4(0.0);
        v_coverage_side = vec4(0.0);
        return;
    }
    uint k = segment + corner / 2u;
    uint base = (slot * MAX_VERTICES + k) * 2u;
    StrandVertex v;
    v.position = strand_vertices[base].xyz;
    v.width = strand_vertices[base].w;
    v.tangent = strand_vertices[base + 1u].xyz;
    v.tau = strand_vertices[base + 1u].w;
    vec4 left;
    vec4 right;
    float coverage;
    float strand_coverage;
    strip_corners(v, uintBitsToFloat(info.w), left, right, coverage, strand_coverage);
    bool is_left = (corner & 1u) == 0u;
    gl_Position = is_left ? left : right;
    StrandVaryings o = strand_varyings(v, info.x, info.y, coverage, strand_coverage, is_left ? -1.0 : 1.0);
    v_position_tau = o.position_tau;
    v_tangent_random = o.tangent_random;
    v_coverage_side = o.coverage_side;
}
