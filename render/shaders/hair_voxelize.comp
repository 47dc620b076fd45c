#version 460
// Voxelization fused with generation (render/src/volume.rs): one invocation generates a strand
// (gen-gpu's strand-coherent evaluation, as the compute rasterizer's hair_raster.comp) at full
// detail and samples each of its segments twice per voxel it crosses; each sample adds its share
// of the segment's projected area (length × width, voxel units) and that area times the
// segment's direction to the voxel it falls in, as 64-bit fixed point (exact sums in any order).
// Dispatched over every strand (a LOD pass with LOD and culling off). CPU port:
// volume.rs cpu::voxelize.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "hair_gen.glsl"
#include "hair_outputs.glsl"
#include "hk_render_contract.glsl"

layout(local_size_x = 32) in;

// Per voxel: area, then area × direction x, y, z (two's complement), in 1 / AREA_SCALE units.
layout(std430, set = 0, binding = HK_BINDING_VOXEL_SUMS) buffer SumBuffer { uint64_t sums[]; };

layout(push_constant) uniform VoxelizeParams {
    mat4 object_to_voxel;  // uniform scale: voxel coordinates, voxel i spanning [i, i + 1)
    uvec4 dims;            // xyz voxels per axis
} vox;

const float AREA_SCALE = 1048576.0;  // volume.rs AREA_SCALE

// volume.rs cpu::segment_samples
uint segment_samples(float length_voxels) {
    return uint(clamp(ceil(2.0 * length_voxels), 1.0, 4096.0));
}

int64_t fixed_signed(float x) {
    return int64_t(round(x * AREA_SCALE));
}

// Segment a-b in voxel coordinates, full widths wa, wb in voxels.
void voxelize_segment(vec3 a, vec3 b, float wa, float wb) {
    vec3 d = b - a;
    float len = length(d);
    if (!(len > 0.0)) {
        return;
    }
    vec3 direction = d / len;
    uint n = segment_samples(len);
    float step = len / float(n);
    vec3 size = vec3(vox.dims.xyz);
    for (uint j = 0u; j < n; ++j) {
        float t = (float(j) + 0.5) / float(n);
        vec3 p = a + d * t;
        if (any(lessThan(p, vec3(0.0))) || any(greaterThanEqual(p, size))) {
            continue;
        }
        uvec3 c = uvec3(p);
        uint voxel = (c.z * vox.dims.y + c.y) * vox.dims.x + c.x;
        float area = step * mix(wa, wb, t);
        uint64_t q = uint64_t(area * AREA_SCALE + 0.5);
        if (q == 0UL) {
            continue;
        }
        atomicAdd(sums[4u * voxel], q);
        atomicAdd(sums[4u * voxel + 1u], uint64_t(fixed_signed(direction.x * area)));
        atomicAdd(sums[4u * voxel + 2u], uint64_t(fixed_signed(direction.y * area)));
        atomicAdd(sums[4u * voxel + 3u], uint64_t(fixed_signed(direction.z * area)));
    }
}

void main() {
    uint group = gl_WorkGroupID.y * DISPATCH_ROW + gl_WorkGroupID.x;
    uint slot = group * STRANDS_PER_GROUP + gl_LocalInvocationID.x;
    if (slot >= chunk_size(0u)) {
        return;
    }
    uint bundle = slot_bundle(slot);
    uint strand = slot - offsets[bundle];
    BundleLod l = lods[bundle];
    uint segments = 1u << l.level;
    bool from_control = PER_VERTEX_FETCH == 0u;
    vec2 root = root_parameter(bundle, strand);
    SegmentControl c;
    c.segment = -1;
    uint seed = strand_seed(bundle, strand);
    float scale = length_scale(seed);
    float to_voxels = length(vox.object_to_voxel[0].xyz);
    vec3 previous = vec3(0.0);
    float previous_width = 0.0;
    for (uint k = 0u; k <= segments; ++k) {
        float tau = float(k) / float(segments);
        vec3 p = from_control ? thread_strand_point(bundle, seed, scale, root, tau, c)
                              : strand_point(bundle, strand, root, tau);
        vec3 q = (vox.object_to_voxel * vec4(p, 1.0)).xyz;
        float width = width_at(tau) * l.width_scale * to_voxels;
        if (k > 0u) {
            voxelize_segment(previous, q, previous_width, width);
        }
        previous = q;
        previous_width = width;
    }
}
