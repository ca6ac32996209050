#version 460
// The volume's feature buffers (post/features.glsl) from the camera ray through each pixel's
// centre, once per view: a deterministic march of the Monte Carlo renderers' medium (the transfer
// function's albedo and extinction × density), which finds where the transmittance first falls
// below ½ (solved inside the crossing step for the step's midpoint extinction, as depth.glsl
// does), the gradient normal and albedo there, and the transmittance to the background. Rays that
// never fall below ½ take the expectation of their first collision instead: a thin cloud still
// gets a depth and an albedo the filter can compare.
// Steps follow the majorant grid the Monte Carlo trackers walk: empty cells (largest extinction
// 0) are passed by cell lookups alone, and a step goes on through occupied cells until their
// majorant optical depth reaches TAU_STEP (but at least two voxels or the ray-march step, and no
// further than the next empty cell). Thin medium is crossed in a few long steps, dense medium
// ends the march within a few: one filtered sample per step.
#include "common.glsl"
#include "../post/features.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rg32ui) uniform writeonly uimage2D features;
layout(set = 0, binding = 4) uniform sampler3D gradient_tex;
// Per cell: (min, max) extinction of the transfer function over the cell's values, as float bits.
layout(set = 0, binding = 5) uniform usampler3D majorant_grid;
layout(push_constant) uniform Push { float density; uint max_steps; uint max_iterations; uint max_cells; } pc;

// Largest optical depth (under the cell's majorant) of one step: the midpoint rule's error in a
// step's transmittance stays small, and a crossing is still solved inside its step.
const float TAU_STEP = 0.5;
// Below 1/62 the 5-bit transmittance stores 0 and the ray has long crossed ½: nothing further
// changes the feature.
const float T_END = 1.0 / 64.0;

vec4 medium_here(vec3 uvw) {
    vec4 at = lookup_at(uvw);
    float g = TF_GRADIENT ? sample_gradient_from(uvw, at) : 0.0;
    vec4 tf = label_medium(transfer(sample_volume_at(uvw, at), g), uvw);
    return vec4(clamp(tf.rgb, 0.0, 1.0), tf.a * pc.density);
}

// The majorant-grid cell holding the ray point at distance `a`: its largest extinction (× density)
// and the ray's exit from it (never before `a`: every lookup moves on). `inv` is 1 / r.d.
float cell_exit(Ray r, vec3 inv, float a, out float sigma_max) {
    vec3 cell = clamp(floor(to_tex(r.o + r.d * a) * cells_per_tex()), vec3(0.0), H.grid - 1.0);
    sigma_max = uintBitsToFloat(texelFetch(majorant_grid, ivec3(cell), 0).g) * pc.density;
    vec3 t0 = (H.box_min + cell / cells_per_tex() * H.box_extent - r.o) * inv;
    vec3 t1 = (H.box_min + (cell + 1.0) / cells_per_tex() * H.box_extent - r.o) * inv;
    vec3 far = max(t0, t1);
    return max(min(far.x, min(far.y, far.z)), a);
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
        // Shortest step: two voxels (or the ray-march step, if longer; edge-stopping needs no
        // finer depth), and no more than pc.max_steps of them along the whole ray.
        vec3 voxel = H.box_extent / H.dims;
        float ds = max(max(P.box_min.w, 2.0 * min(voxel.x, min(voxel.y, voxel.z))), len / float(pc.max_steps));
        // Cells are looked up a little past where the ray is, so a point on a face finds the
        // cell the ray enters.
        float nudge = 1e-3 * ds;
        // An axis the ray does not move along never reaches a face (and 0·inf would be NaN).
        vec3 inv = mix(1.0 / r.d, vec3(3.0e38), lessThan(abs(r.d), vec3(1e-20)));
        float a = t.x;
        for (uint i = 0u; i < pc.max_iterations; ++i) {  // bounded: the host declares both loops
            if (a >= t.y || T < T_END) break;
            // One step [s, b]: past the empty cells from a (a filtered sample costs a row of
            // lanes the same wherever it lands, a cell lookup far less), then on through occupied
            // cells while their majorant optical depth stays under TAU_STEP (or the step under
            // ds), ending where an empty cell begins.
            float s = a, b = a, tau = 0.0;
            for (uint j = 0u; j < pc.max_cells; ++j) {
                if (b >= t.y) break;
                float sigma_max;
                float e = min(cell_exit(r, inv, min(b + nudge, t.y), sigma_max), t.y);
                if (sigma_max <= 0.0) {
                    if (b > s) break;
                    s = b = e;
                    continue;
                }
                float end = max(b + (TAU_STEP - tau) / sigma_max, s + ds);
                if (end < e) {
                    b = end;
                    break;
                }
                tau += sigma_max * (e - b);
                b = e;
            }
            a = b;
            if (b <= s) continue;  // nothing but empty cells (or the bound) up to here
            float dt = b - s;
            vec4 m = medium_here(to_tex(r.o + r.d * (s + 0.5 * dt)));
            float next = T * exp(-m.a * dt);
            float w = T - next;  // probability that the first collision lies in this step
            sum_w += w;
            sum_t += w * (s + 0.5 * dt);
            sum_a += w * m.rgb;
            if (depth < 0.0 && next <= 0.5) {
                depth = s + (m.a > 0.0 ? min(log(T / 0.5) / m.a, dt) : 0.0);
                albedo = m.rgb;
            }
            T = next;
        }
        if (T < T_END) T = 0.0;
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
