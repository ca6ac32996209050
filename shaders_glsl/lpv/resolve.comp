#version 460
// A flat atomic light buffer (12 values per cell) → the injected light as a flat buffer of three
// channel blocks (what gather propagation reads; a buffer store is the cheap path on llvmpipe).
// INT: fixed point × 1/scale after integer injection; otherwise floats (float-atomic injection, a
// scatter propagation step). ACCUMULATE (scatter steps): writes the step's images instead and
// adds the step to the accumulated grid.
#include "common.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits); y and z are scalar loops.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
// The atomic buffer is read as texels, a cell's channel (4 values) per texel: llvmpipe gathers a
// texel per lane in one vector operation, where a storage-buffer load loops over the lanes per
// word (12 such loops per cell made the resolve cost more than the injection).
// The texel holding channel ch of a cell: values ch·4 … ch·4 + 3 of its 12.
int channel_texel(uint cascade, uint ch, uint cell) { return int(light_index(cascade, ch * 4u, cell) / 4u); }
#ifdef INT
layout(set = 0, binding = 1, rgba32i) readonly uniform iimageBuffer flat_t;
vec4 channel(uint cascade, uint ch, uint cell) { return vec4(imageLoad(flat_t, channel_texel(cascade, ch, cell))) * L.params.z; }
#else
layout(set = 0, binding = 1, rgba32f) readonly uniform imageBuffer flat_t;
vec4 channel(uint cascade, uint ch, uint cell) { return imageLoad(flat_t, channel_texel(cascade, ch, cell)); }
#endif
#ifdef ACCUMULATE
#define DST_BINDING 2
#define ACC_BINDING 5
#else
#define STACKED_BINDING 2
#endif
#include "images.glsl"

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    uint cl = cell_linear(ivec3(id.x, id.y, id.z % n));
    vec4 v[3];
    for (uint ch = 0u; ch < 3u; ++ch) v[ch] = channel(c, ch, cl);
#ifdef ACCUMULATE
    store_dst(ivec3(id), v);
    accumulate(ivec3(id), v);
#else
    store_stacked(ivec3(id), v);
#endif
}
