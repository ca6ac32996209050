#version 460
// Smoke-test kernel: out[i] = (i * 7 + offset) * SCALE, so a readback can be checked exactly.
#include "../common/hash.glsl"
#ifndef SCALE
#define SCALE 1
#endif
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, std430) writeonly buffer Out { uint values[]; };
layout(push_constant) uniform Push { uint count; uint offset; uint hash_check; } pc;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    values[i] = pc.hash_check != 0u ? pcg_hash(i) : (i * 7u + pc.offset) * uint(SCALE);
}
