// A synthetic strand pattern drawn by both generation paths (task+mesh shaders, and compute +
// vertex pulling). It exercises the plumbing of each path before real hair exists: the paths
// share this one file, so any image difference comes from the pipelines, not from the math.

const uint TEST_STRIP_SEGMENTS = 16u;
const uint TEST_STRIP_POINTS = TEST_STRIP_SEGMENTS + 1u;

layout(push_constant) uniform TestStripParams {
    uint strand_count;
    // Width / height of the target, to keep strip widths isotropic in pixels.
    float aspect;
    // Root width in normalized device units.
    float width;
    uint pad;
} params;

struct StripVertexPair {
    vec4 left;
    vec4 right;
    vec4 color;
};

// Point k of strand s in normalized device coordinates; strands get distinct depths so the
// depth test, not the drawing order, decides overlaps.
vec3 test_strip_point(uint strand, uint k) {
    float s = (float(strand) + 0.5) / float(params.strand_count);
    float t = float(k) / float(TEST_STRIP_SEGMENTS);
    float x = -0.8 + 1.6 * s + 0.12 * sin(6.0 * t + 11.0 * s) * t;
    float y = -0.85 + 1.7 * t;
    float z = 0.1 + 0.8 * fract(s * 7.31);
    return vec3(x, y, z);
}

StripVertexPair test_strip_vertex_pair(uint strand, uint k) {
    vec3 prev = test_strip_point(strand, k == 0u ? 0u : k - 1u);
    vec3 next = test_strip_point(strand, min(k + 1u, TEST_STRIP_SEGMENTS));
    vec3 p = test_strip_point(strand, k);
    vec2 tangent = vec2((next.x - prev.x) * params.aspect, next.y - prev.y);
    vec2 side = normalize(vec2(-tangent.y, tangent.x));
    float t = float(k) / float(TEST_STRIP_SEGMENTS);
    float half_width = 0.5 * params.width * (1.0 - 0.8 * t);
    vec2 offset = vec2(side.x / params.aspect, side.y) * half_width;
    float s = float(strand) / float(max(params.strand_count, 1u));
    vec3 color = 0.5 + 0.5 * cos(6.2831853 * (s + vec3(0.0, 0.33, 0.67)));
    StripVertexPair pair;
    pair.left = vec4(p.xy - offset, p.z, 1.0);
    pair.right = vec4(p.xy + offset, p.z, 1.0);
    pair.color = vec4(color * (0.6 + 0.4 * t), 1.0);
    return pair;
}
