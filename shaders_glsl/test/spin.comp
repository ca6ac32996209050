#version 460
// Deliberately slow kernel for the GPU-timeout test: every invocation runs `iterations` steps of
// an LCG + xorshift chain and stores the result, so the work cannot be optimised away and the
// test can check it on the CPU. The caller keeps `iterations` under llvmpipe's 65,535 loop
// iterations per SIMD row (the loop is uniform, so a row counts it once) and makes the run long
// with many workgroups instead.
layout(local_size_x = 64) in;
layout(set = 0, binding = 0, std430) writeonly buffer Out { uint values[]; };
layout(push_constant) uniform Push { uint iterations; uint count; } pc;
void main() {
    uint i = gl_GlobalInvocationID.x;
    uint h = i;
    for (uint k = 0u; k < pc.iterations; ++k) {
        h = h * 1664525u + 1013904223u;
        h ^= h >> 16;
    }
    if (i < pc.count) values[i] = h;
}
