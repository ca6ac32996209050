#version 460
// One invocation per 8×8 tile of a Monte Carlo image: the tile's part of the image's estimated
// relative error (mc_tiles.glsl). A pixel is foreground once its paths disagree: rays that miss
// the medium return the same radiance every time, as the background's do. Disagree means a
// variance per path above 1e-8 of the mean² (a relative spread of 1e-4): bounded work's mean
// is sum / n, which rounding keeps from equalling x exactly after n equal paths x, so its M2
// there is rounding noise of relative size about ε²·n (ε = 2^-24), under 1e-9 for n < 10^5,
// while a path's relative spread through a medium is orders of magnitude above 1e-4. The
// variance of the mean needs two paths; before that the tile's n_min says it is not ready.
// A loop over the tile's pixels rather than a workgroup reduction: llvmpipe pays for every
// barrier (a workgroup per tile with a shared-memory tree ran 5× the time of the accumulation).
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D accum;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D moments;
#define TILES_BINDING 2
#define TILES_ACCESS
#include "mc_tiles.glsl"
layout(push_constant) uniform Push { uint tiles_x; uint tiles_y; } pc;

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t >= pc.tiles_x * pc.tiles_y) return;
    ivec2 size = imageSize(accum);
    ivec2 origin = ivec2(t % pc.tiles_x, t / pc.tiles_x) * int(TILE);
    Half h[2];
    h[0] = Half(0.0, 0.0, 0.0, 0xffffffffu, 0u);
    h[1] = h[0];
    for (int k = 0; k < int(TILE * TILE); ++k) {  // 64 iterations
        ivec2 p = origin + ivec2(k % int(TILE), k / int(TILE));
        if (any(greaterThanEqual(p, size))) continue;
        uint i = tile_half(p);
        vec4 s = imageLoad(moments, p);
        h[i].n_min = min(h[i].n_min, uint(s.a));
        float m2 = s.r + s.g + s.b;
        vec3 m = imageLoad(accum, p).rgb;
        if (s.a >= 2.0 && m2 > 1e-8 * (s.a - 1.0) * dot(m, m)) {
            h[i].pvar += m2 / (s.a - 1.0);
            h[i].var += m2 / (s.a * (s.a - 1.0));
            h[i].sq += dot(m, m);
            h[i].fg += 1u;
        }
    }
    TS.t[t].h[0] = h[0];
    TS.t[t].h[1] = h[1];
    if (t == 0u) {
        TS.weight_sum = 0u;  // mc_adapt.comp adds this frame's weights next
        TS.tiles_x = pc.tiles_x;
        TS.tiles_y = pc.tiles_y;
    }
}
