// A character's strands in drawing order for the compute rasterizer's two phases
// (raster_split.comp writes it, hair_raster.comp reads it). Each entry is a slot and its
// strand's marks from the last frame (bit i * 32 / segments for segment i; all ones: drawn
// whole): the front part holds the strands with segments that reached the last frame's image,
// walking just those (or, with little history, every SPARSE_SLOT_STRIDE-th slot, whole); the
// rest part every other strand, walking the segments the front part did not. Each part is in
// slot order, with an indirect dispatch.
#include "hk_render_contract.glsl"

layout(std430, set = 0, binding = HK_BINDING_RASTER_SLOTS) buffer SlotOrder {
    DispatchArgs front_dispatch; // over the front part (STRANDS_PER_GROUP per workgroup)
    DispatchArgs rest_dispatch;  // over the rest
    uint front_count;
    uint rest_count;
    uvec2 ordered_slots[];       // (slot, marks): the front part, then the rest
};

// The slot and marks of invocation `index` of the front (or rest) phase; false past the part's
// end.
bool ordered_slot(bool front, uint index, out uint slot, out uint walk) {
    uint count = front ? front_count : rest_count;
    slot = 0u;
    walk = 0u;
    if (index >= count) {
        return false;
    }
    uvec2 entry = ordered_slots[(front ? 0u : front_count) + index];
    slot = entry.x;
    walk = entry.y;
    return true;
}
