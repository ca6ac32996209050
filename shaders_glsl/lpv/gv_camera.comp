#version 460
// Geometry volume from the camera's depth buffer: every `stride`-th pixel is a surfel whose area
// is its footprint, (d·α·stride)² / |n·v| (α: one pixel's angle), so surfaces the RSM cannot see
// (hidden from the light) still block light. Written to GV source 1.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 1) uniform sampler2D depth_tex;
layout(set = 0, binding = 2) uniform sampler2D normal_tex;
layout(set = 0, binding = 3, std430) buffer Gv { int v[]; } V;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy) * int(L.gbuffer.z);
    if (any(greaterThanEqual(p, ivec2(L.gbuffer.xy)))) return;
    float depth = texelFetch(depth_tex, p, 0).r;
    if (depth >= 1.0) return;
    vec2 uv = (vec2(p) + 0.5) / vec2(L.gbuffer.xy);
    vec4 w = L.inv_view_proj * vec4(uv * 2.0 - 1.0, depth, 1.0);
    vec3 x = w.xyz / w.w;
    vec3 n = normalize(texelFetch(normal_tex, p, 0).xyz);
    vec3 to_eye = L.camera.xyz - x;
    float d = length(to_eye);
    float side = d * L.camera.w * float(L.gbuffer.z);
    float area = side * side / max(abs(dot(n, to_eye / max(d, 1e-9))), 0.25);
    vec4 lobe = sh_cosine_lobe(n);
    for (uint c = 0u; c < L.dims.y; ++c) {
        float s = L.cascade[c].w;
        ivec3 g = ivec3(floor(to_cells(c, x) + 0.5));
        if (!in_grid(g)) continue;
        vec4 b = lobe * (area / (s * s)) * L.params.w;
        uint cl = cell_linear(g);
        for (uint k = 0u; k < 4u; ++k) atomicAdd(V.v[gv_index(1u, c, k, cl)], int(round(b[k])));
    }
}
