#version 460
// 32-bit atomic-add throughput: invocation i adds 1 to counter i % addresses, per_invocation
// times. addresses = invocation count is uncontended (each its own address); a small count
// (64) is contended, the trade-off of atomic LPV injection. FLOAT: float atomics
// (GL_EXT_shader_atomic_float), otherwise uint.
#ifdef FLOAT
#extension GL_EXT_shader_atomic_float : enable
#endif
layout(local_size_x = 64) in;
layout(push_constant) uniform Push { uint addresses; uint per_invocation; } pc;
#ifdef FLOAT
layout(set = 0, binding = 0, std430) buffer Counters { float v[]; } c;
#define ONE 1.0
#else
layout(set = 0, binding = 0, std430) buffer Counters { uint v[]; } c;
#define ONE 1u
#endif

void main() {
    uint addr = gl_GlobalInvocationID.x % pc.addresses;
    for (uint k = 0u; k < pc.per_invocation; ++k) atomicAdd(c.v[addr], ONE);
}
