#ifndef PROFILE_COMMON_GLSL
#define PROFILE_COMMON_GLSL
// Shared by the device-limit micro-benchmarks. demos/src/limits/cpu.rs mirrors every constant
// and function here on the CPU, so tests can check each kernel's output exactly.
#include "../common/hash.glsl"

// Buffer kernels: invocations per workgroup and vec4s each invocation reads or writes.
#define WG 64
const uint ITEMS = 32u;
// Storage-image kernels: texels along z each invocation covers.
const uint ZITEMS = 16u;
// Texture kernel: trilinear fetches per invocation.
const uint TEXTURE_FETCHES = 8u;

// Element k of this invocation: each workgroup owns one contiguous block of WG·ITEMS vec4s and
// at every step consecutive invocations touch consecutive vec4s (coalesced on GPUs; on a CPU
// driver one thread streams through one cache-friendly block).
uint block_index(uint k) { return gl_WorkGroupID.x * (uint(WG) * ITEMS) + k * uint(WG) + gl_LocalInvocationID.x; }

// What the write kernels store at element i: distinct per element and exact in f32 for any i.
vec4 pattern(uint i) { return vec4(float(i & 0xFFFu), float((i >> 12) & 0xFFFu), float(i >> 24), 1.0); }
#endif
