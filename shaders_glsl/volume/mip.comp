#version 460
// Maximum intensity projection: the largest normalized value along each ray, as grey.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D hdr;
void main() {
    load_params();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr);
    if (any(greaterThanEqual(p, size))) return;
    Ray r = camera_ray(p, size);
    vec2 t = volume_interval(r);
    if (t.x >= t.y) { imageStore(hdr, p, vec4(P.background.rgb, 1.0)); return; }
    float step = P.box_min.w;
    float m = 0.0;
    for (float s = t.x + 0.5 * step; s < t.y; s += step) m = max(m, sample_volume(to_tex(r.o + r.d * s)));
    m = max(m, sample_volume(to_tex(r.o + r.d * t.y)));
    // Over the background, so the box itself does not show as a black silhouette.
    imageStore(hdr, p, vec4(max(vec3(m), P.background.rgb), 1.0));
}
