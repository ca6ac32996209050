#version 460
// Depth-only draws of opaque materials (shadow tiles, the sky's height map): the position alone
// and no fragment stage, so llvmpipe shades and interpolates nothing per fragment and its depth
// test runs early; alpha-masked materials keep mesh.vert and shadow.frag for their discard.
#include "frame.glsl"
layout(location = 0) in vec3 in_pos;

void main() {
    gl_Position = view_matrix(D.view) * vec4(in_pos, 1.0);
}
