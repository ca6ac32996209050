#version 460
// Storage-buffer write bandwidth: each invocation stores ITEMS vec4s of a known pattern.
#include "common.glsl"
layout(local_size_x = WG) in;
layout(set = 0, binding = 0, std430) writeonly buffer Dst { vec4 v[]; } dst;

void main() {
    for (uint k = 0u; k < ITEMS; ++k) {
        uint i = block_index(k);
        dst.v[i] = pattern(i);
    }
}
