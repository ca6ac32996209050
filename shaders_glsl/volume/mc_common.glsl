#ifndef VOLUME_MC_COMMON_GLSL
#define VOLUME_MC_COMMON_GLSL
// What both Monte Carlo path tracers share (mc.comp: one path per pixel per frame;
// mc_bounded.comp: persistent paths with a bounded number of steps per dispatch): the frame
// output, MIS, the environment map's lookup and sampling (ENV_MAP), hybrid scattering's
// Lambertian kernel (HYBRID), and the scattering kernel's value and pdf.
#include "tracking.glsl"
#include "phase.glsl"
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D frame_out;
const float PI = 3.14159265358979;

// Adaptive sampling (MC_FEATURES bit 6, set from a mean's second frame on): mc_adapt.comp's
// decision per half tile; a half of weight 0 traces nothing this frame.
#define TILES_BINDING 24
#define TILES_ACCESS readonly
#include "mc_tiles.glsl"
bool adaptive() { return mc_feature(6u); }

float power_heuristic(float a, float b) { return (a * a) / max(a * a + b * b, 1e-30); }

vec3 uniform_sphere(vec2 xi) {
    float z = 1.0 - 2.0 * xi.x;
    float s = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * xi.y;
    return vec3(s * cos(phi), s * sin(phi), z);
}

// Where a path segment after the camera's leaves the medium it sees: the clipped volume, or with
// `clip_shadows=on` (P.clip_count.y) the whole box, so the removed part still shadows and scatters.
float exit_distance(vec3 o, vec3 d) {
    Ray r = Ray(o, d);
    vec2 t = intersect_box(r, P.box_min.xyz, P.box_max.xyz);
    return P.clip_count.y != 0u ? t.y : clip_interval(r, t).y;
}

// Temperature-driven emission: the blackbody radiance over M.emission.zw kelvin (z = w = 0: none).
#include "temperature.glsl"

// Le at texture-space point `uvw` of colour c: S·c, or with a temperature grid S × the blackbody
// radiance at the point's temperature (nothing below the range, the hottest above it).
vec3 emitted(vec3 c, vec3 uvw) {
    if (M.emission.w <= 0.0) return M.emission.x * c;
    g_fetches += 2u;
    return M.emission.x * blackbody_at(uvw, M.emission.zw);
}

// A real collision at texture-space point `uvw` of a path of throughput β in medium `med`
// (albedo rgb, extinction): returns the albedo that multiplies β. Emissive media (`emission=S`,
// `albedo=F`, docs/volume-rendering.md): the medium emits σa·Le (Le: `emitted`) and scatters with
// albedo F·c, c the transfer function's colour, so σa = σt·(1 − F·c). Delta tracking's real
// collisions have density T(t)·σt(t) along the flight, so β·(σa/σt)·Le added at each has the
// expectation ∫ β T σa Le dt, the emission term of the radiative transfer equation: the
// collision estimator, unbiased. Collisions past the last scattering event add nothing (the
// next-flight walk samples none).
vec3 collide(vec4 med, vec3 uvw, inout vec3 L, vec3 beta) {
    if (!emissive()) return med.rgb;
    vec3 albedo = med.rgb * M.emission.y;
    L += beta * (1.0 - albedo) * emitted(med.rgb, uvw);
    return albedo;
}

#ifdef ENV_MAP
layout(set = 0, binding = 8) uniform sampler2D env_tex;  // rgb radiance; a: the texel's (u,v) pdf
// CDFs: the marginal over rows (h + 1 floats), then each row's conditional (w + 1 floats).
layout(set = 0, binding = 9, std430) readonly buffer EnvCdf { float cdf[]; } E;

// World ↔ map frame: the map is turned by M.env_map's angle about +Y (world = R_y(a) · map).
vec3 map_to_world(vec3 m) { return vec3(M.env_map.y * m.x + M.env_map.z * m.z, m.y, -M.env_map.z * m.x + M.env_map.y * m.z); }
vec3 world_to_map(vec3 w) { return vec3(M.env_map.y * w.x - M.env_map.z * w.z, w.y, M.env_map.z * w.x + M.env_map.y * w.z); }

// Radiance arriving from world direction d and the solid-angle pdf of env_sample drawing d.
vec3 env_lookup(vec3 d, out float pdf) {
    vec3 m = world_to_map(d);
    ivec2 size = textureSize(env_tex, 0);
    float phi = atan(m.z, m.x);
    if (phi < 0.0) phi += 2.0 * PI;
    float v = acos(clamp(m.y, -1.0, 1.0)) / PI;
    ivec2 ij = min(ivec2(vec2(min(phi / (2.0 * PI), 1.0), v) * vec2(size)), size - 1);
    vec4 t = texelFetch(env_tex, ij, 0);
    float s = length(m.xz);  // sin θ; acos near the poles would lose digits
    pdf = s > 0.0 ? t.a / (2.0 * PI * PI * s) : 0.0;
    return t.rgb * M.env_map.x;
}

// Largest i in [0, n-1] with cdf[base + i] <= xi (binary search; empty intervals are skipped
// because the largest such i is taken).
uint env_search(uint base, uint n, float xi) {
    uint lo = 0u, hi = n - 1u;
    while (lo < hi) {
        uint mid = (lo + hi + 1u) >> 1u;
        if (E.cdf[base + mid] <= xi) lo = mid; else hi = mid - 1u;
    }
    return lo;
}

float env_fraction(uint i, float xi) {
    float a = E.cdf[i], b = E.cdf[i + 1u];
    return b > a ? clamp((xi - a) / (b - a), 0.0, 0.99999994) : 0.5;
}

// Draws a world direction from the map's distribution; radiance and solid-angle pdf (0: skip).
vec3 env_sample(vec2 xi, out vec3 radiance, out float pdf) {
    ivec2 size = textureSize(env_tex, 0);
    uint w = uint(size.x), h = uint(size.y);
    uint y = env_search(0u, h, xi.x);
    float fy = env_fraction(y, xi.x);
    uint row = h + 1u + y * (w + 1u);
    uint x = env_search(row, w, xi.y);
    float fx = env_fraction(row + x, xi.y);
    float u = (float(x) + fx) / float(w), v = (float(y) + fy) / float(h);
    float st = sin(PI * v);
    vec3 m = vec3(st * cos(2.0 * PI * u), cos(PI * v), st * sin(2.0 * PI * u));
    vec4 t = texelFetch(env_tex, ivec2(x, y), 0);
    radiance = t.rgb * M.env_map.x;
    pdf = st > 0.0 ? t.a / (2.0 * PI * PI * st) : 0.0;
    return map_to_world(m);
}
#endif

#ifdef HYBRID
// Cosine-weighted direction about unit n (pdf cos/π): Lambert's kernel / pdf = 1.
vec3 cosine_hemisphere(vec3 n, vec2 xi, out float pdf) {
    float r = sqrt(xi.x), phi = 2.0 * PI * xi.y;
    float z = sqrt(max(0.0, 1.0 - xi.x));
    // Branchless orthonormal basis (Duff et al. 2017).
    float sg = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sg + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + sg * n.x * n.x * a, sg * b, -sg * n.x);
    vec3 bt = vec3(b, sg + n.y * n.y * a, -n.y);
    pdf = z / PI;
    return normalize(r * cos(phi) * t + r * sin(phi) * bt + z * n);
}
float lambert(vec3 n, vec3 l) { return max(dot(n, l), 0.0) / PI; }
// The chosen kernel's value (= its sampling pdf: both kernels are sampled exactly).
#define KERNEL_EVAL(l) (brdf ? lambert(nrm, l) : phase_eval(ph, dot(wi, l)))
#define KERNEL_PDF(l) (brdf ? lambert(nrm, l) : phase_pdf(ph, wi, l))
#else
#define KERNEL_EVAL(l) phase_eval(ph, dot(wi, l))
#define KERNEL_PDF(l) phase_pdf(ph, wi, l)
#endif

#endif
