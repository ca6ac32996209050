#version 460
// Storage-buffer read bandwidth: each invocation sums ITEMS vec4 loads and stores the sum, so
// no load can be optimised away (the sums, 1/ITEMS of the bytes read, are checked by tests).
#include "common.glsl"
layout(local_size_x = WG) in;
layout(set = 0, binding = 0, std430) readonly buffer Src { vec4 v[]; } src;
layout(set = 0, binding = 1, std430) writeonly buffer Dst { vec4 v[]; } dst;

void main() {
    // Two independent sums, so the loads do not wait on one chain of adds.
    vec4 a = vec4(0.0);
    vec4 b = vec4(0.0);
    for (uint k = 0u; k < ITEMS; k += 2u) {
        a += src.v[block_index(k)];
        b += src.v[block_index(k + 1u)];
    }
    dst.v[gl_GlobalInvocationID.x] = a + b;
}
