#version 460
// egui's tessellated meshes: positions in points, premultiplied sRGB vertex colours.

layout(location = 0) in vec2 in_pos;
layout(location = 1) in vec2 in_uv;
layout(location = 2) in vec4 in_color;

layout(push_constant) uniform Push {
    vec2 screen_points; // target size in points
} pc;

layout(location = 0) out vec2 v_uv;
layout(location = 1) out vec4 v_color;

void main() {
    v_uv = in_uv;
    v_color = in_color;
    gl_Position = vec4(2.0 * in_pos / pc.screen_points - 1.0, 0.0, 1.0);
}
