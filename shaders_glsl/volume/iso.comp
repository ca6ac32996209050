#version 460
// Isosurface, pass 1: first crossing of the iso value along the ray, refined by bisection.
// Writes the hit position (texture space) and ray distance; w < 0 marks a miss.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D hit;
void main() {
    load_params();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hit);
    if (any(greaterThanEqual(p, size))) return;
    Ray r = camera_ray(p, size);
    vec2 t = volume_interval(r);
    float iso = P.box_max.w;
    vec4 result = vec4(0.0, 0.0, 0.0, -1.0);
    if (t.x < t.y) {
        // March for the first bracket [a, b] with v(a) < iso <= v(b), then bisect it.
        float step = P.box_min.w;
        int n = int(ceil((t.y - t.x) / step));
        float a = t.x, b = t.x;
        bool found = labelled_value(to_tex(r.o + r.d * t.x)) >= iso;
        for (int k = 1; k <= n && !found; ++k) {
            a = b;
            b = min(t.x + float(k) * step, t.y);
            found = labelled_value(to_tex(r.o + r.d * b)) >= iso;
        }
        if (found) {
            for (int i = 0; i < 12 && b > a; ++i) {
                float m = 0.5 * (a + b);
                if (labelled_value(to_tex(r.o + r.d * m)) >= iso) b = m; else a = m;
            }
            result = vec4(to_tex(r.o + r.d * b), b);
        }
    }
    imageStore(hit, p, result);
}
