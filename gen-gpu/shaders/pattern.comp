#version 460
#extension GL_GOOGLE_include_directive : require
#include "hk_gen_contract.glsl"
// Writes a known integer pattern so tests can check dispatch, indexing and readback exactly.
layout(local_size_x = 64) in;

layout(push_constant) uniform PatternParams {
    uint count;
    uint seed;
} params;

layout(std430, set = 0, binding = HK_BINDING_DIAGNOSTIC_OUTPUT) writeonly buffer Pattern {
    uint values[];
};

// Wang hash: cheap, well mixed, identical on CPU and GPU.
uint wang_hash(uint x) {
    x = (x ^ 61u) ^ (x >> 16u);
    x *= 9u;
    x = x ^ (x >> 4u);
    x *= 0x27d4eb2du;
    x = x ^ (x >> 15u);
    return x;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < params.count) {
        values[i] = wang_hash(i ^ params.seed);
    }
}
