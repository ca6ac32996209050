#version 460
// Scatter propagation's accumulation: accum += this step's grid.
#include "common.glsl"
layout(local_size_x = 64) in;
layout(set = 0, binding = 1, std430) readonly buffer Step { float v[]; } S;
layout(set = 0, binding = 2, std430) buffer Accum { float v[]; } C;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= cells() * 12u * L.dims.y) return;
    C.v[i] += S.v[i];
}
