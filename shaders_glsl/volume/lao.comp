#version 460
// Local ambient occlusion (Hernell, Ljung, Ynnerman 2010 style): emission–absorption ray
// marching as eam.comp (same segment lattice and opacity 1 - exp(-σ ds)), where each sample's
// emission is scaled by the fraction of ambient light reaching it from within `radius`: the mean
// over a fixed set of `dirs` directions (a Fibonacci sphere, the same for every sample, so the
// image has no noise) of exp(-∫σ) along a short ray of `steps` midpoint samples. Outside the
// volume's box the medium is empty (the clamped texture would otherwise repeat the border).
//
// LAO_LIGHT adds a spherical light (vpt's LAORenderer has "soft shadows" from a light of radius
// `lightRadious`; ours is a physical reading of that, see docs/volume-rendering.md): each sample's
// emission is scaled by `ambient · A(x) + intensity · V(x)`, where V is the light's visibility, the
// mean transmittance of `light_samples` shadow rays over the cone the sphere subtends at x, at
// directions stratified in solid angle (cos θ uniform in [cos θmax, 1] in equal strata,
// golden-angle azimuths) = points on the sphere's visible cap weighted by the solid angle they
// cover, which is the fraction of a uniformly bright sphere's light that reaches x. Each shadow ray
// ends on the sphere and is marched over its part inside the box with the camera ray's segment
// length and midpoint samples. Radius 0 is one ray to the centre: a hard shadow.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
// Between the dispatches of one frame the HDR texel carries the march's state: (colour, T).
layout(set = 0, binding = 3, rgba32f) uniform image2D hdr;
layout(set = 0, binding = 4) uniform sampler3D gradient_tex;
layout(push_constant) uniform Push {
    // Samples [first, first + count) of each camera ray; a ray's first dispatch starts the march,
    // its last (`last` != 0) adds the background. Splitting a ray over dispatches bounds the loop
    // iterations of each (llvmpipe stops a SIMD row's loops at 65,535) and leaves the arithmetic
    // unchanged: the state is carried exactly.
    uint first;
    uint count;
    uint last;
    uint pad0;
    float radius;  // world units
    uint dirs;
    uint steps;
    float target;  // 1 - depth threshold (DEPTH_OUT)
#ifdef LAO_LIGHT
    vec4 light;        // xyz: centre (world), w: radius (world, >= 0)
    float intensity;   // light factor at full visibility
    uint light_samples;
    float ambient;     // weight of the ambient-occlusion term
    float pad;
#endif
} L;
#ifdef DEPTH_OUT
#include "depth.glsl"
layout(set = 0, binding = 5, rgba32f) uniform image2D depth_img;
#endif

vec4 medium(vec3 uvw) {
    vec4 at = lookup_at(uvw);
    return label_medium(transfer(sample_volume_at(uvw, at), TF_GRADIENT ? sample_gradient_from(uvw, at) : 0.0), uvw);
}

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

#ifdef LAO_LIGHT
// Transmittance along x + d·[0, len], clipped to the box, with segments of the march step.
float shadow_transmittance(vec3 x, vec3 d, float len) {
    Ray s;
    s.o = x;
    s.d = d;
    vec2 t = volume_interval(s);
    float t1 = min(t.y, len);
    if (!(t.x < t1)) return 1.0;
    float ds = P.box_min.w;
    int n = int(ceil((t1 - t.x) / ds));
    float tau = 0.0;
    for (int k = 0; k < n; ++k) {
        float a = t.x + float(k) * ds;
        float b = min(a + ds, t1);
        tau += medium(to_tex(x + d * (0.5 * (a + b)))).a * (b - a);
    }
    return exp(-tau);
}

// Visibility of the spherical light from x: see the header.
float light_visibility(vec3 x) {
    vec3 to_light = L.light.xyz - x;
    float dist = length(to_light);
    float r = L.light.w;
    if (dist <= r) return 1.0;  // inside the light: nothing between
    vec3 w = to_light / dist;
    if (r <= 0.0) return shadow_transmittance(x, w, dist);
    float cos_max = sqrt(max(0.0, 1.0 - (r / dist) * (r / dist)));
    // Orthonormal basis around w (Duff et al. 2017).
    float sgn = w.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + w.z);
    float b = w.x * w.y * a;
    vec3 u = vec3(1.0 + sgn * w.x * w.x * a, sgn * b, -sgn * w.x);
    vec3 v = vec3(b, sgn + w.y * w.y * a, -w.y);
    float c = dist * dist - r * r;
    uint n = L.light_samples;
    float sum = 0.0;
    for (uint i = 0u; i < n; ++i) {
        float cos_t = 1.0 - (1.0 - cos_max) * (float(i) + 0.5) / float(n);
        float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
        float phi = 2.39996322972865332 * float(i);
        vec3 d = u * (sin_t * cos(phi)) + v * (sin_t * sin(phi)) + w * cos_t;
        // Nearest intersection with the sphere (d lies inside its cone, so it exists).
        float bd = dot(to_light, d);
        sum += shadow_transmittance(x, d, bd - sqrt(max(bd * bd - c, 0.0)));
    }
    return sum / float(n);
}

float light_factor(vec3 x) {
    float f = L.intensity > 0.0 ? L.intensity * light_visibility(x) : 0.0;
    return L.ambient > 0.0 ? f + L.ambient * ambient(x) : f;
}
#else
float light_factor(vec3 x) { return ambient(x); }
#endif

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
    if (L.first > 0u) {
        vec4 state = imageLoad(hdr, p);
        color = state.rgb;
        T = state.a;
#ifdef DEPTH_OUT
        depth = imageLoad(depth_img, p).r;  // depth_texel's distance, -1 before a crossing
#endif
    }
#ifdef DEPTH_OUT
    bool done = T < P.light_dir.w && depth >= 0.0;
#else
    bool done = T < P.light_dir.w;
#endif
    if (t.x < t.y && !done) {
        float ds = P.box_min.w;
        int n = min(int(ceil((t.y - t.x) / ds)), int(L.first + L.count));
        for (int k = int(L.first); k < n; ++k) {
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
            color += T * m.rgb * alpha * light_factor(x);
            T *= 1.0 - alpha;
#ifdef DEPTH_OUT
            if (T < P.light_dir.w && depth >= 0.0) break;
#else
            if (T < P.light_dir.w) break;
#endif
        }
    }
    imageStore(hdr, p, L.last != 0u ? vec4(color + T * P.background.rgb, 1.0) : vec4(color, T));
#ifdef DEPTH_OUT
    imageStore(depth_img, p, depth_texel(r, depth));
#endif
}
