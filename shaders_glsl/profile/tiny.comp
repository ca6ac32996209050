#version 460
// Dispatch overhead: a one-invocation dispatch that stores a marker into the 4 bytes its
// descriptor covers (each dispatch gets its own range, so no two dispatches race).
// SIMD width: one invocation on purpose — it measures the cost of a dispatch, not of work.
layout(local_size_x = 1) in;
layout(set = 0, binding = 0, std430) writeonly buffer Slot { uint v; } slot;

void main() { slot.v = 0xD15Au; }
