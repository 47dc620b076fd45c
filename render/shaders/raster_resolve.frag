#version 460
// Compute rasterizer, resolve: each pixel's shaded nearest fragment, averaged with those of its
// 3×3 neighbours that lie at about its depth (a bilateral filter: a pixel of sub-pixel strands
// sees one strand, its neighbours others, and the average stands for the several strands the
// pixel really holds instead of one strand's highlight or shadow), times the alpha the pixel's
// accumulated coverage gives; premultiplied and blended over the
// target (occluders, background), with the hair's depth written (the depth test keeps a nearer
// occluder's).
#extension GL_GOOGLE_include_directive : require
#include "raster_common.glsl"
#include "raster_frame.glsl"

layout(std430, set = 0, binding = HK_BINDING_VISIBILITY) readonly buffer PixelBuffer { uint64_t pixel_words[]; };
layout(std430, set = 0, binding = HK_BINDING_SHADED) readonly buffer ShadedBuffer { vec4 shaded[]; };

layout(location = 0) out vec4 out_color;

// The rectangle the shade pass wrote (raster_rect.vert draws just it); size.z: slots K.
layout(push_constant) uniform Rect {
    uvec4 rect;
    uvec4 size;
} area;

// Neighbours farther than this fraction of the pixel's view depth from it are another surface.
const float DEPTH_TOLERANCE = 0.02;

void main() {
    ivec2 xy = ivec2(gl_FragCoord.xy);
    ivec2 size = ivec2(frame.size.xy);
    uint pixel = uint(xy.y * size.x + xy.x);
    vec4 centre = shaded[pixel];
    if (centre.w < 0.0) {
        discard;
    }
    vec3 sum = vec3(0.0);
    float weights = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = xy + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(area.rect.xy))) || any(greaterThanEqual(q, ivec2(area.rect.zw)))) {
                continue;
            }
            vec4 n = shaded[q.y * size.x + q.x];
            if (n.w < 0.0 || abs(n.w - centre.w) > DEPTH_TOLERANCE * centre.w) {
                continue;
            }
            float weight = (dx == 0 ? 2.0 : 1.0) * (dy == 0 ? 2.0 : 1.0);
            sum += weight * n.rgb;
            weights += weight;
        }
    }
    // The coverage word holds every fragment's alpha (coverage times opacity).
    float alpha = coverage_alpha(pixel_words[pixel_word(pixel, area.size.z, area.size.z)]);
    out_color = vec4(sum / weights * alpha, alpha);
    // The pixel centre's point at the fragment's view depth, projected.
    vec2 ndc = gl_FragCoord.xy / vec2(size) * 2.0 - 1.0;
    vec4 far_point = frame.inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 ray = normalize(far_point.xyz / far_point.w - frame.eye.xyz);
    vec3 position = frame.eye.xyz + ray * (centre.w / max(dot(ray, frame.forward.xyz), 1e-6));
    vec4 clip = frame.view_proj * vec4(position, 1.0);
    gl_FragDepth = clamp(clip.z / clip.w, 0.0, 1.0);
}
