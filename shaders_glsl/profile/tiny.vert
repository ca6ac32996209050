#version 460
// Draw overhead: draw i (firstInstance = i) puts one point on pixel i of a width-wide target.
layout(push_constant) uniform Push { uint width; uint height; } pc;
layout(location = 0) flat out uint v_id;

void main() {
    uint i = uint(gl_InstanceIndex);
    vec2 px = vec2(float(i % pc.width), float(i / pc.width)) + 0.5;
    gl_Position = vec4(px / vec2(float(pc.width), float(pc.height)) * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = 1.0;
    v_id = i;
}
