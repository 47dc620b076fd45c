#version 460
#extension GL_GOOGLE_include_directive : require
#include "hk_render_contract.glsl"
// Occluder meshes (scalp, body) pulled from storage buffers: indexed triangles, world-space
// position and normal out. Also the vertex stage of the occluder shadow depth pass.
layout(std430, set = 0, binding = HK_BINDING_OCCLUDER_POSITIONS) readonly buffer Positions { vec4 positions[]; };
layout(std430, set = 0, binding = HK_BINDING_OCCLUDER_NORMALS) readonly buffer Normals { vec4 normals[]; };
layout(std430, set = 0, binding = HK_BINDING_OCCLUDER_INDICES) readonly buffer Indices { uint indices[]; };

layout(push_constant) uniform Occluder {
    mat4 model;       // object -> world
    mat4 view_proj;   // world -> clip (the camera's, or the light's in the shadow pass)
    vec4 eye;         // xyz world eye; w: number of lights
    vec4 color;       // rgb albedo (linear); w: ambient
} occluder;

layout(location = 0) out vec3 v_position;
layout(location = 1) out vec3 v_normal;

void main() {
    uint index = indices[gl_VertexIndex];
    vec4 world = occluder.model * vec4(positions[index].xyz, 1.0);
    v_position = world.xyz;
    // Uniform scale and rotation only (scene transforms), so the model matrix moves normals.
    v_normal = mat3(occluder.model) * normals[index].xyz;
    gl_Position = occluder.view_proj * world;
}
