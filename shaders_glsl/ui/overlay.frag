#version 460
// Blended in gamma space onto the tone-mapped (already sRGB-encoded) UNORM image, as egui's
// own gamma-framebuffer backends do; texture and vertex colours are both premultiplied.

layout(set = 0, binding = 0) uniform sampler2D tex;

layout(location = 0) in vec2 v_uv;
layout(location = 1) in vec4 v_color;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = v_color * texture(tex, v_uv);
}
