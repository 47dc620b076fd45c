#version 460
// Compute rasterizer, shade: per pixel, the nearest fragment of the visibility buffer shaded
// with the triangle path's shade_hair — its world position rebuilt from the pixel centre and
// the stored view depth; its tangent, tau and strand random from the stored attributes; its
// material from the frame's table — into the shaded buffer (unpremultiplied colour, view depth;
// w < 0 where no hair is). The resolve filters and composites it.
#extension GL_GOOGLE_include_directive : require
#include "raster_common.glsl"
#include "hair_shading.glsl"
#include "raster_frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// The pixel rectangle the frame's hair can cover (x0, y0, x1, y1; x1, y1 exclusive).
layout(push_constant) uniform Rect {
    uvec4 rect;
} area;

layout(std430, set = 0, binding = HK_BINDING_VISIBILITY) readonly buffer PixelBuffer { uint64_t pixel_words[]; };
layout(std430, set = 0, binding = HK_BINDING_SHADED) writeonly buffer ShadedBuffer { vec4 shaded[]; };

void main() {
    uvec2 xy = gl_GlobalInvocationID.xy + area.rect.xy;
    if (xy.x >= area.rect.z || xy.y >= area.rect.w) {
        return;
    }
    uint pixel = xy.y * frame.size.x + xy.x;
    uint64_t word = pixel_words[2u * pixel];
    if (word == VISIBILITY_EMPTY) {
        shaded[pixel] = vec4(0.0, 0.0, 0.0, -1.0);
        return;
    }
    VisibleFragment f = decode_visibility(word);
    vec2 ndc = (vec2(xy) + 0.5) / vec2(frame.size.xy) * 2.0 - 1.0;
    vec4 far_point = frame.inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 ray = normalize(far_point.xyz / far_point.w - frame.eye.xyz);
    vec3 position = frame.eye.xyz + ray * (f.w / max(dot(ray, frame.forward.xyz), 1e-6));
    RasterMaterial m = frame.materials[min(f.material, MAX_MATERIALS - 1u)];
    // Shaded at full coverage: the resolve applies the pixel's alpha.
    HairSample s = HairSample(position, f.tau, f.tangent, f.random, 1.0);
    HairMaterial material = HairMaterial(mat4(1.0), frame.eye.xyz, uint(frame.eye.w), m.hair_color,
                                         m.specular_shift, m.specular_strength, 1.0);
    shaded[pixel] = vec4(shade_hair(s, material).rgb, f.w);
}
