#version 460
// Two triangles covering a pixel rectangle of the target (the compute rasterizer's resolve draws
// only where its characters can be).
layout(push_constant) uniform Rect {
    uvec4 rect;  // x0, y0, x1, y1 in pixels (x1, y1 exclusive)
    uvec4 size;  // target width, height
} r;

void main() {
    const uvec2 CORNERS[6] = uvec2[6](uvec2(0, 0), uvec2(1, 0), uvec2(0, 1), uvec2(0, 1), uvec2(1, 0), uvec2(1, 1));
    uvec2 c = CORNERS[gl_VertexIndex % 6];
    vec2 p = vec2(c.x == 0u ? r.rect.x : r.rect.z, c.y == 0u ? r.rect.y : r.rect.w) / vec2(r.size.xy);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
