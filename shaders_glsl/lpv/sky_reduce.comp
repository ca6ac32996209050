#version 460
// Sky light: the height map reduced to one texel per cell of the coarsest cascade, keeping the
// nearest depth (the highest surface) of each block, so marching it cell by cell cannot step
// over a wall thinner than a cell.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) uniform sampler2D height;
layout(set = 0, binding = 1, r32f) uniform writeonly image2D reduced;

void main() {
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(reduced);
    if (any(greaterThanEqual(t, size))) return;
    int k = textureSize(height, 0).x / size.x;
    float d = 1.0;
    for (int y = 0; y < k; ++y) {
        for (int x = 0; x < k; ++x) d = min(d, texelFetch(height, t * k + ivec2(x, y), 0).r);
    }
    imageStore(reduced, t, vec4(d));
}
