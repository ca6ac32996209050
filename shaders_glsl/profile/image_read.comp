#version 460
// Storage-image read bandwidth (RGBA32F 3D, imageLoad): each invocation sums a column of
// ZITEMS texels along z and stores the sum (1/ZITEMS of the bytes read), so no load is dead.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) readonly uniform image3D src;
layout(set = 0, binding = 1, std430) writeonly buffer Dst { vec4 v[]; } dst;

void main() {
    ivec3 p = ivec3(gl_GlobalInvocationID.xy, gl_GlobalInvocationID.z * ZITEMS);
    vec4 a = vec4(0.0);
    vec4 b = vec4(0.0);
    for (int k = 0; k < int(ZITEMS); k += 2) {
        a += imageLoad(src, p + ivec3(0, 0, k));
        b += imageLoad(src, p + ivec3(0, 0, k + 1));
    }
    uvec3 n = gl_NumWorkGroups * gl_WorkGroupSize;
    uvec3 id = gl_GlobalInvocationID;
    dst.v[id.x + n.x * (id.y + n.y * id.z)] = a + b;
}
