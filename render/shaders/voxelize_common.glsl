// The voxelization's sums and segment sampling (render/src/volume.rs), shared by the fused
// kernel (hair_voxelize.comp) and the stored-strand one (hair_voxelize_stored.comp). CPU port:
// volume.rs cpu::voxelize.

#include "float_int.glsl"

// Per voxel: area, then area × direction x, y, z (two's complement), in 1 / AREA_SCALE units.
layout(std430, set = 0, binding = HK_BINDING_VOXEL_SUMS) buffer SumBuffer { uint64_t sums[]; };

layout(push_constant) uniform VoxelizeParams {
    mat4 object_to_voxel;  // uniform scale: voxel coordinates, voxel i spanning [i, i + 1)
    uvec4 dims;            // xyz voxels per axis; w: stored strands, the slots in the bound window
} vox;

const float AREA_SCALE = 1048576.0;  // volume.rs AREA_SCALE

// volume.rs cpu::segment_samples
uint segment_samples(float length_voxels) {
    return uint(floor_int(clamp(ceil(length_voxels), 1.0, 4096.0)));
}

int64_t fixed_signed(float x) {
    return int64_t(round(x * AREA_SCALE));
}

// A strand's consecutive samples in one voxel (a strand runs about a voxel's length through each
// voxel it crosses, segments shorter than a voxel add one each, consecutive segments meet in
// one) are summed here and added with one set of atomics when the strand leaves
// the voxel: integer sums, so the voxel's totals are the same bits as one atomic per sample, with
// fewer atomics (the voxelization's largest cost on lavapipe). Every kernel
// calls flush_voxel() after its strand's last segment.
const uint NO_VOXEL = 0xffffffffu;
uint run_voxel = NO_VOXEL;
uint64_t run_area = 0UL;
i64vec3 run_direction = i64vec3(0L);

void flush_voxel() {
    if (run_voxel != NO_VOXEL) {
        atomicAdd(sums[4u * run_voxel], run_area);
        atomicAdd(sums[4u * run_voxel + 1u], uint64_t(run_direction.x));
        atomicAdd(sums[4u * run_voxel + 2u], uint64_t(run_direction.y));
        atomicAdd(sums[4u * run_voxel + 3u], uint64_t(run_direction.z));
    }
    run_voxel = NO_VOXEL;
    run_area = 0UL;
    run_direction = i64vec3(0L);
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
        uvec3 c = uvec3(floor_int3(p));
        uint voxel = (c.z * vox.dims.y + c.y) * vox.dims.x + c.x;
        float area = step * mix(wa, wb, t);
        uint64_t q = uint64_t(area * AREA_SCALE + 0.5);
        if (q == 0UL) {
            continue;
        }
        if (voxel != run_voxel) {
            flush_voxel();
            run_voxel = voxel;
        }
        run_area += q;
        run_direction += i64vec3(fixed_signed(direction.x * area), fixed_signed(direction.y * area),
                                 fixed_signed(direction.z * area));
    }
}
