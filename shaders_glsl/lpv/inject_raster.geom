#version 460
// Routes each VPL point to its grid slice with gl_Layer; points outside the grid are dropped.
layout(points) in;
layout(points, max_vertices = 1) out;
layout(location = 0) flat in int v_layer[];
layout(location = 1) flat in vec4 v_r[];
layout(location = 2) flat in vec4 v_g[];
layout(location = 3) flat in vec4 v_b[];
layout(location = 0) flat out vec4 g_r;
layout(location = 1) flat out vec4 g_g;
layout(location = 2) flat out vec4 g_b;

void main() {
    if (v_layer[0] < 0) return;
    gl_Position = gl_in[0].gl_Position;
    gl_Layer = v_layer[0];
    g_r = v_r[0];
    g_g = v_g[0];
    g_b = v_b[0];
    EmitVertex();
    EndPrimitive();
}
