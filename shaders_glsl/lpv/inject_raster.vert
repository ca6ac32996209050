#version 460
// Raster injection (the thesis' geometry-shader path): one point per RSM texel, instanced per
// cascade. The vertex places the point at its cell's centre in an N×N viewport and hands the
// layer (cell z within the cascade's slab) and the VPL's SH to the geometry shader.
#include "common.glsl"
layout(set = 0, binding = 1) uniform sampler2D rsm_position;
layout(set = 0, binding = 2) uniform sampler2D rsm_normal;
layout(set = 0, binding = 3) uniform sampler2D rsm_flux;
layout(location = 0) flat out int v_layer;
layout(location = 1) flat out vec4 v_r;
layout(location = 2) flat out vec4 v_g;
layout(location = 3) flat out vec4 v_b;

void main() {
    uint size = L.dims.z;
    ivec2 t = ivec2(uint(gl_VertexIndex) % size, uint(gl_VertexIndex) / size);
    uint c = uint(gl_InstanceIndex);
    vec4 p = texelFetch(rsm_position, t, 0);
    vec3 n, flux;
    bool lit = vpl(texelFetch(rsm_normal, t, 0), texelFetch(rsm_flux, t, 0).rgb, n, flux);
    ivec3 cell = vpl_cell(c, p.xyz, n);
    v_layer = -1;
    gl_Position = vec4(2.0, 2.0, 0.5, 1.0);  // outside the viewport unless it lands in the grid
    if (p.w <= 0.0 || !lit || !in_grid(cell)) return;
    float N = float(lpv_n());
    gl_Position = vec4((vec2(cell.xy) + 0.5) / N * 2.0 - 1.0, 0.5, 1.0);
    v_layer = cell.z + int(c * lpv_n());
    vec4 lobe = sh_cosine_lobe(n) / PI;
    v_r = flux.r * lobe;
    v_g = flux.g * lobe;
    v_b = flux.b * lobe;
}
