#version 460
#extension GL_GOOGLE_include_directive : require
#include "hk_gen_contract.glsl"
// Vertex pulling for strips: six vertices per segment, two triangles
// (2k, 2k+1, 2k+2) and (2k+2, 2k+1, 2k+3), the same order the mesh shader emits.
#include "test_strips.glsl"

layout(std430, set = 0, binding = HK_BINDING_DIAGNOSTIC_OUTPUT) readonly buffer StripVertices {
    vec4 vertices[];
};

layout(location = 0) out vec4 v_color;

const uint CORNER[6] = uint[6](0u, 1u, 2u, 2u, 1u, 3u);

void main() {
    uint segment = uint(gl_VertexIndex) / 6u;
    uint strand = segment / TEST_STRIP_SEGMENTS;
    uint k = segment % TEST_STRIP_SEGMENTS;
    uint strip_vertex = 2u * k + CORNER[uint(gl_VertexIndex) % 6u];
    uint v = strand * 2u * TEST_STRIP_POINTS + strip_vertex;
    gl_Position = vertices[2u * v];
    v_color = vertices[2u * v + 1u];
}
