#version 460
// Fixed point → float after integer injection.
#include "common.glsl"
layout(local_size_x = 64) in;
layout(set = 0, binding = 1, std430) readonly buffer Fixed { int v[]; } I;
layout(set = 0, binding = 2, std430) writeonly buffer Grid { float v[]; } G;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= cells() * 12u * L.dims.y) return;
    G.v[i] = float(I.v[i]) * L.params.z;
}
