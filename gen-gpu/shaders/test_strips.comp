#version 460
#extension GL_GOOGLE_include_directive : require
#include "hk_gen_contract.glsl"
// Compute path: one thread per strand point writes the point's two strip vertices
// (position, colour) for `strip_pull.vert` to draw.
#include "test_strips.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = HK_BINDING_DIAGNOSTIC_OUTPUT) writeonly buffer StripVertices {
    vec4 vertices[];
};

void main() {
    uint id = gl_GlobalInvocationID.x;
    if (id >= params.strand_count * TEST_STRIP_POINTS) {
        return;
    }
    StripVertexPair pair = test_strip_vertex_pair(id / TEST_STRIP_POINTS, id % TEST_STRIP_POINTS);
    vertices[4u * id + 0u] = pair.left;
    vertices[4u * id + 1u] = pair.color;
    vertices[4u * id + 2u] = pair.right;
    vertices[4u * id + 3u] = pair.color;
}
