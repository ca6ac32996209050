#version 460
// Monte Carlo volume path tracing with bounded work per dispatch (the estimator of mc.comp,
// restructured as vpt does it): every pixel keeps one path in flight in a buffer, and each
// dispatch advances it by at most B.budget steps — a step is one free-flight or shadow-ray
// tracking step, or one event (scattering, light sample, escape, restart). A finished path adds
// its radiance to the pixel's sum and count and the next path starts at once, so no SIMD lane
// waits for the longest path of its row (lanes still wait for the row's longest walk in progress:
// the walk loop runs while any lane walks), and no dispatch can run unbounded at any density. A
// row stops for the frame once its pixels completed B.cap paths each on average and each of
// them at least one (or its budget), and a pixel after 4 × B.cap (main explains). Each
// completed path also updates the pixel's second moment (the `moments` image), and with
// adaptive sampling a stopped tile's pixels are not advanced.
// The frame output is the mean of the completed paths: a ratio estimator, biased by O(1/N) in
// the number N of completed paths (which paths have completed depends on their lengths).
//
// Path stages: a walk (FLIGHT: delta tracking along the path; SUN, POINT, ENV: the shadow
// ray's transmittance by the chosen estimator; VIEW: the same estimator along the camera ray,
// for the environment seen through the medium, before the path's FLIGHT walk — mc.comp's
// view-ray estimate) or an event between walks. Walks resume where
// the last dispatch left them: exponential steps are memoryless, so restarting one at the
// stored distance is the same tracker. The walk's majorant-grid cell is stored with it rather
// than re-derived from the position, which at a cell boundary could round back into the cell
// just left.
// Next-flight environment (`env_light=flight`, mc.comp explains): a FLIGHT walk then also
// ratio-tracks the transmittance to the box at its own tentative points; it records its collision
// (`hit_t`, the albedo applied to β at once) and walks on until the estimate ends, and ENV has
// no shadow walk.
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_vote : require
#include "mc_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

// One pixel's path (std430, 7 × 16 bytes; 8 with HYBRID). llvmpipe loads and stores a storage
// buffer one 32-bit word per lane at a time, so every word of the state costs twice a frame
// (about 0.45 ms per word at 512²): values that are never live together share a word.
struct PathState {
    vec4 o_t;       // walk origin (the scatter point while shadow rays run), distance along it
    vec4 d_end;     // walk direction, walk end
    vec4 beta_T;    // path throughput; the shadow walk's transmittance estimate so far
    vec4 L_rng;     // path radiance so far; random state (bits)
    vec4 pend_bits; // the shadow ray's contribution if unblocked; stage | bounce << 4 | brdf << 17 (bits)
    vec4 wi_cell;   // direction into the scatter point (while shadow rays run; in a FLIGHT or VIEW
                    // walk: x the pdf of the direction the path continued in, y the next-flight
                    // collision distance, < 0 none); the walk's majorant cell, 10 bits per axis
    vec4 sum;       // completed paths: radiance sum, count
#ifdef HYBRID
    vec4 nrm;       // hybrid scattering's normal (w unused)
#endif
};
#ifdef ENV_MAP
#define STATE_BINDING 10
#else
#define STATE_BINDING 8
#endif
layout(set = 0, binding = STATE_BINDING, std430) buffer Paths { PathState s[]; } PS;
// budget: steps per pixel and dispatch; reset: start every pixel afresh (first frame); cap:
// completed paths per pixel and dispatch on average over the row (main explains). Without the
// cap a row of pixels whose paths are short (rays through the box's empty parts) would spend its
// whole budget on thousands of them, where one path per frame costs such a row almost nothing.
// On the default cloud, at most 4 per frame measured 1.5–1.8× the efficiency of mc.comp; without
// a cap it was 0.6–0.8×.
// regroup: the percentage of a row's lanes with an ended walk at which the row stops walking
// and takes their events (main explains).
// interleave, subset: this dispatch advances only the 8×8 tiles of one subset (tiles() explains).
// max_budget: adaptive sampling's largest budget of a tile (main explains).
// Read at `g_block` as P is (common.glsl explains), once.
struct Push {
    uint budget; uint reset; uint cap; uint regroup; uint interleave; uint subset; uint max_budget;
};
layout(push_constant) uniform PushBlock { Push v[1]; } PC;
Push B;
// Each pixel's second moment beside its mean (mc_accumulate.comp explains): (M2.rgb, paths), M2
// by Welford's update as each path completes.
layout(set = 0, binding = 23, rgba32f) uniform image2D moments;

// The pixel of this invocation. Interleaved, the dispatch is 1/interleave as wide and each
// workgroup takes one tile of its row's subset: in tile row y the tiles x ≡ subset − 2y
// (mod interleave), a diagonal pattern, so that every frame refines the whole picture a little.
ivec2 pixel() {
    uvec2 tile = gl_WorkGroupID.xy;
    uint k = B.interleave;
    tile.x = tile.x * k + (B.subset + k - (2u * tile.y) % k) % k;
    return ivec2(tile * gl_WorkGroupSize.xy + gl_LocalInvocationID.xy);
}

// RESTART: the last camera ray missed the box; the next dispatch starts a new path.
const uint FLIGHT = 0u, SUN = 1u, POINT = 2u, ENV = 3u, CONTINUE = 4u, RESTART = 5u, VIEW = 6u;

// The path, in registers while the dispatch runs.
vec3 o, d, beta, L, pend, wi, nrm;
float t, t_end, T, prev_pdf;
uint rng, stage, bounce;
uvec3 cell;
bool brdf;
// Next-flight walk: where it collided (< 0: not yet).
float hit_t = -1.0;
vec4 sum;
vec3 m2;  // the completed paths' Σ (x − mean)², per channel
uint budget, cap;  // this pixel's steps and completed paths in this dispatch
bool stop;  // this pixel is done for this dispatch (its camera ray missed the box, or the cap)
// The walk's current segment (its cell's extinction bounds and exit), kept while the walk
// stays in the cell: null collisions then cost no majorant fetch and no exit computation.
bool seg_valid = false;
float seg_b;
vec2 seg_bounds;
int seg_axis;
uint seg_word;  // segment words (tracking.glsl): the cell's (brick's) page-table word
Phase ph;

// Any environment light at all (a map that is on, or a constant above 0).
bool has_env() {
#ifdef ENV_MAP
    return mc_feature(2u) && M.env_map.w > 0.0;
#else
    return mc_feature(2u) && any(greaterThan(M.env_radiance.rgb, vec3(0.0)));
#endif
}

// The next-flight environment is on: every FLIGHT walk estimates the environment along it.
bool flight_env() { return mc_feature(5u) && (M.opts.y & 4u) != 0u && has_env(); }

// A next-flight walk still samples its collision: none yet, and not the walk after the last
// scattering (bounce does not change during a walk).
bool looking() { return hit_t < 0.0 && bounce < M.opts.x; }

// Starts a walk along (origin, dir) over [t0, t1].
void walk_start(vec3 origin, vec3 dir, float t0, float t1) {
    o = origin;
    d = dir;
    t = t0;
    t_end = t1;
    seg_valid = false;
    cell = uvec3(clamp(floor(to_tex(o + d * t0) * cells_per_tex() - walk_shift()), vec3(0.0), H.grid - 1.0));
}

// Distance at which the walk leaves its cell, and the axis it crosses.
float cell_exit(out int axis) {
    vec3 og, dg;
    grid_ray(o, d, og, dg);
    og -= walk_shift();
    bvec3 still = lessThan(abs(dg), vec3(1e-20));
    if (segment_words()) still = bvec3(uvec3(still) | uvec3(edge_axes(vec3(cell), dg)));
    vec3 next = mix((vec3(cell) + max(sign(dg), vec3(0.0)) - og) / dg, vec3(3.0e38), still);
    float te = min(min(next.x, next.y), next.z);
    axis = next.x <= te ? 0 : (next.y <= te ? 1 : 2);
    return te;
}

// One tracking step of the current walk. Returns true when the walk ends: a real collision
// (FLIGHT: `hit`, the medium in `med`), a blocked shadow ray (T = 0), or the walk's end.
bool walk_step(out bool hit, out vec4 med) {
    hit = false;
    med = vec4(0.0);
    if (t >= t_end) return true;
    bool fl = stage == FLIGHT && flight_env();
    // Delta tracking while a flight looks for its collision; the shadow estimator otherwise (a
    // next-flight walk's estimate is at least ratio tracking).
    uint method = stage != FLIGHT ? shadow_method() : ((fl && !looking()) ? max(shadow_method(), 1u) : 0u);
    if (!seg_valid) {
        seg_axis = -1;
        if (grid_majorant()) {
            seg_bounds = cell_bounds_word(ivec3(cell), seg_word);
            // max: a cell clamped at the walk's start may end behind it.
            seg_b = max(min(cell_exit(seg_axis), t_end), t);
        } else {
            seg_bounds = global_bounds();
            seg_b = t_end;
        }
        seg_valid = true;
    }
    vec2 bounds = seg_bounds;
    float b = seg_b;
    int axis = seg_axis;
    // Residual ratio tracking: the cell's minimum extinction as the control (tracking.glsl).
    float c = method == 2u ? bounds.x : 0.0;
    float m = bounds.y - c;
    float tn = m > 0.0 ? t - log(1.0 - rand01(rng)) / m : 3.0e38;
    if (tn >= b) {
        T *= exp(-c * (b - t));
        t = b;
        seg_valid = false;
        if (axis >= 0) {
            int dir = d[axis] > 0.0 ? 1 : -1;
            int next = int(cell[axis]) + dir;
            if (next < 0 || next >= int(H.grid[axis])) t = t_end;
            else cell[axis] = uint(next);
        }
        return t >= t_end;
    }
    T *= exp(-c * (tn - t));
    t = tn;
    vec3 uvw = to_tex(o + d * t);
    vec4 mt = segment_words() ? medium_at(uvw, atlas_in(uvw, vec3(cell), seg_word)) : medium(uvw);
    check_majorant(mt.a, bounds.y);
    if (method == 0u) {
        bool real = rand01(rng) * m < mt.a;
        if (!fl) {
            if (real) {
                hit = true;
                med = mt;
                T = 0.0;
            }
            return real;
        }
        if (real) {
            hit_t = t;
            beta *= collide(mt, uvw, L, beta);  // σs/σt of the collision; the estimate's pend was fixed at the start
        }
    }
    bool killed = false;
    if (T > 0.0 || !fl) {
        T *= ratio_weight(mt.a, c, bounds.y);
        if (T < RR_BELOW) {
            killed = rand01(rng) < RR_KILL;
            T = killed ? 0.0 : T / (1.0 - RR_KILL);
        }
    }
    return fl ? (!looking() && T <= 0.0) : killed;
}

// The environment's radiance along dir, and the solid-angle pdf of its NEE sampling.
vec3 env_along(vec3 dir, out float env_pdf) {
#ifdef ENV_MAP
    return env_lookup(dir, env_pdf);
#else
    env_pdf = PHASE_INV_4PI;
    return M.env_radiance.rgb;
#endif
}

// The view-ray estimate is on: a camera path's unscattered escape adds nothing (VIEW counted it).
// The next-flight walk makes it without a walk of its own.
bool view_estimate() { return mc_feature(4u) && (M.opts.y & 2u) != 0u && has_env() && !flight_env(); }

// A FLIGHT walk has started along d: with the next-flight environment, what it sees of the
// environment if unblocked, and no collision yet (looking() says whether it samples one).
void flight_begin() {
    float env_pdf;
    pend = beta * env_along(d, env_pdf);
    hit_t = -1.0;
}

// A path completed with radiance x: into the pixel's sum and its second moment.
void complete(vec3 x) {
    vec3 before = sum.rgb / max(sum.w, 1.0);
    sum += vec4(x, 1.0);
    m2 += (x - before) * (x - sum.rgb / sum.w);
}

// A new camera path. A ray that misses the box sees the environment and completes at once; it
// ends the pixel's dispatch (more such paths would only repeat it), and the next dispatch
// starts afresh.
void start_path() {
    ivec2 p = pixel();
    ivec2 size = imageSize(frame_out);
    vec2 j = (P.flags.x & FLAG_JITTER) != 0u ? rand2(rng) : vec2(0.5);
    Ray r = camera_ray_at(p, size, j);
    vec2 tb = volume_interval(r);
    beta = vec3(1.0);
    L = vec3(0.0);
    prev_pdf = 0.0;
    bounce = 0u;
    stage = FLIGHT;
    T = 1.0;
    walk_start(r.o, r.d, tb.x, tb.y);
    float env_pdf;
    if (tb.x >= tb.y) {
        complete(env_along(r.d, env_pdf));
        stage = RESTART;
        stop = true;
    } else if (view_estimate()) {
        stage = VIEW;
        pend = env_along(r.d, env_pdf);
    } else if (flight_env()) {
        flight_begin();
    }
}

uint finished = 0u;  // paths completed in this dispatch
// The most paths one pixel may complete in a dispatch, in caps: where its row's other pixels have
// longer paths, it takes their share of the row's cap (main explains).
const uint ROW_SPREAD = 4u;

// Each piece of the event code below appears once: llvmpipe runs every branch for the whole row
// under a lane mask, and GLSL inlines a function at each call site, so a function called from
// three places would cost three times on every event of any lane.

// The continuation: sample the kernel and roulette; false when roulette ends the path.
bool continue_path() {
    float pdf;
#ifdef HYBRID
    vec3 wo = brdf ? cosine_hemisphere(nrm, rand2(rng), pdf) : phase_sample(ph, wi, rand2(rng), pdf);
#else
    vec3 wo = phase_sample(ph, wi, rand2(rng), pdf);  // phase / pdf = 1: beta unchanged
#endif
    prev_pdf = pdf;
    if (float(bounce) >= M.global_majorant.z) {
        // Roulette only below unit throughput, survival max β (mc.comp explains).
        float q = max(max(beta.r, beta.g), beta.b);
        float u = rand01(rng);
        if (q < 1.0) {
            if (u >= q) return false;
            beta /= q;
        }
    }
    bounce += 1u;
    stage = FLIGHT;
    T = 1.0;
    walk_start(o, wo, 0.0, exit_distance(o, wo));
    if (flight_env()) flight_begin();
    return true;
}

// Sets up the first light from `s` on that is on as a shadow walk from the scatter point o;
// false after the last light.
bool enter_light(uint s) {
    vec3 l = vec3(0.0, 1.0, 0.0), rad = vec3(0.0);
    float tmax = 0.0;
    float env_pdf = 1.0;
    if (s == SUN && !sun_on()) s = POINT;
    if (s == POINT && !point_on()) s = ENV;
    if (s == SUN) {
        l = normalize(M.sun_dir.xyz);
        rad = M.sun_radiance.rgb;
    } else if (s == POINT) {
        vec3 to = M.point_pos.xyz - o;
        float dist = length(to);
        l = to / max(dist, 1e-6);
        rad = M.point_intensity.rgb / max(dist * dist, 1e-6);
        tmax = dist;
    } else if (s == ENV && flight_env()) {
        s = CONTINUE;  // the next flight estimates it
    } else if (s == ENV) {
#ifdef ENV_MAP
        if (has_env()) l = env_sample(rand2(rng), rad, env_pdf);
        if (!(has_env() && env_pdf > 0.0)) s = CONTINUE;
#else
        rad = M.env_radiance.rgb;
        env_pdf = PHASE_INV_4PI;  // uniform sphere
        if (has_env()) l = uniform_sphere(rand2(rng));
        else s = CONTINUE;
#endif
    }
    if (s >= CONTINUE) return false;
    float exit = exit_distance(o, l);
    // Only the medium inside the box attenuates; the point light may sit outside it.
    tmax = s == POINT ? min(tmax, exit) : exit;
    if (s == ENV) {
        float pp = KERNEL_PDF(l);
        pend = beta * pp * rad * power_heuristic(env_pdf, pp) / env_pdf;
    } else {
        pend = beta * KERNEL_EVAL(l) * rad;
    }
    stage = s;
    T = 1.0;
    walk_start(o, l, 0.0, tmax);
    return true;
}

// What happens when a walk ends: a scattering event, an escape, or a light sample's result.
void end_walk(bool hit, vec4 med) {
    bool finish = false, scatter = false;
    uint light = CONTINUE + 1u;  // none
    if (stage == VIEW) {
        // The camera ray's own transmittance is known; now the path walks the same ray.
        L += pend * T;
        stage = FLIGHT;
        T = 1.0;
        walk_start(o, d, volume_interval(Ray(o, d)).x, t_end);
    } else if (stage != FLIGHT) {
        L += pend * T;
        light = stage + 1u;
    } else if (flight_env()) {
        // The environment along this flight; then its collision (albedo already in β), if any.
        L += pend * T;
        scatter = hit_t >= 0.0;
        finish = !scatter;
        t = max(hit_t, 0.0);
    } else if (!hit) {
        // Escaped: the environment seen by the continuation, with its MIS weight, or directly
        // (unless the view-ray estimate already counted it).
        float env_pdf;
        vec3 env = env_along(d, env_pdf);
        if (bounce > 0u) L += beta * env * power_heuristic(prev_pdf, env_pdf);
        else if (!view_estimate()) L += env;
        finish = true;
    } else if (bounce == M.opts.x) {  // one more scattering than this renderer estimates
        finish = true;
    } else {
        beta *= collide(med, to_tex(o + d * t), L, beta);  // σs/σt: the collision was real, absorption weights it
        scatter = !(emissive() && all(equal(beta, vec3(0.0))));  // albedo 0: nothing more to carry
        finish = !scatter;
    }
    if (scatter) {
        vec3 x = o + d * t;
        wi = d;
        brdf = false;
        nrm = vec3(0.0, 1.0, 0.0);
#ifdef HYBRID
        if (M.hybrid.x > 0.0) {
            vec3 uvw = to_tex(x);
            g_fetches += 1u;
            float gm = clamp(sample_gradient(uvw) * M.hybrid.y, 0.0, 1.0);
            float p_brdf = M.hybrid.x * (1.0 - exp(-25.0 * gm * gm * gm));
            if (p_brdf > 0.0) {
                vec3 gv = gradient(uvw);
                g_fetches += 6u;
                float gl = length(gv);
                if (gl > 1e-12 && rand01(rng) < p_brdf) {
                    brdf = true;
                    nrm = gv / gl;
                    if (dot(nrm, wi) > 0.0) nrm = -nrm;
                }
            }
        }
#endif
        o = x;
        light = SUN;
    }
    if (light <= CONTINUE && !enter_light(light)) finish = !continue_path();
    if (finish) {
        complete(L);
        finished += 1u;
        if (finished >= ROW_SPREAD * cap) stop = true;
        start_path();
    }
}

void load(uint i) {
    PathState q = PS.s[i];
    o = q.o_t.xyz;
    t = q.o_t.w;
    d = q.d_end.xyz;
    t_end = q.d_end.w;
    beta = q.beta_T.rgb;
    T = q.beta_T.w;
    L = q.L_rng.rgb;
    rng = floatBitsToUint(q.L_rng.w);
    pend = q.pend_bits.rgb;
    uint bits = floatBitsToUint(q.pend_bits.w);
    stage = bits & 15u;
    bounce = (bits >> 4u) & 8191u;  // bounces ≤ 4096 (settings)
    brdf = (bits >> 17u) != 0u;
    wi = q.wi_cell.xyz;
    prev_pdf = q.wi_cell.x;
    hit_t = q.wi_cell.y;
    uint c = floatBitsToUint(q.wi_cell.w);
    cell = uvec3(c & 1023u, (c >> 10u) & 1023u, c >> 20u);
    sum = q.sum;
#ifdef HYBRID
    nrm = q.nrm.xyz;
#endif
}

void store(uint i) {
    uint bits = stage | (bounce << 4u) | (uint(brdf) << 17u);
    uint c = cell.x | (cell.y << 10u) | (cell.z << 20u);
    // wi is dead from the continuation to the next scattering, prev_pdf and hit_t outside it.
    vec3 w = (stage == FLIGHT || stage == VIEW) ? vec3(prev_pdf, hit_t, 0.0) : wi;
    PS.s[i] = PathState(vec4(o, t), vec4(d, t_end), vec4(beta, T), vec4(L, uintBitsToFloat(rng)),
                        vec4(pend, uintBitsToFloat(bits)), vec4(w, uintBitsToFloat(c)), sum
#ifdef HYBRID
                        , vec4(nrm, 0.0)
#endif
    );
}

void main() {
    load_mc_params();
    B = PC.v[g_block];
    ivec2 p = pixel();
    ivec2 size = imageSize(frame_out);
    if (any(greaterThanEqual(p, size))) return;
    uint i = uint(p.y) * uint(size.x) + uint(p.x);
    stop = false;
    ph = Phase(phase_kind(), uintBitsToFloat(M.phase.y), uintBitsToFloat(M.phase.z), uintBitsToFloat(M.phase.w));
    budget = B.budget;
    cap = B.cap;
    if (adaptive() && B.reset == 0u) {
        // A stopped half tile keeps its path and its mean as they are. The others share the
        // frame's budget by weight: a half of weight w gets budget · w · halves / Σ weights (all of
        // it when none has stopped and all weigh alike), at most max_budget.
        float w = tile_weight(p);
        if (w <= 0.0) return;
        float share = w * float(2u * TS.tiles_x * TS.tiles_y) * 256.0 / float(max(TS.weight_sum, 1u));
        budget = clamp(uint(float(B.budget) * share), 1u, B.max_budget);
        cap = uint(ceil(float(B.cap) * max(share, 1.0)));
    }
    if (B.reset != 0u) {
        sum = vec4(0.0);
        m2 = vec3(0.0);
        rng = rng_state(uvec2(p), P.flags.y, P.flags.w);
        start_path();
    } else {
        load(i);
        m2 = imageLoad(moments, p).rgb;
        if (stage == RESTART) start_path();
    }
    // Each lane walks until its walk ends (the inner loop), then handles the event; both count
    // against the budget, so every loop's iterations per dispatch are bounded by the budget
    // (the host checks the 8-lane row's total against llvmpipe's loop limit; a paused walk
    // spent at least one step per outer iteration, so the bound holds with regrouping).
    // The cap is the row's (the subgroup's): it stops once its pixels completed their caps'
    // sum, so a pixel whose paths are short goes on while its neighbours finish long ones,
    // rather than idling masked until the row's last pixel reached its own cap (a per-pixel cap
    // measured 1.07–1.09× the cost on vpt's scene at 256²). ROW_SPREAD bounds what one pixel
    // takes of it. The row also waits for every pixel's first completed path (or its budget):
    // a pixel whose paths are far longer than its neighbours' would otherwise get only the few
    // steps their quota takes, frame after frame, and show no path, or only its shortest, long
    // after a per-pixel cap had completed them. Lanes that stopped stay in the loop, masked, so
    // the row's sums see them.
    uint steps = 0u;
    uint row_cap = subgroupAdd(cap);
    for (;;) {
        bool owed = finished == 0u && steps < budget && !stop;
        if (subgroupAdd(finished) >= row_cap && !subgroupAny(owed)) stop = true;
        if (!subgroupAny(steps < budget && !stop)) break;
        if (steps >= budget || stop) continue;
        bool ended = false, hit = false;
        vec4 med = vec4(0.0);
        // A lane whose walk ended would idle, masked, until the row's longest walk ends; once
        // B.regroup percent of the row's lanes wait, the walks in progress pause (their state
        // is in registers) and the row takes the waiting lanes' events. Each lane's own sequence
        // of steps is unchanged. On vpt's scene at 512², 25–40 % took 0.72× the time of 100 %.
        uint row = subgroupBallotBitCount(subgroupBallot(true));
        while (!ended && steps < budget) {
            ended = walk_step(hit, med);
            steps += 1u;
            uint walking = subgroupBallotBitCount(subgroupBallot(!ended));
            if ((row - walking) * 100u >= row * B.regroup) break;
        }
        if (ended) {
            end_walk(hit, med);
            steps += 1u;
        }
    }
    store(i);
    imageStore(frame_out, p, vec4(sum.rgb / max(sum.w, 1.0), 1.0));
    imageStore(moments, p, vec4(m2, sum.w));
    if (g_fetches != 0u) atomicAdd(S.fetches, g_fetches);
}
