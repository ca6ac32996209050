#version 460
// Every raster pass of the mesh renderer draws the same vertices (world space, baked at load)
// from the view D.view selects: camera, a shadow tile or the RSM light.
#include "frame.glsl"
layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in vec4 in_tangent;
layout(location = 0) out vec3 v_pos;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;
layout(location = 3) out vec4 v_tangent;

void main() {
    v_pos = in_pos;
    v_normal = in_normal;
    v_uv = in_uv;
    v_tangent = in_tangent;
    gl_Position = view_matrix(D.view) * vec4(in_pos, 1.0);
}
