#version 460
// Storage-image write bandwidth (RGBA32F 3D, imageStore): each invocation stores a column of
// ZITEMS texels along z, texel (x, y, z) = pattern(its linear index).
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) writeonly uniform image3D dst;

void main() {
    ivec3 size = imageSize(dst);
    ivec3 base = ivec3(gl_GlobalInvocationID.xy, gl_GlobalInvocationID.z * ZITEMS);
    for (int k = 0; k < int(ZITEMS); ++k) {
        ivec3 p = base + ivec3(0, 0, k);
        imageStore(dst, p, pattern(uint(p.x + size.x * (p.y + size.y * p.z))));
    }
}
