#version 460
// Compute path, pass 1a: culling and LOD per bundle.
#extension GL_GOOGLE_include_directive : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"

layout(local_size_x = 64) in;

void main() {
    uint b = gl_GlobalInvocationID.x;
    if (b < params.counts.x) {
        lods[b] = bundle_lod(b);
    }
}
