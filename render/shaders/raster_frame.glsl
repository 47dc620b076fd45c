// The compute rasterizer's frame data for its shade and resolve passes: the camera and the hair
// materials (render/src/raster.rs `RasterFrameHeader`, `RasterMaterial`).

// One hair material (frame.rs `Shading` without the transform).
struct RasterMaterial {
    vec4 hair_color;         // rgb base colour (linear); w: per-strand variation
    vec4 specular_shift;
    vec4 specular_strength;
    vec4 opacity;            // x: opacity of one strand
};

layout(std430, set = 0, binding = HK_BINDING_RASTER_FRAME) readonly buffer RasterFrame {
    mat4 view_proj;          // world -> clip
    mat4 inv_view_proj;      // clip -> world
    vec4 eye;                // xyz world eye; w: number of lights
    vec4 forward;            // xyz unit view direction
    uvec4 size;              // x width, y height
    RasterMaterial materials[];
} frame;
