#version 460
// Test kernel for tests/phase.rs: checks the GLSL phase functions and RNG against the CPU twins.
// mode 0: invocation i (pixel (i % 256, i / 256), stream 0) draws xi = rand2, samples wo with
//   phase_sample and writes 12 floats: [mu = dot(wi,wo), phase_eval(mu), sampled pdf,
//   phase_pdf(wi,wo)], [wo, |wo|], [xi.x, xi.y, 0, 0].
// mode 1: writes u32_to_open01 of fixed edge-case words (then of pcg_hash(i)) into slot 0.
#include "../volume/phase.glsl"
#include "../volume/random.glsl"
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, std430) writeonly buffer Out { float values[]; };
layout(push_constant) uniform Push {
    Phase phase;
    uint count;
    uint frame;
    uint mode;
    uint pad;
    vec4 wi;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uint o = i * 12u;
    if (pc.mode == 1u) {
        // Extremes of the mapping: all-zero, all-one and just-below/above the 23-bit cut.
        uint words[6] = uint[6](0u, 0xFFFFFFFFu, 0xFFFFFE00u, 0x000001FFu, 0x80000000u, 0x7FFFFFFFu);
        uint x = i < 6u ? words[i] : pcg_hash(i);
        values[o] = u32_to_open01(x);
        for (uint k = 1u; k < 12u; ++k) values[o + k] = 0.0;
        return;
    }
    uint s = rng_state(uvec2(i % 256u, i / 256u), pc.frame, 0u);
    vec2 xi = rand2(s);
    vec3 wi = normalize(pc.wi.xyz);
    float pdf;
    vec3 wo = phase_sample(pc.phase, wi, xi, pdf);
    float mu = dot(wi, wo);
    values[o + 0u] = mu;
    values[o + 1u] = phase_eval(pc.phase, mu);
    values[o + 2u] = pdf;
    values[o + 3u] = phase_pdf(pc.phase, wi, wo);
    values[o + 4u] = wo.x;
    values[o + 5u] = wo.y;
    values[o + 6u] = wo.z;
    values[o + 7u] = length(wo);
    values[o + 8u] = xi.x;
    values[o + 9u] = xi.y;
    values[o + 10u] = 0.0;
    values[o + 11u] = 0.0;
}
