#version 460
// Accumulation test input: a reproducible value in [0, 2) per pixel and frame (CPU twin in tests).
#include "../common/hash.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform writeonly image2D frame;
layout(push_constant) uniform Push { uint frame_index; } pc;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(frame)))) return;
    uint h = pcg_hash(uint(p.x + 8 * p.y) + 64u * pc.frame_index);
    imageStore(frame, p, vec4(float(h) / 2147483648.0));
}
