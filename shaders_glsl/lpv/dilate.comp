#version 460
// Directional propagation: the normal grid for the next step. RESOLVE: the summed VPL normals
// → unit vectors (w = 1 where the cell holds VPLs). Otherwise one dilation step, by gathering: a
// cell keeps its own normal, or takes the mean direction of its six neighbours' normals, so the
// normals spread one cell per step, as fast as the light.
#include "common.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits); y and z are scalar loops.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
#ifdef RESOLVE
layout(set = 0, binding = 1, std430) readonly buffer Normals { int v[]; } S;
#else
layout(set = 0, binding = 1, rgba32f) readonly uniform image3D src;
#endif
layout(set = 0, binding = 2, rgba32f) writeonly uniform image3D dst;

vec4 unit_or_none(vec3 sum) { return dot(sum, sum) > 1e-12 ? vec4(normalize(sum), 1.0) : vec4(0.0); }

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    ivec3 cell = ivec3(id.x, id.y, id.z % n);
#ifdef RESOLVE
    uint base = (c * cells() + cell_linear(cell)) * 4u;
    vec4 own = S.v[base + 3u] > 0 ? unit_or_none(vec3(S.v[base], S.v[base + 1u], S.v[base + 2u])) : vec4(0.0);
    imageStore(dst, ivec3(id), own);
#else
    vec4 own = imageLoad(src, ivec3(id));
    if (own.w > 0.0) {
        imageStore(dst, ivec3(id), own);
        return;
    }
    vec3 sum = vec3(0.0);
    for (int i = 0; i < 6; ++i) {
        ivec3 nb = cell + DIRS[i];
        if (!in_grid(nb)) continue;
        vec4 v = imageLoad(src, grid_texel(c, nb));
        if (v.w > 0.0) sum += v.xyz;
    }
    imageStore(dst, ivec3(id), unit_or_none(sum));
#endif
}
