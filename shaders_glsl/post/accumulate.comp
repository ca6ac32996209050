#version 460
// Progressive mean in 32-bit float with an integer sample count (REFERENCE.md, "Accumulation"):
// m_n = m_{n-1} + (x_n - m_{n-1}) / n; n == 1 overwrites, which is how a reset happens.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D frame;
layout(set = 0, binding = 1, rgba32f) uniform image2D accum;
layout(push_constant) uniform Push { uint n; } pc;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(accum)))) return;
    vec4 x = imageLoad(frame, p);
    if (pc.n <= 1u) {
        imageStore(accum, p, x);
    } else {
        vec4 m = imageLoad(accum, p);
        imageStore(accum, p, m + (x - m) / float(pc.n));
    }
}
