#version 460
// Gather injection, no atomics: each cell projects its box (grown by the VPL offset) into the
// RSM and sums the texels whose VPL lands in it. Every texel is read by the few cells its
// footprint covers, so the result equals scatter injection up to summation order.
// Bounded work: one dispatch reads at most one T.size² tile of the RSM (the host dispatches
// every tile in turn, the first writing the grid and the others adding to it), so a cell whose
// rectangle is the whole map — one straddling a spot light's apex reads every texel, 65,792 loop
// iterations at 256² — stays under llvmpipe's loop limit (engine/lpv/passes/mod.rs
// gather_loop_iterations is the worst case per SIMD row the pass declares).
#include "common.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits); y and z are scalar loops.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
layout(set = 0, binding = 1) uniform sampler2D rsm_position;
layout(set = 0, binding = 2) uniform sampler2D rsm_normal;
layout(set = 0, binding = 3) uniform sampler2D rsm_flux;
// Read-write (not images.glsl's write-only): every tile after the first adds to the grid.
layout(set = 0, binding = 4, rgba32f) uniform image3D dst_r;
layout(set = 0, binding = 5, rgba32f) uniform image3D dst_g;
layout(set = 0, binding = 6, rgba32f) uniform image3D dst_b;
// origin: the tile's first texel; size: its edge; accumulate: 0 for the first tile (write), 1 after.
layout(push_constant) uniform Tile { ivec2 origin; int size; uint accumulate; } T;

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    ivec3 cell = ivec3(id.x, id.y, id.z % n);
    float s = L.cascade[c].w;
    vec3 lo = L.cascade[c].xyz + vec3(cell) * s - vec3(L.params.x * s);
    vec3 hi = lo + vec3(s * (1.0 + 2.0 * L.params.x));
    // Texel rectangle covering the projected box.
    vec2 tmin = vec2(1e30), tmax = vec2(-1e30);
    bool behind = false;
    for (int i = 0; i < 8; ++i) {
        vec3 q = vec3((i & 1) != 0 ? hi.x : lo.x, (i & 2) != 0 ? hi.y : lo.y, (i & 4) != 0 ? hi.z : lo.z);
        vec4 clip = L.rsm_vp * vec4(q, 1.0);
        if (clip.w <= 1e-6) { behind = true; break; }
        vec2 uv = (clip.xy / clip.w) * 0.5 + 0.5;
        tmin = min(tmin, uv);
        tmax = max(tmax, uv);
    }
    float size = float(L.dims.z);
    ivec2 a = ivec2(floor(clamp(tmin, 0.0, 1.0) * size));
    ivec2 b = ivec2(ceil(clamp(tmax, 0.0, 1.0) * size));
    if (behind) { a = ivec2(0); b = ivec2(L.dims.z); }  // a cell straddling a spot's apex: all texels
    b = min(b, ivec2(L.dims.z));
    // This dispatch's tile only.
    a = max(a, T.origin);
    b = min(b, T.origin + ivec2(T.size));
    // A later tile that adds nothing to this cell leaves its texels as they are.
    if (T.accumulate != 0u && any(greaterThanEqual(a, b))) return;
    vec4 acc[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
    for (int y = a.y; y < b.y; ++y) {
        for (int x = a.x; x < b.x; ++x) {
            vec4 p = texelFetch(rsm_position, ivec2(x, y), 0);
            if (p.w <= 0.0) continue;
            vec3 nrm, flux;
            if (!vpl(texelFetch(rsm_normal, ivec2(x, y), 0), texelFetch(rsm_flux, ivec2(x, y), 0).rgb, nrm, flux)) continue;
            if (vpl_cell(c, p.xyz, nrm) != cell) continue;
            vec4 lobe = sh_cosine_lobe(nrm) / PI;
            acc[0] += flux.r * lobe;
            acc[1] += flux.g * lobe;
            acc[2] += flux.b * lobe;
        }
    }
    ivec3 t = ivec3(id);
    if (T.accumulate != 0u) {
        acc[0] += imageLoad(dst_r, t);
        acc[1] += imageLoad(dst_g, t);
        acc[2] += imageLoad(dst_b, t);
    }
    imageStore(dst_r, t, acc[0]);
    imageStore(dst_g, t, acc[1]);
    imageStore(dst_b, t, acc[2]);
}
