#version 460
// Compute rasterizer, resolve: each pixel's shaded nearest fragment, averaged with those of its
// 3×3 neighbours that lie at about its depth (a bilateral filter: a pixel of sub-pixel strands
// sees one strand, its neighbours others, and the average stands for the several strands the
// pixel really holds instead of one strand's highlight or shadow), times the alpha the pixel's
// accumulated coverage gives; premultiplied and blended over what the frame's image holds
// there (the occluders, or the background), with the hair's depth where it lies in front.
//
// Written straight into the frame's readback buffers (RGBA16F colour, f32 depth; what the frame
// returns), not drawn over the colour attachment: on CPU devices a full-screen draw costs a
// fixed price for the attachments and a price per pixel even with every fragment discarded.
// Only the hair's screen rectangle is dispatched. With occluders the copy-out pass has filled
// the buffers with their image first; without, the pixels outside the rectangle are the
// background, which the frame's read fills in on the host (render/src/target.rs
// SceneTarget::read): no attachment, no copy.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#include "raster_common.glsl"
#include "raster_frame.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = HK_BINDING_VISIBILITY) readonly buffer PixelBuffer { uint64_t pixel_words[]; };
layout(std430, set = 0, binding = HK_BINDING_SHADED) readonly buffer ShadedBuffer { vec4 shaded[]; };
// The frame's image: per pixel RGBA16F as two words (red and green, blue and alpha), and depth.
layout(std430, set = 0, binding = HK_BINDING_OUTPUT_COLOR) buffer OutputColor { uvec2 output_color[]; };
layout(std430, set = 0, binding = HK_BINDING_OUTPUT_DEPTH) buffer OutputDepth { float output_depth[]; };

// render/src/raster.rs ResolvePush.
layout(push_constant) uniform ResolveParams {
    uvec4 rect;        // the pixels the shade pass wrote, dispatched (x0, y0, x1, y1; exclusive ends)
    vec4 background;   // rgb; w: 1 when the buffers hold the occluders' image (blend over it)
    uint k;            // visibility slots per pixel
    uint pad0;
    uint64_t shaded_address;  // the shaded colours' device address, for LOAD_BY_ADDRESS
} resolve;

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer ShadedRef { vec4 colours[]; };

// The nine neighbours' shaded colours through the buffer reference where the device has one
// (LOAD_BY_ADDRESS, raster_common.glsl): on CPU devices a gather instead of a loop over the
// SIMD lanes per component (in a fragment shader references are slower).
vec4 load_shaded(uint i) {
    return LOAD_BY_ADDRESS != 0u ? ShadedRef(resolve.shaded_address).colours[i] : shaded[i];
}

// Neighbours farther than this fraction of the pixel's view depth from it are another surface.
const float DEPTH_TOLERANCE = 0.02;

void main() {
    uvec2 xy = resolve.rect.xy + gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(xy, resolve.rect.zw))) {
        return;
    }
    ivec2 size = ivec2(frame.size.xy);
    uint pixel = xy.y * uint(size.x) + xy.x;
    bool over_image = resolve.background.w > 0.5;
    vec4 centre = load_shaded(pixel);
    if (centre.w < 0.0) {
        // No hair: the occluders' image stays; else the background, alpha 0 and depth 1.
        if (!over_image) {
            output_color[pixel] = uvec2(packHalf2x16(resolve.background.rg), packHalf2x16(vec2(resolve.background.b, 0.0)));
            output_depth[pixel] = 1.0;
        }
        return;
    }
    vec3 sum = vec3(0.0);
    float weights = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = ivec2(xy) + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(resolve.rect.xy))) || any(greaterThanEqual(q, ivec2(resolve.rect.zw)))) {
                continue;
            }
            vec4 n = load_shaded(uint(q.y * size.x + q.x));
            if (n.w < 0.0 || abs(n.w - centre.w) > DEPTH_TOLERANCE * centre.w) {
                continue;
            }
            float weight = (dx == 0 ? 2.0 : 1.0) * (dy == 0 ? 2.0 : 1.0);
            sum += weight * n.rgb;
            weights += weight;
        }
    }
    // The coverage word holds every fragment's alpha (coverage times opacity).
    float alpha = coverage_alpha(pixel_words[pixel_word(pixel, resolve.k, resolve.k)]);
    vec4 hair = vec4(sum / weights * alpha, alpha);
    // The pixel centre's point at the fragment's view depth, projected: the hair's depth.
    vec2 ndc = (vec2(xy) + 0.5) / vec2(size) * 2.0 - 1.0;
    vec4 far_point = frame.inv_view_proj * vec4(ndc, 1.0, 1.0);
    vec3 ray = normalize(far_point.xyz / far_point.w - frame.eye.xyz);
    vec3 position = frame.eye.xyz + ray * (centre.w / max(dot(ray, frame.forward.xyz), 1e-6));
    vec4 clip = frame.view_proj * vec4(position, 1.0);
    float depth = clamp(clip.z / clip.w, 0.0, 1.0);
    // As the depth test (less) and premultiplied "over" blending of a draw would.
    vec4 below = vec4(resolve.background.rgb, 0.0);
    float below_depth = 1.0;
    if (over_image) {
        uvec2 words = output_color[pixel];
        below = vec4(unpackHalf2x16(words.x), unpackHalf2x16(words.y));
        below_depth = output_depth[pixel];
    }
    if (!(depth < below_depth)) {
        return;
    }
    vec4 blended = hair + below * (1.0 - hair.a);
    output_color[pixel] = uvec2(packHalf2x16(blended.rg), packHalf2x16(blended.ba));
    output_depth[pixel] = depth;
}
