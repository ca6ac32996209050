#ifndef VOLUME_TRACKING_GLSL
#define VOLUME_TRACKING_GLSL
// Free-flight sampling and transmittance through the volume (REFERENCE.md): delta (Woodcock)
// tracking, ratio tracking and residual ratio tracking, each walking the majorant grid by 3D DDA
// (or one segment with the global majorant). Exponential steps are memoryless, so restarting at
// each cell boundary with the next cell's majorant is unbiased.
#include "common.glsl"
#include "random.glsl"

// Per cell: (min, max) extinction as float bits; with SEGMENT_WORDS also the cell's (brick's)
// page-table word (common.glsl).
layout(set = 0, binding = 4) uniform usampler3D majorant_grid;
layout(set = 0, binding = 5) uniform sampler3D gradient_tex;
struct McData {
    vec4 sun_dir;       // xyz towards the sun; w > 0: sun on
    vec4 sun_radiance;  // rgb
    vec4 env_radiance;  // rgb; a: density scale
    uvec4 phase;        // kind, g, g2, w (floats as bits)
    uvec4 opts;         // x: max scattering events; y: bits: 1 camera-ray transmittance test mode,
                        // 2 view-ray estimate, 4 next-flight environment;
                        // z: 1 = majorant grid, 0 = global; w: shadow transmittance (0 delta, 1 ratio, 2 residual)
    vec4 global_majorant;  // x: max, y: min extinction over the volume; z: Russian-roulette start;
                           // w: majorant multiplier (1; below 1 only to prove violations are counted)
    vec4 point_pos;        // xyz world position; w > 0: point light on
    vec4 point_intensity;  // rgb radiant intensity (W/sr)
    vec4 env_map;   // x: intensity, y/z: cos/sin of the map's rotation about +Y, w: 1 = map on (ENV_MAP)
    vec4 hybrid;    // x: blend factor (0..1), y: 1 / max gradient magnitude (HYBRID)
    vec4 emission;  // x: emission scale S; y: albedo multiplier (`emissive()`)
};
// Read at `g_block` as P is (common.glsl explains).
layout(set = 0, binding = 6, std140) uniform Mc { McData m[1]; } MB;
#define M MB.m[g_block]
// fetches: filtered texel fetches, summed once per invocation (profiles report the renderer's
// fetch rate against the device's; wraps at 2³², the host takes per-frame differences).
layout(set = 0, binding = 7, std430) buffer Stats { uint violations; uint fetches; } S;
uint g_fetches = 0u;

// What the scene uses, folded when the pipeline is made: llvmpipe runs every branch not taken
// under a lane mask, so the code of a light that is off, of the phase functions and estimators
// not chosen, costs on every event or step unless a constant removes it. Bits (the host's
// `mc_features` in renderer.rs): 0 sun, 1 point light, 2 environment, 3 estimator test mode,
// 4 view-ray estimate, 5 next-flight environment (each still also checked at run time), 6
// adaptive sampling (mc_common.glsl), 7 emission or an albedo multiplier below 1 (`emissive()`);
// 8–9 majorant (0 global, 1 grid), 10–11 shadow estimator (0–2), 12–15 phase kind — a field of
// all ones takes M's value at run time. The default, all ones, decides everything at run time.
layout(constant_id = 1) const uint MC_FEATURES = 0xffffffffu;
bool mc_feature(uint bit) { return (MC_FEATURES & (1u << bit)) != 0u; }
uint mc_field(uint shift, uint mask, uint runtime) {
    uint v = (MC_FEATURES >> shift) & mask;
    return v == mask ? runtime : v;
}
bool sun_on() { return mc_feature(0u) && M.sun_dir.w > 0.0; }
bool point_on() { return mc_feature(1u) && M.point_pos.w > 0.0; }
bool emissive() { return mc_feature(7u) && (M.emission.x > 0.0 || M.emission.y != 1.0); }
bool test_mode() { return mc_feature(3u) && (M.opts.y & 1u) != 0u; }
bool grid_majorant() { return mc_field(8u, 3u, M.opts.z) != 0u; }
uint shadow_method() { return mc_field(10u, 3u, M.opts.w); }
uint phase_kind() { return mc_field(12u, 15u, M.phase.x); }

// What the trackers' per-step code needs of M, read once per invocation (common.glsl's `H`
// explains): the density scale, the grid majorants' scale and the global (min, max).
struct McHoisted { float density; float cell_scale; vec2 global_bounds; };
McHoisted HM;

// `load_params()` and `HM`: the first call of every Monte Carlo shader's main.
void load_mc_params() {
    load_params();
    HM.density = M.env_radiance.a;
    HM.cell_scale = M.env_radiance.a * M.global_majorant.w;
    HM.global_bounds = M.global_majorant.yx * M.global_majorant.w;
}

// (albedo rgb, extinction) at a texture-space point: filtered fetches of the volume, the gradient
// magnitude (if the transfer function uses it) and the transfer function; `at` where the value
// is read (`lookup_at`).
vec4 medium_at(vec3 uvw, vec4 at) {
    float g = 0.0;
    if (TF_GRADIENT) {
        g_fetches += 1u;
        g = sample_gradient_from(uvw, at);
    }
    g_fetches += 2u;
    vec4 tf = label_medium(transfer(sample_volume_at(uvw, at), g), uvw);
    return vec4(clamp(tf.rgb, 0.0, 1.0), tf.a * HM.density);
}
vec4 medium(vec3 uvw) { return medium_at(uvw, lookup_at(uvw)); }

// The majorant grid's (min, max) extinction of a cell, scaled as the medium is.
vec2 cell_bounds(ivec3 cell) {
    g_fetches += 1u;
    return uintBitsToFloat(texelFetch(majorant_grid, cell, 0).rg) * HM.cell_scale;
}

// `cell_bounds` and, with SEGMENT_WORDS, the cell's page-table word (one fetch).
vec2 cell_bounds_word(ivec3 cell, out uint word) {
    g_fetches += 1u;
    uvec4 c = texelFetch(majorant_grid, cell, 0);
    word = c.b;
    return uintBitsToFloat(c.rg) * HM.cell_scale;
}

// The one global (min, max) extinction (`majorant=global`).
vec2 global_bounds() { return HM.global_bounds; }

// Counts an extinction sample above its majorant: a bug in the grid, or majorant_scale < 1.
void check_majorant(float sigma, float majorant) {
    if (sigma > majorant * 1.0001) atomicAdd(S.violations, 1u);
}

// Ratio tracking's weight at a null collision, 1 − (σ − c)/(M − c) for the segment's majorant M
// (`maj`) and control c, written as (M − σ)/(M − c): a device may evaluate the textbook form as
// fma(−(σ − c), rcp(M − c), 1), which is −3e-8 where σ = M (a homogeneous medium: σ = 3 gives
// 3·rcp(3) = 1 + 2⁻²⁴), and those weights made whole pixels negative on an H200. M − σ is exact
// in sign for σ ≤ M on any IEEE device; above M (a violation, counted by check_majorant) the
// weight is 0 rather than negative, so every estimate stays in [0, 1] whatever the filter does.
float ratio_weight(float sigma, float c, float maj) { return max(maj - sigma, 0.0) / (maj - c); }

// Ratio tracking's Russian roulette: an estimate below RR_BELOW is ended with probability
// RR_KILL (and survivors divided by 1 - RR_KILL), which keeps dense media cheap without bias.
const float RR_BELOW = 0.05;
const float RR_KILL = 0.75;

// Segment words (common.glsl) with the majorant grid: the walk's cells are the bricks' sample
// regions, half a voxel above the grid's cells (whose majorants bound them too: each cell's value
// range is dilated by a voxel), and a tentative collision reads its slot from its segment.
bool segment_words() { return SEGMENT_WORDS && grid_majorant(); }
float walk_shift() { return segment_words() ? 0.5 / float(BRICK) : 0.0; }

// The axes along which a shifted walk in `cell` moving along `dir` has no next cell boundary.
// The shifted cells stop half a voxel inside the box's low faces, so a walk leaving the first
// cell along an axis stays in it there (its points are the clamped edge texels') until the box
// ends the walk; the last cells reach past the box.
bvec3 edge_axes(vec3 cell, vec3 dir) {
    uvec3 low = uvec3(lessThan(dir, vec3(0.0))) & uvec3(equal(cell, vec3(0.0)));
    uvec3 high = uvec3(greaterThan(dir, vec3(0.0))) & uvec3(equal(cell, H.grid - 1.0));
    return bvec3(low | high);
}

// A world ray in majorant-grid coordinates: origin in cells, and cells per world unit along d.
void grid_ray(vec3 o, vec3 d, out vec3 og, out vec3 dg) {
    vec3 scale = cells_per_tex();
    og = to_tex(o) * scale;
    dg = d / H.box_extent * scale;
}

// DDA state over the majorant grid, parameterized by the world-space ray distance t.
// With segment words, `brick` and `word` are the last segment's cell and its page-table word.
struct Walk { vec3 cell; vec3 step; vec3 t_next; vec3 t_delta; float t; float t_end; bool grid; vec3 brick; uint word; };

Walk walk_begin(Ray r, float t0, float t1) {
    Walk w;
    w.t = t0;
    w.t_end = t1;
    w.grid = grid_majorant();
    vec3 dims = H.grid;
    vec3 o, d;
    grid_ray(r.o, r.d, o, d);
    o -= walk_shift();
    w.cell = clamp(floor(o + d * t0), vec3(0.0), dims - 1.0);  // o, d already in cells
    w.brick = w.cell;
    w.word = 0u;
    w.step = sign(d);
    vec3 inv = 1.0 / d;
    // An axis the ray does not move along never has the next boundary (avoid 0·inf = NaN).
    bvec3 still = lessThan(abs(d), vec3(1e-20));
    if (segment_words()) still = bvec3(uvec3(still) | uvec3(edge_axes(w.cell, d)));
    w.t_next = mix(((w.cell + max(w.step, vec3(0.0))) - o) * inv, vec3(3.0e38), still);
    w.t_delta = mix(abs(inv), vec3(3.0e38), still);
    return w;
}

// Next segment [a, b] with its (min, max) extinction; false when the walk has ended.
bool walk_next(inout Walk w, out float a, out float b, out vec2 bounds) {
    if (w.t >= w.t_end) return false;
    a = w.t;
    if (!w.grid) {
        b = w.t_end;
        bounds = global_bounds();
        w.t = b;
        return true;
    }
    w.brick = w.cell;
    bounds = segment_words() ? cell_bounds_word(ivec3(w.cell), w.word) : cell_bounds(ivec3(w.cell));
    float t_exit = min(min(w.t_next.x, w.t_next.y), w.t_next.z);
    b = min(t_exit, w.t_end);
    // A start clamped into its cell may put that cell's exit behind it.
    if (segment_words()) b = max(b, a);
    if (w.t_next.x <= t_exit) { w.cell.x += w.step.x; w.t_next.x += w.t_delta.x; }
    else if (w.t_next.y <= t_exit) { w.cell.y += w.step.y; w.t_next.y += w.t_delta.y; }
    else { w.cell.z += w.step.z; w.t_next.z += w.t_delta.z; }
    w.t = b;
    bvec3 outside = bvec3(uvec3(lessThan(w.cell, vec3(0.0))) | uvec3(greaterThanEqual(w.cell, H.grid)));
    if (segment_words()) {
        // Shifted cells: the edge cell goes on along that axis (above).
        w.cell = clamp(w.cell, vec3(0.0), H.grid - 1.0);
        w.t_next = mix(w.t_next, vec3(3.0e38), outside);
    } else if (any(outside)) {
        // Leaving the grid ends the walk even if rounding left t slightly short of t_end.
        w.t = w.t_end;
    }
    return true;
}

// The medium at `uvw`, a point of the walk's last segment: its slot from the segment with
// segment words, else by a page lookup.
vec4 walk_medium(Walk w, vec3 uvw) {
    return segment_words() ? medium_at(uvw, atlas_in(uvw, w.brick, w.word)) : medium(uvw);
}

// Delta tracking: samples a real collision on [t0, t1]; returns false if the ray passes.
bool delta_track(Ray r, float t0, float t1, inout uint rng, out float t_hit, out vec4 med) {
    Walk w = walk_begin(r, t0, t1);
    float a, b;
    vec2 bounds;
    while (walk_next(w, a, b, bounds)) {
        float m = bounds.y;
        if (m <= 0.0) continue;  // empty cell: nothing can collide, skip it whole
        float t = a;
        for (;;) {
            t -= log(1.0 - rand01(rng)) / m;
            if (t >= b) break;
            vec4 mt = walk_medium(w, to_tex(r.o + r.d * t));
            check_majorant(mt.a, m);
            if (rand01(rng) * m < mt.a) {
                t_hit = t;
                med = mt;
                return true;
            }
        }
    }
    return false;
}

// Transmittance estimate on [t0, t1]: 0 delta tracking, 1 ratio tracking, 2 residual ratio
// tracking (control = the cell's minimum extinction, tracked against max - min). The control
// stays at the minimum so every weight 1 - (σ - c)/m lies in [0, 1] and the estimate is bounded
// by 1: a control at the cell midpoint halves the collisions but allows weights up to 2, whose
// products are heavy-tailed (measured: its mean had not converged after 1024 frames).
float transmittance(Ray r, float t0, float t1, uint method, inout uint rng) {
    if (method == 0u) {
        float th;
        vec4 med;
        return delta_track(r, t0, t1, rng, th, med) ? 0.0 : 1.0;
    }
    Walk w = walk_begin(r, t0, t1);
    float a, b;
    vec2 bounds;
    float T = 1.0;
    while (walk_next(w, a, b, bounds) && T > 0.0) {
        float c = method == 2u ? bounds.x : 0.0;
        float m = bounds.y - c;
        T *= exp(-c * (b - a));
        if (m <= 0.0) continue;
        float t = a;
        for (;;) {
            t -= log(1.0 - rand01(rng)) / m;
            if (t >= b) break;
            float s = walk_medium(w, to_tex(r.o + r.d * t)).a;
            check_majorant(s, bounds.y);
            T *= ratio_weight(s, c, bounds.y);
            if (T < RR_BELOW) {
                if (rand01(rng) < RR_KILL) { T = 0.0; break; }
                T /= 1.0 - RR_KILL;
            }
        }
    }
    return T;
}

// The next-flight walk: delta tracking of the ray's next collision and, at the same tentative
// points (one medium fetch serves both), ratio tracking of the transmittance T over the whole
// [t0, t1] — the estimate of the light that leaves the medium along this ray, which then need not
// be counted at the escape nor sampled by NEE. After the collision the walk goes on as the ratio
// tracker alone (residual from there with method 2), and it stops as soon as neither part is
// left. want_hit false: the transmittance only. Returns whether it collided (at t_hit, medium med).
// The collision and T are correlated, but each has its own tracker's expectation, so the sum of
// the path's terms is unbiased.
bool flight_track(Ray r, float t0, float t1, uint method, bool want_hit, inout uint rng, out float t_hit, out vec4 med, out float T) {
    Walk w = walk_begin(r, t0, t1);
    float a, b;
    vec2 bounds;
    bool looking = want_hit, hit = false;
    T = 1.0;
    t_hit = t1;
    med = vec4(0.0);
    while ((looking || T > 0.0) && walk_next(w, a, b, bounds)) {
        float t = a;
        for (;;) {
            float c = (!looking && method == 2u) ? bounds.x : 0.0;
            float m = bounds.y - c;
            float tn = m > 0.0 ? t - log(1.0 - rand01(rng)) / m : 3.0e38;
            T *= exp(-c * (min(tn, b) - t));
            if (tn >= b) break;
            t = tn;
            vec4 mt = walk_medium(w, to_tex(r.o + r.d * t));
            check_majorant(mt.a, bounds.y);
            if (looking && rand01(rng) * m < mt.a) {
                looking = false;
                hit = true;
                t_hit = t;
                med = mt;
            }
            if (T > 0.0) {
                T *= ratio_weight(mt.a, c, bounds.y);
                if (T < RR_BELOW) {
                    if (rand01(rng) < RR_KILL) T = 0.0;
                    else T /= 1.0 - RR_KILL;
                }
            }
            if (!looking && T <= 0.0) break;
        }
    }
    return hit;
}
#endif
