// Float-to-int helpers shared by gen-gpu's and render's shaders (included once: guarded).
#ifndef HK_FLOAT_INT_GLSL
#define HK_FLOAT_INT_GLSL

// int(floor(x)) for |x| <= 2^22 (x is clamped there) without a float-to-int conversion: CPU
// devices (llvmpipe) convert lane by lane with saturation, about six instructions per lane,
// where this is four vector instructions — adding 1.5 * 2^23 leaves the integer in the
// mantissa. Measured: two conversions per pixel column were a fifth of the compute
// rasterizer's time on lavapipe.
int floor_int(float x) {
    float f = floor(clamp(x, -4194304.0, 4194304.0));
    return floatBitsToInt(f + 12582912.0) - 0x4B400000;
}

// Per component (CPU devices keep each component in its own vector register anyway).
ivec2 floor_int2(vec2 x) {
    return ivec2(floor_int(x.x), floor_int(x.y));
}

ivec3 floor_int3(vec3 x) {
    return ivec3(floor_int(x.x), floor_int(x.y), floor_int(x.z));
}

#endif
