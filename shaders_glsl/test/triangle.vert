#version 460
// Full-viewport triangle fixture: covers the left-bottom half of NDC so pixel tests know
// exactly which pixels are inside.
layout(location = 0) out vec3 v_color;
void main() {
    const vec2 pos[3] = vec2[](vec2(-1.0, -1.0), vec2(1.0, 1.0), vec2(-1.0, 1.0));
    gl_Position = vec4(pos[gl_VertexIndex], 0.0, 1.0);
    v_color = vec3(1.0, 0.5, 0.25);
}
