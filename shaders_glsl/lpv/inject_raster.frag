#version 460
// Additive blending sums every VPL that lands in a cell (float blending, no atomics).
layout(location = 0) flat in vec4 g_r;
layout(location = 1) flat in vec4 g_g;
layout(location = 2) flat in vec4 g_b;
layout(location = 0) out vec4 out_r;
layout(location = 1) out vec4 out_g;
layout(location = 2) out vec4 out_b;

void main() {
    out_r = g_r;
    out_g = g_g;
    out_b = g_b;
}
