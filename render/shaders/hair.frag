#version 460
// Opaque-mode hair fragment stage: shaded, premultiplied colour blended into the target.
#extension GL_GOOGLE_include_directive : require
#include "hair_fragment.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    out_color = shade_hair_fragment();
}
