#version 460
// Full-viewport triangle fixture: covers the left-bottom half of NDC so pixel tests know
// exactly which pixels are inside.
layout(location = 0) out vec3 v_color;
void main() {
    const vec2 pos[3] = vec2[](vec2(-1.0, -1.0), vec2(1.0, 1.0), vec2(-1.0, 1.0));
    gl_Position = vec4(pos[gl_VertexIndex], 0.0, 1.0);
    // 0.4·255 = 102 and 0.2·255 = 51 are half a step from any rounding tie, so every conformant
    // UNORM conversion stores them exactly (0.5 is 127.5: the H200 stored 127, lavapipe 128).
    v_color = vec3(1.0, 0.4, 0.2);
}
