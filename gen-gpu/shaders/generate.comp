#version 460
// Compute path, pass 2 (generate_main.glsl), each vertex stored as two vec4s: for devices
// without shaderInt64.
#extension GL_GOOGLE_include_directive : require
#include "generate_main.glsl"
