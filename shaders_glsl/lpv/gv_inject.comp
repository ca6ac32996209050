#version 460
// Geometry volume from the RSM: each texel is a surfel of area A (the texel's footprint on the
// surface); its blocking potential B(ω) = (A/s²)·max(0, n·ω) is added, in fixed point, to the
// GV cell whose centre (at an LPV cell corner: the half-cell offset) is nearest.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 1) uniform sampler2D rsm_position;
layout(set = 0, binding = 2) uniform sampler2D rsm_normal;
layout(set = 0, binding = 3, std430) buffer Gv { int v[]; } V;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(t, ivec2(L.dims.z)))) return;
    vec4 p = texelFetch(rsm_position, t, 0);
    if (p.w <= 0.0) return;
    vec3 n = normalize(texelFetch(rsm_normal, t, 0).xyz);
    // Footprint: the texel's cross-section perpendicular to the light, divided by the cosine
    // (capped so grazing texels do not claim huge areas).
    float area;
    vec3 to_light;
    if (L.rsm_light.x == 0.0) {
        to_light = -normalize(L.light.xyz);
        area = L.rsm_light.y;
    } else {
        vec3 d = p.xyz - L.light.xyz;
        float dist = length(d);
        to_light = -d / max(dist, 1e-9);
        float texel = 2.0 * L.rsm_light.y / L.rsm_light.z;
        area = texel * texel * dist * dist;  // ≈ solid angle × d² near the axis
    }
    area /= max(abs(dot(n, to_light)), 0.25);
    vec4 lobe = sh_cosine_lobe(n);
    for (uint c = 0u; c < L.dims.y; ++c) {
        float s = L.cascade[c].w;
        ivec3 g = ivec3(floor(to_cells(c, p.xyz) + 0.5));
        if (!in_grid(g)) continue;
        vec4 b = lobe * (area / (s * s)) * L.params.w;
        uint cl = cell_linear(g);
        for (uint k = 0u; k < 4u; ++k) atomicAdd(V.v[gv_index(0u, c, k, cl)], int(round(b[k])));
    }
}
