#version 460
// Maximum intensity projection: the largest normalized value along each ray, as grey.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D hdr;
// Keeps the larger of `m` and the labelled value at `uvw`, and the labels' colour where it is.
void labelled_max(vec3 uvw, inout float m, inout vec3 colour) {
    vec4 q = label_medium(vec4(1.0), uvw);
    float v = sample_volume(uvw) * q.a;
    colour = v > m ? q.rgb : colour;
    m = max(m, v);
}

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
    if (LABELS) {
        // The largest value scaled by the labels' opacity, coloured by the labels there; the
        // samples of the loop below.
        vec3 colour = vec3(1.0);
        for (float s = t.x + 0.5 * step; s < t.y; s += step) labelled_max(to_tex(r.o + r.d * s), m, colour);
        labelled_max(to_tex(r.o + r.d * t.y), m, colour);
        imageStore(hdr, p, vec4(max(m * colour, P.background.rgb), 1.0));
        return;
    }
    for (float s = t.x + 0.5 * step; s < t.y; s += step) m = max(m, sample_volume(to_tex(r.o + r.d * s)));
    m = max(m, sample_volume(to_tex(r.o + r.d * t.y)));
    // Over the background, so the box itself does not show as a black silhouette.
    imageStore(hdr, p, vec4(max(vec3(m), P.background.rgb), 1.0));
}
