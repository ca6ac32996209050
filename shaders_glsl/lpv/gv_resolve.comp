#version 460
// Geometry volume, fixed point → float image: one (N+1)³ block per source and cascade (common.glsl),
// the extra lattice layer zero, so propagation can sample it with hardware trilinear filtering.
#include "common.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits); y and z are scalar loops.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
layout(set = 0, binding = 1, std430) readonly buffer Gv { int v[]; } V;
layout(set = 0, binding = 2, rgba32f) writeonly uniform image3D gv;

void main() {
    uint m = gv_block();
    uvec3 id = gl_GlobalInvocationID;
    uint block = id.z / m;
    uint sources = L.gbuffer.w != 0u ? 2u : 1u;
    if (id.x >= m || id.y >= m || block >= sources * L.dims.y) return;
    ivec3 g = ivec3(id.x, id.y, id.z % m);
    vec4 b = vec4(0.0);
    if (in_grid(g)) {
        uint source = block / L.dims.y, c = block % L.dims.y, cl = cell_linear(g);
        for (uint k = 0u; k < 4u; ++k) b[k] = float(V.v[gv_index(source, c, k, cl)]);
    }
    imageStore(gv, ivec3(id), b / L.params.w);
}
