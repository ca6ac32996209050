#ifndef VOLUME_RANDOM_GLSL
#define VOLUME_RANDOM_GLSL
// Per-pixel random streams for the path tracer. The seed is a chain of pcg_hash over
// (stream, frame, pixel.y, pixel.x), so every pixel, frame and stream (e.g. 0 = camera jitter,
// 1 = scattering, ...) starts at an unrelated point; each draw then advances a 32-bit PCG
// (LCG + RXS-M-XS output permutation, Jarzynski & Olano 2020), i.e. draw n of a stream is
// pcg_hash applied to the n-th LCG state. All seeds share one 2^32-long LCG cycle, so two streams
// can overlap only if their seeds land within a path's draw count of each other (rare, and then
// only shifted copies); a CPU twin lives in tests/phase.rs.
#include "../common/hash.glsl"

// Seed of the stream `stream` of `pixel` in `frame`.
uint rng_state(uvec2 pixel, uint frame, uint stream) {
    return pcg_hash(pixel.x + pcg_hash(pixel.y + pcg_hash(frame + pcg_hash(stream))));
}

// Next 32 random bits; advances the state by one LCG step.
uint rand_u32(inout uint s) {
    s = s * 747796405u + 2891336453u;
    uint word = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (word >> 22u) ^ word;
}

// Maps 32 random bits to the OPEN interval (0,1): (k + 0.5) / 2^23 with the top 23 bits k.
// 23 bits, not 24: (k + 0.5) needs one more mantissa bit than k, and with 24 bits the largest
// value (2^24 - 0.5) rounds to 2^24, i.e. xi = 1.0 exactly. Range: [2^-24, 1 - 2^-24], exact.
float u32_to_open01(uint x) {
    return (float(x >> 9u) + 0.5) * (1.0 / 8388608.0);
}

// Uniform xi in (0,1), never exactly 0 or 1 (so -log(xi), 1/xi and inverse CDFs stay finite).
float rand01(inout uint s) {
    return u32_to_open01(rand_u32(s));
}

// Two independent uniforms in (0,1).
vec2 rand2(inout uint s) {
    float a = rand01(s);
    return vec2(a, rand01(s));
}
#endif
