#version 460
// Directional propagation (the thesis' §5.2), step one: the normals of the VPLs in each cell,
// summed with integer atomics (×1024, rounded) so every device can add them — only their
// direction is used, and 1024² VPLs in one cell still fit in 31 bits.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 1) uniform sampler2D rsm_position;
layout(set = 0, binding = 2) uniform sampler2D rsm_normal;
layout(set = 0, binding = 3) uniform sampler2D rsm_flux;
layout(set = 0, binding = 4, std430) buffer Normals { int v[]; } S;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(t, ivec2(L.dims.z)))) return;
    vec4 p = texelFetch(rsm_position, t, 0);
    if (p.w <= 0.0) return;
    vec3 n, flux;
    if (!vpl(texelFetch(rsm_normal, t, 0), texelFetch(rsm_flux, t, 0).rgb, n, flux)) return;
    ivec3 q = ivec3(round(n * 1024.0));
    for (uint c = 0u; c < L.dims.y; ++c) {
        ivec3 cell = vpl_cell(c, p.xyz, n);
        if (!in_grid(cell)) continue;
        uint base = (c * cells() + cell_linear(cell)) * 4u;
        atomicAdd(S.v[base], q.x);
        atomicAdd(S.v[base + 1u], q.y);
        atomicAdd(S.v[base + 2u], q.z);
        atomicAdd(S.v[base + 3u], 1);
    }
}
