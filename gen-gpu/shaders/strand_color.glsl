// Placeholder hair colour until the renderer's shading exists: a brown base varied per strand,
// lit by a fixed Kajiya-Kay diffuse term so strand direction is visible.
vec4 strand_color(StrandVertex v, uint bundle, uint strand) {
    vec3 base = vec3(0.33, 0.2, 0.11) * (0.75 + 0.5 * strand_random(bundle, strand, 7u));
    vec3 light = normalize(vec3(0.4, 0.8, 0.45));
    float sin_tl = sqrt(max(0.0, 1.0 - pow(dot(v.tangent, light), 2.0)));
    return vec4(base * (0.35 + 0.9 * sin_tl) * (0.6 + 0.4 * v.tau), 1.0);
}
