#version 460
// Scatter injection: each RSM texel is a VPL of flux Φ at p with normal n; it adds the SH of
// its intensity Φ/π·max(0, n·ω) to the cell containing p + δ·n, in every cascade. ATOMIC_INT
// adds fixed point (scale from the light's total flux, rounded; the thesis preset truncates
// ×1000) and counts overflows; otherwise float atomics.
#extension GL_EXT_shader_atomic_float : enable
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 1) uniform sampler2D rsm_position;
layout(set = 0, binding = 2) uniform sampler2D rsm_normal;
layout(set = 0, binding = 3) uniform sampler2D rsm_flux;
#ifdef ATOMIC_INT
layout(set = 0, binding = 4, std430) buffer Grid { int v[]; } G;
#else
layout(set = 0, binding = 4, std430) buffer Grid { float v[]; } G;
#endif
layout(set = 0, binding = 5, std430) buffer Stats { uint overflows; uint injected; } S;

// Wrapped sums this invocation saw, counted once at the end: llvmpipe runs an atomic as a loop
// over the lanes even where the mask leaves none, so one per add cost as much as the add.
uint overflows = 0u;
#ifdef ATOMIC_INT
void add(uint i, float x) {
    float scaled = x * L.params.y;
    int q = (L.dims.w & 2u) != 0u ? int(scaled) : int(round(scaled));
    if (q == 0) return;
    int old = atomicAdd(G.v[i], q);
    // Two's-complement wrap: the sum's sign differs from both operands'. The sum is formed in
    // uint, where wrapping is defined (a compiler may assume signed adds never overflow).
    int sum = int(uint(old) + uint(q));
    if (((old ^ sum) & (q ^ sum)) < 0) overflows++;
}
#else
void add(uint i, float x) { if (x != 0.0) atomicAdd(G.v[i], x); }
#endif

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(t, ivec2(L.dims.z)))) return;
    vec4 p = texelFetch(rsm_position, t, 0);
    if (p.w <= 0.0) return;  // no surface in this texel
    vec3 n, flux;
    if (!vpl(texelFetch(rsm_normal, t, 0), texelFetch(rsm_flux, t, 0).rgb, n, flux)) return;
    vec4 lobe = sh_cosine_lobe(n) / PI;
    bool injected = false;  // into the finest cascade (the statistics' count)
    for (uint c = 0u; c < L.dims.y; ++c) {
        ivec3 cell = vpl_cell(c, p.xyz, n);
        if (!in_grid(cell)) continue;
        uint cl = cell_linear(cell);
        for (uint ch = 0u; ch < 3u; ++ch) {
            for (uint k = 0u; k < 4u; ++k) add(light_index(c, ch * 4u + k, cl), flux[ch] * lobe[k]);
        }
        injected = injected || c == 0u;
    }
    if (injected) atomicAdd(S.injected, 1u);
    if (overflows > 0u) atomicAdd(S.overflows, overflows);
}
