#version 460
// Isosurface, pass 1: first crossing of the iso value along the ray, refined by bisection.
// Writes the hit position (texture space) and ray distance; w < 0 marks a miss.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D hit;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hit);
    if (any(greaterThanEqual(p, size))) return;
    Ray r = camera_ray(p, size);
    vec2 t = intersect_box(r, P.box_min.xyz, P.box_max.xyz);
    float iso = P.box_max.w;
    vec4 result = vec4(0.0, 0.0, 0.0, -1.0);
    if (t.x < t.y) {
        float step = P.box_min.w;
        float prev_t = t.x;
        float prev_v = sample_volume(to_tex(r.o + r.d * prev_t));
        if (prev_v >= iso) {
            result = vec4(to_tex(r.o + r.d * prev_t), prev_t);
        } else {
            for (float s = t.x + step; prev_t < t.y; s += step) {
                float cur_t = min(s, t.y);
                float cur_v = sample_volume(to_tex(r.o + r.d * cur_t));
                if (cur_v >= iso) {
                    float a = prev_t, b = cur_t;
                    for (int i = 0; i < 12; ++i) {
                        float m = 0.5 * (a + b);
                        if (sample_volume(to_tex(r.o + r.d * m)) >= iso) b = m; else a = m;
                    }
                    result = vec4(to_tex(r.o + r.d * b), b);
                    break;
                }
                prev_t = cur_t;
            }
        }
    }
    imageStore(hit, p, result);
}
