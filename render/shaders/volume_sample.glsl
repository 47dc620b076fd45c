// Reading a hair volume region (render/src/volume.rs): trilinear samples, the bricks the
// marches skip, and the transmittance of the hair along a ray. The includer declares
// `vec4 volume[]` (mean direction, σ) and `uint bricks[]` (volume_bricks.comp) readonly.
// A region: `dims` = (voxels per axis, first voxel), `first_brick` its first brick.

#include "float_int.glsl"

const float VOLUME_MEAN_SIN = 0.78539816;  // mean |sin| between a strand and a random direction
const int VOLUME_BRICK = 4;
const float VOLUME_OPAQUE = 1.0 / 256.0;   // transmittance below which a march stops

// Trilinear sample at voxel coordinates p (voxel centres at i + 0.5; outside the grid is empty).
vec4 volume_sample(uvec4 dims, vec3 p) {
    vec3 q = p - 0.5;
    ivec3 i0 = floor_int3(q);
    vec3 f = q - vec3(i0);
    ivec3 d = ivec3(dims.xyz);
    vec4 sum = vec4(0.0);
    for (int k = 0; k < 8; ++k) {
        ivec3 o = ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        ivec3 c = i0 + o;
        if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, d))) {
            continue;
        }
        vec3 w3 = mix(1.0 - f, f, vec3(o));
        sum += (w3.x * w3.y * w3.z) * volume[dims.w + (uint(c.z) * uint(d.y) + uint(c.y)) * uint(d.x) + uint(c.x)];
    }
    return sum;
}

// Ray parameters [t0, t1] of origin + t · direction inside the box [0, size] (t1 < t0: a miss).
// `direction` has no zero component.
vec2 volume_box_range(vec3 origin, vec3 direction, vec3 size) {
    vec3 a = -origin / direction;
    vec3 b = (size - origin) / direction;
    vec3 lo = min(a, b);
    vec3 hi = max(a, b);
    return vec2(max(max(lo.x, lo.y), lo.z), min(min(hi.x, hi.y), hi.z));
}

// A direction with no zero component (the slab tests divide by them).
vec3 volume_safe_direction(vec3 d) {
    return mix(d, vec3(1e-20), lessThan(abs(d), vec3(1e-20)));
}

// When the brick holding voxel point p is empty: the ray parameter where origin + t · direction
// leaves it (> t); else -1.
float volume_skip_brick(uvec4 dims, uint first_brick, vec3 origin, vec3 direction, float t, vec3 p) {
    ivec3 nb = (ivec3(dims.xyz) + VOLUME_BRICK - 1) / VOLUME_BRICK;
    ivec3 b = clamp(floor_int3(p / float(VOLUME_BRICK)), ivec3(0), nb - 1);
    if (bricks[first_brick + uint((b.z * nb.y + b.y) * nb.x + b.x)] != 0u) {
        return -1.0;
    }
    vec3 far_face = (vec3(b) + step(vec3(0.0), direction)) * float(VOLUME_BRICK);
    vec3 exits = (far_face - origin) / direction;
    return max(min(min(exits.x, exits.y), exits.z), t + 1e-4);
}

// Optical depth per voxel travelled of sample s along unit direction u, for strands of opacity a:
// σ · a · |sin(T, u)|, the mean |sin| where the voxel's strands disagree.
float volume_extinction(vec4 s, vec3 u, float a) {
    float agreement = length(s.xyz);
    float along = agreement > 1e-6 ? dot(s.xyz / agreement, u) : 0.0;
    float sin_t = mix(VOLUME_MEAN_SIN, sqrt(max(0.0, 1.0 - along * along)), min(agreement, 1.0));
    return s.w * a * sin_t;
}

// Transmittance of the hair from voxel point origin along `direction` (voxels per unit of t)
// over t in [t0, t1], one sample per voxel, skipping empty bricks.
float volume_transmittance(uvec4 dims, uint first_brick, vec3 origin, vec3 direction, float t0, float t1,
                           float opacity) {
    direction = volume_safe_direction(direction);
    vec2 range = volume_box_range(origin, direction, vec3(dims.xyz));
    float t = max(t0, range.x);
    t1 = min(t1, range.y);
    float speed = length(direction);
    float dt = 1.0 / speed;
    vec3 unit = direction / speed;
    float depth = 0.0;
    for (uint i = 0u; i < 1024u && t < t1 && depth < -log(VOLUME_OPAQUE); ++i) {
        float ts = t + 0.5 * dt;
        vec3 p = origin + direction * ts;
        float skip = volume_skip_brick(dims, first_brick, origin, direction, t, p);
        if (skip >= 0.0) {
            t = skip;
            continue;
        }
        t += dt;
        depth += volume_extinction(volume_sample(dims, p), unit, opacity);
    }
    return exp(-depth);
}
