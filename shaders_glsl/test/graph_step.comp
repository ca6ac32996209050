#version 460
// Graph test: dst = src * 3 + add (ping-pong step).
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, r32ui) uniform readonly uimage2D src;
layout(set = 0, binding = 1, r32ui) uniform writeonly uimage2D dst;
layout(push_constant) uniform Push { uint add; } pc;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(dst)))) return;
    imageStore(dst, p, uvec4(imageLoad(src, p).x * 3u + pc.add));
}
