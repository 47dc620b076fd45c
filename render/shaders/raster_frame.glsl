// The compute rasterizer's frame data for its shade and resolve passes: the camera and the hair
// materials (render/src/raster.rs `RasterFrameHeader`, `RasterMaterial`).

// One hair material (frame.rs `Shading` without the transform), per character with AO.
struct RasterMaterial {
    vec4 hair_color;         // rgb base colour (linear); w: per-strand variation
    vec4 specular_shift;
    vec4 specular_strength;
    vec4 opacity;            // x: opacity of one strand
    // The character's hair volume for AO (render/src/volume.rs): world -> voxel coordinates,
    // and its grid (xyz voxels per axis, 0 without AO; w its first voxel in the volume buffers).
    mat4 world_to_voxel;
    uvec4 volume;
    uvec4 volume_info;       // x: the region's first brick, y: bit 0 AO, bit 1 volume shadows
};

layout(std430, set = 0, binding = HK_BINDING_RASTER_FRAME) readonly buffer RasterFrame {
    mat4 view_proj;          // world -> clip
    mat4 inv_view_proj;      // clip -> world
    vec4 eye;                // xyz world eye; w: number of lights
    vec4 forward;            // xyz unit view direction
    uvec4 size;              // x width, y height
    RasterMaterial materials[];
} frame;
