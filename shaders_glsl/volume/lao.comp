#version 460
// Local ambient occlusion (Hernell, Ljung, Ynnerman 2010 style): emission–absorption ray
// marching as eam.comp (same segment lattice and opacity 1 - exp(-σ ds)), where each sample's
// emission is scaled by the fraction of ambient light reaching it from within `radius`: the mean
// over a fixed set of `dirs` directions (a Fibonacci sphere, the same for every sample, so the
// image has no noise) of exp(-∫σ) along a short ray of `steps` midpoint samples. Outside the
// volume's box the medium is empty (the clamped texture would otherwise repeat the border).
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D hdr;
layout(set = 0, binding = 4) uniform sampler3D gradient_tex;
layout(push_constant) uniform Push {
    float radius;  // world units
    uint dirs;
    uint steps;
    float target;  // 1 - depth threshold (DEPTH_OUT)
} L;
#ifdef DEPTH_OUT
#include "depth.glsl"
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D depth_img;
#endif

vec4 medium(vec3 uvw) { return transfer(sample_volume(uvw), texture(gradient_tex, uvw).r); }

float extinction_at(vec3 world) {
    vec3 uvw = to_tex(world);
    if (any(lessThan(uvw, vec3(0.0))) || any(greaterThan(uvw, vec3(1.0)))) return 0.0;
    return medium(uvw).a;
}

// Direction i of n on a Fibonacci sphere: equal-area, deterministic, no clustering at poles.
vec3 fibonacci_dir(uint i, uint n) {
    float z = 1.0 - (2.0 * float(i) + 1.0) / float(n);
    float rho = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.39996322972865332 * float(i);  // golden angle
    return vec3(rho * cos(phi), rho * sin(phi), z);
}

float ambient(vec3 x) {
    float h = L.radius / float(L.steps);
    float sum = 0.0;
    for (uint i = 0u; i < L.dirs; ++i) {
        vec3 d = fibonacci_dir(i, L.dirs);
        float tau = 0.0;
        for (uint j = 0u; j < L.steps; ++j) tau += extinction_at(x + d * (h * (float(j) + 0.5)));
        sum += exp(-tau * h);
    }
    return sum / float(L.dirs);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr);
    if (any(greaterThanEqual(p, size))) return;
    Ray r = camera_ray(p, size);
    vec2 t = intersect_box(r, P.box_min.xyz, P.box_max.xyz);
    vec3 color = vec3(0.0);
    float T = 1.0;
#ifdef DEPTH_OUT
    float depth = -1.0;
#endif
    if (t.x < t.y) {
        float ds = P.box_min.w;
        int n = int(ceil((t.y - t.x) / ds));
        for (int k = 0; k < n; ++k) {
            float a = t.x + float(k) * ds;
            float b = min(a + ds, t.y);
            vec3 x = r.o + r.d * (0.5 * (a + b));
            vec4 m = medium(to_tex(x));
            // Transparent samples add nothing: skip their occlusion rays (the dominant cost).
            if (m.a <= 0.0) continue;
            float alpha = 1.0 - exp(-m.a * (b - a));
#ifdef DEPTH_OUT
            if (depth < 0.0) depth_segment(depth, T, m.a, a, b, L.target);
#endif
            color += T * m.rgb * alpha * ambient(x);
            T *= 1.0 - alpha;
#ifdef DEPTH_OUT
            if (T < P.light_dir.w && depth >= 0.0) break;
#else
            if (T < P.light_dir.w) break;
#endif
        }
    }
    imageStore(hdr, p, vec4(color + T * P.background.rgb, 1.0));
#ifdef DEPTH_OUT
    imageStore(depth_img, p, depth_texel(r, depth));
#endif
}
