#version 460
// Monte Carlo's progressive mean, post/accumulate.comp's recurrence m_n = m_{n-1} + (x_n - m_{n-1}) / n
// with each pixel's own path count n, and beside it the pixel's second moment by Welford's
// update: moments = (M2.rgb, n), M2 = Σ (x_i - m_n)² over its n paths, so the variance of its
// mean is M2 / (n (n - 1)). Without adaptive sampling every pixel's n is the frame count, so
// the mean is post/accumulate.comp's to the bit. With it (pc.adaptive, from a mean's second frame
// on), the pixels of a stopped half tile keep both: mc.comp traced no path there.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D frame;
layout(set = 0, binding = 1, rgba32f) uniform image2D accum;
layout(set = 0, binding = 2, rgba32f) uniform image2D moments;
#define TILES_BINDING 3
#define TILES_ACCESS readonly
#include "mc_tiles.glsl"
layout(push_constant) uniform Push { uint n; uint adaptive; } pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(accum)))) return;
    if (pc.adaptive != 0u && tile_weight(p) <= 0.0) return;
    vec4 x = imageLoad(frame, p);
    if (pc.n <= 1u) {
        imageStore(accum, p, x);
        imageStore(moments, p, vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    vec4 m = imageLoad(accum, p);
    vec4 s = imageLoad(moments, p);
    float n = s.a + 1.0;  // exact: counts stay far below 2^24
    vec4 next = m + (x - m) / n;
    imageStore(accum, p, next);
    imageStore(moments, p, vec4(s.rgb + (x.rgb - m.rgb) * (x.rgb - next.rgb), n));
}
