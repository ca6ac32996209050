#version 460
// Graph test: seed an r32ui image with x + 1000*y + base.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, r32ui) uniform writeonly uimage2D dst;
layout(push_constant) uniform Push { uint base; } pc;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(dst)))) return;
    imageStore(dst, p, uvec4(uint(p.x) + 1000u * uint(p.y) + pc.base));
}
