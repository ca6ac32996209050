#version 460
// Depth-only passes (shadow tiles): only alpha-masked materials need a fragment stage.
#include "frame.glsl"
#include "material.glsl"
// The full interface of mesh.vert, so no vertex output goes unconsumed.
layout(location = 0) in vec3 v_pos;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) in vec4 v_tangent;

void main() {
    material_albedo(v_uv);
}
