#version 460
// Raster injection's slices (three RGBA32F 2D arrays, layer = z + cascade·N) → the flat grid.
#include "common.glsl"
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(set = 0, binding = 1) uniform sampler2DArray slices_r;
layout(set = 0, binding = 2) uniform sampler2DArray slices_g;
layout(set = 0, binding = 3) uniform sampler2DArray slices_b;
layout(set = 0, binding = 4, std430) writeonly buffer Grid { float v[]; } G;

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    ivec3 t = ivec3(id);
    vec4 v[3] = vec4[3](texelFetch(slices_r, t, 0), texelFetch(slices_g, t, 0), texelFetch(slices_b, t, 0));
    uint cl = cell_linear(ivec3(id.x, id.y, id.z % n));
    for (uint ch = 0u; ch < 3u; ++ch) {
        for (uint k = 0u; k < 4u; ++k) G.v[light_index(c, ch * 4u + k, cl)] = v[ch][k];
    }
}
