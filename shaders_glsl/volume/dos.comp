#version 460
// Directional occlusion shading (Schott et al. 2009), headlight variant as in the paper: the
// volume is cut into slices perpendicular to the view axis and composited front to back; an
// occlusion buffer travels with the slices, and each slice reads the previous slice's buffer
// averaged over a disk of radius Δz·tan(angle) (the cone of occlusion towards the light at the
// eye), shades its emission by (1 - occlusion), then adds its own opacity to the buffer.
// One dispatch per slice: the disk reads neighbouring pixels of the previous slice, which needs
// a device-wide barrier between slices, and only the frame graph issues barriers.
// DEPTH_OUT: the slice in which a pixel's accumulated opacity reaches the threshold writes its
// depth (depth.glsl, solved inside the slice's segment along the ray); init writes "miss".
#ifdef INIT
// Resets the compositing state (C = 0, T = 1) and the first occlusion buffer (0).
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform writeonly image2D accum;
layout(set = 0, binding = 1, r32f) uniform writeonly image2D occ_out;
#ifdef DEPTH_OUT
layout(set = 0, binding = 2, rgba32f) uniform writeonly image2D depth_img;
#endif
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(accum)))) return;
    imageStore(accum, p, vec4(0.0, 0.0, 0.0, 1.0));
    imageStore(occ_out, p, vec4(0.0));
#ifdef DEPTH_OUT
    imageStore(depth_img, p, vec4(-1.0, 1.0, 0.0, 0.0));  // depth_texel's miss
#endif
}
#else
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform image2D accum;  // rgb = C, a = T
layout(set = 0, binding = 4) uniform sampler3D gradient_tex;
layout(set = 0, binding = 5) uniform sampler2D occ_in;
layout(set = 0, binding = 6, r32f) uniform writeonly image2D occ_out;
layout(push_constant) uniform Push {
    vec4 slab;     // x: plane coordinate (along forward) of slice 0's front, y: Δz, z/w: pixel size = z + w·(view depth)
    vec4 forward;  // xyz: view axis, w: tan(cone angle)
    vec4 misc;     // x: eye's plane coordinate, y: slice index, z: 1 on the last slice, w: 1 - depth threshold
} S;
#ifdef DEPTH_OUT
#include "depth.glsl"
layout(set = 0, binding = 7, rgba32f) uniform writeonly image2D depth_img;
#endif

// Disk kernel: the centre and two rings (radius 1/2 and 1, relative), equal weight per tap.
const int TAPS = 13;
const vec2 KERNEL[TAPS] = vec2[](
    vec2(0.0, 0.0),
    vec2(0.5, 0.0), vec2(0.0, 0.5), vec2(-0.5, 0.0), vec2(0.0, -0.5),
    vec2(1.0, 0.0), vec2(0.7071, 0.7071), vec2(0.0, 1.0), vec2(-0.7071, 0.7071),
    vec2(-1.0, 0.0), vec2(-0.7071, -0.7071), vec2(0.0, -1.0), vec2(0.7071, -0.7071));

void main() {
    load_params();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(accum);
    if (any(greaterThanEqual(p, size))) return;
    Ray r = camera_ray(p, size);
    vec3 f = S.forward.xyz;
    float dz = S.slab.y;
    float zk = S.slab.x + (S.misc.y + 0.5) * dz;
    // Occlusion arriving from the previous slice over the cone's footprint, in pixels.
    float pixel = S.slab.z + S.slab.w * max(zk - S.misc.x, 0.0);
    float radius_px = dz * S.forward.w / max(pixel, 1e-12);
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    float occ = 0.0;
    for (int i = 0; i < TAPS; ++i) occ += texture(occ_in, uv + KERNEL[i] * radius_px / vec2(size)).r;
    occ /= float(TAPS);

    vec4 acc = imageLoad(accum, p);
    float cosine = dot(r.d, f);
    float t = (zk - dot(r.o, f)) / cosine;
    float alpha = 0.0;
    vec3 x = r.o + r.d * t;
    vec3 uvw = to_tex(x);
    if (t >= 0.0 && all(greaterThanEqual(uvw, vec3(0.0))) && all(lessThanEqual(uvw, vec3(1.0))) && clip_keeps(x)) {
        vec4 at = lookup_at(uvw);
        vec4 m = label_medium(transfer(sample_volume_at(uvw, at), TF_GRADIENT ? sample_gradient_from(uvw, at) : 0.0), uvw);
        // The slice is Δz thick along the view axis, Δz / cos along this ray.
        alpha = 1.0 - exp(-m.a * dz / cosine);
#ifdef DEPTH_OUT
        // Transmittance falls monotonically, so exactly one slice sees it cross the target.
        float h = 0.5 * dz / cosine;
        float depth = -1.0;
        if (acc.a > S.misc.w) depth_segment(depth, acc.a, m.a, t - h, t + h, S.misc.w);
        if (depth >= 0.0) imageStore(depth_img, p, depth_texel(r, depth));
#endif
        acc.rgb += acc.a * m.rgb * alpha * (1.0 - occ);
        acc.a *= 1.0 - alpha;
    }
    imageStore(occ_out, p, vec4(occ + (1.0 - occ) * alpha));
    if (S.misc.z > 0.5) acc = vec4(acc.rgb + acc.a * P.background.rgb, 1.0);
    imageStore(accum, p, acc);
}
#endif
