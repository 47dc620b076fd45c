// The hair volumes' AO (render/src/volume.rs): its buffer and trilinear samples, for the passes
// that shade hair (raster_shade.comp, hair_fragment.glsl).

#include "float_int.glsl"

layout(std430, set = 0, binding = HK_BINDING_VOLUME_AO) readonly buffer AoBuffer { float volume_ao[]; };

// Trilinear AO of the region `dims` (voxels per axis, first voxel) at voxel point p (voxel
// centres at i + 0.5; points outside take the border's, which the empty padding keeps near 1).
float volume_ao_sample(uvec4 dims, vec3 p) {
    ivec3 d = ivec3(dims.xyz);
    vec3 q = clamp(p - 0.5, vec3(0.0), vec3(d - 1));
    ivec3 i0 = min(floor_int3(q), d - 2);
    vec3 f = q - vec3(i0);
    float sum = 0.0;
    for (int k = 0; k < 8; ++k) {
        ivec3 o = ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        ivec3 c = min(i0 + o, d - 1);
        vec3 w3 = mix(1.0 - f, f, vec3(o));
        sum += (w3.x * w3.y * w3.z) * volume_ao[dims.w + (uint(c.z) * uint(d.y) + uint(c.y)) * uint(d.x) + uint(c.x)];
    }
    return sum;
}
