#version 460
// 3D-texture trilinear fetch rate (sampled RGBA32F, linear filter, clamp to edge): each
// invocation sums TEXTURE_FETCHES fetches and stores the sum. Coherent: the invocation lattice
// spans the texture and each fetch steps a fraction of a lattice cell, so neighbouring
// invocations read neighbouring texels. SCATTERED: every fetch lands at a hashed position.
#include "common.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits), as the LPV cell passes.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
layout(set = 0, binding = 0) uniform sampler3D tex;
layout(set = 0, binding = 1, std430) writeonly buffer Dst { vec4 v[]; } dst;

vec3 coord(uvec3 id, uint linear, uint k, float inv_grid) {
#ifdef SCATTERED
    uint h = pcg_hash(linear * TEXTURE_FETCHES + k);
    return (vec3(uvec3(h & 1023u, (h >> 10) & 1023u, (h >> 20) & 1023u)) + 0.5) * (1.0 / 1024.0);
#else
    return (vec3(id) + 0.5 + float(k) * vec3(0.25, 0.125, 0.0625)) * inv_grid;
#endif
}

void main() {
    uvec3 n = gl_NumWorkGroups * gl_WorkGroupSize;
    uvec3 id = gl_GlobalInvocationID;
    uint linear = id.x + n.x * (id.y + n.y * id.z);
    float inv_grid = 1.0 / float(n.x);
    vec4 a = vec4(0.0);
    vec4 b = vec4(0.0);
    for (uint k = 0u; k < TEXTURE_FETCHES; k += 2u) {
        a += textureLod(tex, coord(id, linear, k, inv_grid), 0.0);
        b += textureLod(tex, coord(id, linear, k + 1u, inv_grid), 0.0);
    }
    dst.v[linear] = a + b;
}
