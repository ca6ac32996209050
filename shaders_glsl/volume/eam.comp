#version 460
// Emission–absorption ray marching (REFERENCE.md): segments of length ds on a lattice fixed by
// the ray's entry point, opacity a = 1 - exp(-σ ds) so the result does not depend on the step
// count, front to back with early termination at transmittance ε (BACK_TO_FRONT: the reverse
// recurrence, for testing). Empty-space skipping jumps whole segments inside blocks whose
// transfer-function extinction is zero, so it changes no sample.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D hdr;
layout(set = 0, binding = 4) uniform usampler3D occupancy;
#include "skip.glsl"
#include "temperature.glsl"
// With a temperature grid and `emission` S > 0, EAM's colour (the emission per unit extinction of
// the emission–absorption model) is the medium's emission as the Monte Carlo renderers define it,
// S × the blackbody radiance at the point's temperature, so EAM shows a fire as an absorbing
// Monte Carlo render of it does. A constant: without, EAM fetches nothing more.
layout(constant_id = 1) const bool TEMPERATURE = false;
#ifdef GRADIENT_TEXTURE
// Precomputed |∇v| per voxel (same central differences, value change per voxel), trilinearly
// filtered: one fetch instead of six, at the cost of interpolating magnitudes.
layout(set = 0, binding = 5) uniform sampler3D gradient_tex;
float gradient_magnitude(vec3 uvw, vec4 at) { return sample_gradient_at(uvw, at); }
#else
float gradient_magnitude(vec3 uvw, vec4 at) { return length(gradient(uvw)); }
#endif
#ifdef DEPTH_OUT
#include "depth.glsl"
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D depth_img;
layout(push_constant) uniform Push { float target; } D;  // 1 - depth threshold
#endif

// The segment of length `len` sampled at its midpoint `uvw` (atlas coordinates `at`, sparse).
vec4 segment_at(vec3 uvw, vec4 at, float len) {
    float v = sample_volume_at(uvw, at);
    float g = TF_GRADIENT ? gradient_magnitude(uvw, at) : 0.0;
    vec4 tf = label_medium(transfer(v, g), uvw);
    if (TEMPERATURE) tf.rgb = P.emission.x * blackbody_at(uvw, P.emission.zw);
    return vec4(tf.rgb, 1.0 - exp(-tf.a * len));
}

vec4 segment(Ray r, float a, float b) {
    vec3 uvw = to_tex(r.o + r.d * (0.5 * (a + b)));
    return segment_at(uvw, SPARSE ? atlas_uvw(uvw) : vec4(uvw, 0.0), b - a);
}

void main() {
    load_params();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr);
    if (any(greaterThanEqual(p, size))) return;
    Ray r = camera_ray(p, size);
    vec2 t = volume_interval(r);
    vec3 color = vec3(0.0);
    float T = 1.0;
#ifdef DEPTH_OUT
    float depth = -1.0;
#endif
    if (t.x < t.y) {
        float ds = P.box_min.w;
        int n = int(ceil((t.y - t.x) / ds));
#ifdef BACK_TO_FRONT
        for (int k = n - 1; k >= 0; --k) {
            vec4 s = segment(r, t.x + float(k) * ds, min(t.x + float(k + 1) * ds, t.y));
            color = s.rgb * s.a + (1.0 - s.a) * color;
            T *= 1.0 - s.a;
        }
#else
        bool ess = (P.flags.x & FLAG_ESS) != 0u;
        for (int k = 0; k < n; ++k) {
            float a = t.x + float(k) * ds;
            float b = min(a + ds, t.y);
            float t_exit;
            vec3 uvw = to_tex(r.o + r.d * (0.5 * (a + b)));
            vec4 at;
            bool empty = empty_at(r, uvw, ess, at, t_exit);
            if (empty) {
                // Segments whose midpoints lie before the block exit are all inside it.
                k = max(k, int(floor((t_exit - t.x) / ds - 0.5)));
                continue;
            }
            vec4 s = segment_at(uvw, at, b - a);
#ifdef DEPTH_OUT
            // Opacity -> extinction: -log(1 - a) / (b - a) is the segment's sigma; only until
            // the crossing is found, so later segments pay nothing for it.
            if (depth < 0.0 && T * (1.0 - s.a) <= D.target) {
                depth_segment(depth, T, -log(max(1.0 - s.a, 1e-30)) / max(b - a, 1e-30), a, b, D.target);
            }
#endif
            color += T * s.rgb * s.a;
            T *= 1.0 - s.a;
#ifdef DEPTH_OUT
            // Keep marching past the termination threshold until the depth threshold is found.
            if (T < P.light_dir.w && depth >= 0.0) break;
#else
            if (T < P.light_dir.w) break;
#endif
        }
#endif
    }
    imageStore(hdr, p, vec4(color + T * P.background.rgb, 1.0));
#ifdef DEPTH_OUT
    imageStore(depth_img, p, depth_texel(r, depth));
#endif
}
