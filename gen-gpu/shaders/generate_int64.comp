#version 460
// Compute path, pass 2 (generate_main.glsl), each vertex stored as one u64vec4: the default
// where the device has shaderInt64 (hair_outputs.glsl `store_vertex`).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#define HK_VERTEX_STORES_INT64
#include "generate_main.glsl"
