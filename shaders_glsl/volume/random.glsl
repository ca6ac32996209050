#ifndef VOLUME_RANDOM_GLSL
#define VOLUME_RANDOM_GLSL
// TEMPORARY (replaced by the phase-function work): per-pixel counter-based random numbers.
#include "../common/hash.glsl"
uint rng_state(uvec2 pixel, uint frame, uint stream) {
    return pcg_hash(pixel.x + pcg_hash(pixel.y + pcg_hash(frame + pcg_hash(stream))));
}
// xi in the open interval (0, 1): never exactly 0 or 1, so logs and divisions stay finite.
float rand01(inout uint s) {
    s = s * 747796405u + 2891336453u;
    uint x = pcg_hash(s);
    return (float(x >> 8) + 0.5) / 16777216.0;
}
vec2 rand2(inout uint s) { return vec2(rand01(s), rand01(s)); }
#endif
