#version 460
// The volume's feature buffers (post/features.glsl) from the camera ray through each pixel's
// centre, once per view: a deterministic march of the Monte Carlo renderers' medium (the transfer
// function's albedo and extinction × density) in at most pc.max_steps steps of two voxels (at least the
// ray-march step), which finds where the transmittance first falls below ½ (solved inside the
// crossing step, as depth.glsl does), the gradient normal and albedo there, and the
// transmittance to the background. Rays that never fall below ½ take the expectation of their
// first collision instead: a thin cloud still gets a depth and an albedo the filter can compare.
// Blocks (bricks) whose extinction is zero under the transfer function are skipped whole, as EAM
// skips them: no step there changes anything.
#include "common.glsl"
#include "../post/features.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rg32ui) uniform writeonly uimage2D features;
layout(set = 0, binding = 4) uniform sampler3D gradient_tex;
layout(set = 0, binding = 5) uniform usampler3D occupancy;
#include "skip.glsl"
layout(push_constant) uniform Push { float density; uint tf_gradient; uint max_steps; uint pad; } pc;

vec4 medium_here(vec3 uvw, vec4 at) {
    float g = pc.tf_gradient != 0u ? sample_gradient_from(uvw, at) : 0.0;
    vec4 tf = label_medium(transfer(sample_volume_at(uvw, at), g), uvw);
    return vec4(clamp(tf.rgb, 0.0, 1.0), tf.a * pc.density);
}

void main() {
    load_params();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(features);
    if (any(greaterThanEqual(p, size))) return;
    Ray r = camera_ray_at(p, size, vec2(0.5));
    vec2 t = volume_interval(r);  // the renderers' interval: box and clipping
    float depth = -1.0, T = 1.0, sum_w = 0.0, sum_t = 0.0;
    vec3 albedo = vec3(0.0), sum_a = vec3(0.0);
    if (t.x < t.y) {
        float len = t.y - t.x;
        // Steps of two voxels (or the ray-march step, if longer): the crossing is solved inside
        // its step and edge-stopping needs no finer depth, so a quarter of a marcher's default
        // half-voxel steps suffices.
        vec3 voxel = H.box_extent / H.dims;
        float ds = max(P.box_min.w, 2.0 * min(voxel.x, min(voxel.y, voxel.z)));
        uint steps = clamp(uint(ceil(len / max(ds, 1e-6))), 1u, pc.max_steps);
        float dt = len / float(steps);
        for (uint i = 0u; i < pc.max_steps; ++i) {  // bounded: the host declares max_steps + 1
            if (i >= steps || T < 1e-3) break;
            float a = t.x + float(i) * dt;
            vec3 uvw = to_tex(r.o + r.d * (a + 0.5 * dt));
            vec4 at;
            float t_exit;
            bool empty = empty_at(r, uvw, true, at, t_exit);
            if (empty) {
                // Steps whose midpoints lie before the block's exit are all inside it.
                i = max(i, uint(max(floor((t_exit - t.x) / dt - 0.5), 0.0)));
                continue;
            }
            vec4 m = medium_here(uvw, at);
            float next = T * exp(-m.a * dt);
            float w = T - next;  // probability that the first collision lies in this step
            sum_w += w;
            sum_t += w * (a + 0.5 * dt);
            sum_a += w * m.rgb;
            if (depth < 0.0 && next <= 0.5) {
                depth = a + (m.a > 0.0 ? min(log(T / 0.5) / m.a, dt) : 0.0);
                albedo = m.rgb;
            }
            T = next;
        }
        if (T < 1e-3) T = 0.0;
    }
    if (depth < 0.0 && sum_w > 0.05) {
        depth = sum_t / sum_w;
        albedo = sum_a / sum_w;
    }
    vec3 n = -r.d;
    if (depth >= 0.0) {
        vec3 g = gradient(to_tex(r.o + r.d * depth));
        if (length(g) > 1e-6) n = dot(g, r.d) > 0.0 ? -normalize(g) : normalize(g);
    }
    imageStore(features, p, uvec4(pack_feature(Feature(depth, n, albedo, T)), 0u, 0u));
}
