#version 460
// Accumulated SH → three RGBA32F 3D images (R, G, B; coefficients in xyzw), cascades stacked
// along z, so shading gets hardware trilinear filtering.
#include "common.glsl"
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(set = 0, binding = 1, std430) readonly buffer Accum { float v[]; } C;
layout(set = 0, binding = 2, rgba32f) uniform writeonly image3D out_r;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image3D out_g;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image3D out_b;

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    uint cl = cell_linear(ivec3(id.x, id.y, id.z % n));
    vec4 v[3];
    for (uint ch = 0u; ch < 3u; ++ch) {
        for (uint k = 0u; k < 4u; ++k) v[ch][k] = C.v[light_index(c, ch * 4u + k, cl)];
    }
    imageStore(out_r, ivec3(id), v[0]);
    imageStore(out_g, ivec3(id), v[1]);
    imageStore(out_b, ivec3(id), v[2]);
}
