#version 460
// Graph test: raster pass sampling the previous pass's output: out = texel + add.
layout(set = 0, binding = 0) uniform usampler2D src;
layout(push_constant) uniform Push { uint add; } pc;
layout(location = 0) out uint o_value;
void main() { o_value = texelFetch(src, ivec2(gl_FragCoord.xy), 0).x + pc.add; }
