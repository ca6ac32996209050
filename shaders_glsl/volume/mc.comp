#version 460
// Monte Carlo volume path tracing (REFERENCE.md). Scatter points by delta tracking; at each,
// next-event estimation of the sun (delta light) and of the environment, MIS with the scattering
// kernel's sampling by the power heuristic; paths continue by sampling that kernel.
// opts.x = 1 is single scattering (MCS); larger is multiple scattering (MCM) with Russian
// roulette (only below unit throughput). One sample per pixel per frame; random numbers keyed
// by pixel, frame and stream.
// Variants (shaders_glsl/variants.txt), so the plain shader stays exactly the old code:
// - ENV_MAP: the environment is an equirectangular HDR map, sampled for NEE from its 2D
//   piecewise-constant distribution (luminance × sin θ; engine/volume/optics/envmap.rs is the CPU twin)
//   instead of the uniform sphere used for a constant environment.
// - HYBRID: Exposure Render's hybrid scattering (Kroes et al. 2012): at each scattering event,
//   with probability P_brdf = hybrid · (1 - exp(-25 m³)), m = |∇v| / max |∇v| ∈ [0, 1], the
//   event scatters by a Lambertian BRDF about the gradient normal instead of the phase function.
//   The choice is one random draw per event and both NEE and continuation use the chosen kernel,
//   so the estimate is unbiased for the mixed kernel (1 - P) p(ωi, ωo) + P cos⁺(n, ωo) / π.
// View-ray estimate (opts.y bit 1): the environment seen straight through the medium, T·L_env
// along the camera ray, is estimated by the shadow-ray estimator along it, and a path that then
// escapes unscattered adds nothing. The two parts are disjoint (unscattered, scattered), so the
// sum is the same expectation; the first is continuous where the escape is a coin flip.
// Next-flight environment (opts.y bit 2, `env_light=flight`): every flight, the camera ray's
// included, is one walk that delta-tracks the next collision and ratio-tracks the transmittance
// to the box (tracking.glsl's flight_track); the environment seen along it, β·T·L_env, is the
// vertex's whole environment term, so there is no environment NEE ray and an escape adds
// nothing. The view-ray estimate is then the first flight's, for free.
// Emissive media (`emission`, `albedo`): each real collision before the last scattering event adds
// the medium's emission by the collision estimator (mc_common.glsl's `collide`).
#include "mc_common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
    load_mc_params();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(frame_out);
    if (any(greaterThanEqual(p, size))) return;
    if (adaptive() && tile_weight(p) <= 0.0) return;  // mc_accumulate.comp keeps the pixel
    uint rng = rng_state(uvec2(p), P.flags.y, P.flags.w);
    Ray r = camera_ray(p, size);
    vec2 t = volume_interval(r);
    bool inside = t.x < t.y;

    if (test_mode()) {  // estimator test mode: transmittance of the camera ray through the box
        float T = inside ? transmittance(r, t.x, t.y, shadow_method(), rng) : 1.0;
        imageStore(frame_out, p, vec4(T, T, T, 1.0));
        if (g_fetches != 0u) atomicAdd(S.fetches, g_fetches);
        return;
    }

    Phase ph = Phase(phase_kind(), uintBitsToFloat(M.phase.y), uintBitsToFloat(M.phase.z), uintBitsToFloat(M.phase.w));
#ifdef ENV_MAP
    bool has_env = mc_feature(2u) && M.env_map.w > 0.0;
#else
    vec3 env = M.env_radiance.rgb;
    bool has_env = mc_feature(2u) && any(greaterThan(env, vec3(0.0)));
    const float env_pdf = PHASE_INV_4PI;  // uniform sphere
#endif
    vec3 L = vec3(0.0);
    bool flight = mc_feature(5u) && (M.opts.y & 4u) != 0u && has_env;
    bool view_estimate = mc_feature(4u) && (M.opts.y & 2u) != 0u && inside && has_env && !flight;
    if (view_estimate) {
#ifdef ENV_MAP
        float env_pdf;
        vec3 env = env_lookup(r.d, env_pdf);
#endif
        L += env * transmittance(r, t.x, t.y, shadow_method(), rng);
    }
    vec3 beta = vec3(1.0);
    float prev_pdf = 0.0;
    uint max_events = M.opts.x;
    for (uint bounce = 0u; bounce <= max_events; ++bounce) {
        float th;
        vec4 med;
        if (flight) {
#ifdef ENV_MAP
            float env_pdf;
            vec3 env = env_lookup(r.d, env_pdf);
#endif
            float T = 1.0;
            bool hit = inside && flight_track(r, t.x, t.y, shadow_method(), bounce < max_events, rng, th, med, T);
            L += beta * env * T;
            if (!hit) break;
        } else if (!(inside && delta_track(r, t.x, t.y, rng, th, med))) {
            // Escaped: the camera sees the environment directly; later vertices already sampled
            // it by NEE, so this direction counts with its MIS weight.
#ifdef ENV_MAP
            float env_pdf;
            vec3 env = env_lookup(r.d, env_pdf);
#endif
            if (bounce > 0u || !view_estimate) L += beta * env * (bounce == 0u ? 1.0 : power_heuristic(prev_pdf, env_pdf));
            break;
        }
        if (bounce == max_events) break;  // one more scattering than this renderer estimates
        beta *= collide(med, to_tex(r.o + r.d * th), L, beta);    // σs/σt: the collision was real, absorption weights it
        if (emissive() && all(equal(beta, vec3(0.0)))) break;  // albedo 0: nothing more to carry
        vec3 x = r.o + r.d * th;
        vec3 wi = r.d;
#ifdef HYBRID
        // Surface-like scattering where the gradient is strong (see the header).
        bool brdf = false;
        vec3 nrm = vec3(0.0, 1.0, 0.0);
        if (M.hybrid.x > 0.0) {
            vec3 uvw = to_tex(x);
            g_fetches += 1u;
            float m = clamp(sample_gradient(uvw) * M.hybrid.y, 0.0, 1.0);
            float p_brdf = M.hybrid.x * (1.0 - exp(-25.0 * m * m * m));
            if (p_brdf > 0.0) {
                vec3 gv = gradient(uvw);
                g_fetches += 6u;
                float gl = length(gv);
                // A vanishing filtered gradient has no normal: P_brdf is taken as 0 there (a
                // deterministic function of x, so the mixture stays well defined).
                if (gl > 1e-12 && rand01(rng) < p_brdf) {
                    brdf = true;
                    // Either orientation is a valid surface normal; face the incoming side.
                    nrm = gv / gl;
                    if (dot(nrm, wi) > 0.0) nrm = -nrm;
                }
            }
        }
#endif
        if (sun_on()) {
            vec3 l = normalize(M.sun_dir.xyz);
            float T = transmittance(Ray(x, l), 0.0, exit_distance(x, l), shadow_method(), rng);
            L += beta * KERNEL_EVAL(l) * T * M.sun_radiance.rgb;
        }
        if (point_on()) {
            vec3 to = M.point_pos.xyz - x;
            float dist = length(to);
            vec3 l = to / max(dist, 1e-6);
            // Only the medium inside the box attenuates; the light may sit outside it.
            float T = transmittance(Ray(x, l), 0.0, min(dist, exit_distance(x, l)), shadow_method(), rng);
            L += beta * KERNEL_EVAL(l) * T * M.point_intensity.rgb / max(dist * dist, 1e-6);
        }
        if (has_env && !flight) {
#ifdef ENV_MAP
            vec3 env;
            float env_pdf;
            vec3 l = env_sample(rand2(rng), env, env_pdf);
            if (env_pdf > 0.0) {
                float pp = KERNEL_PDF(l);
                float T = transmittance(Ray(x, l), 0.0, exit_distance(x, l), shadow_method(), rng);
                L += beta * pp * T * env * power_heuristic(env_pdf, pp) / env_pdf;
            }
#else
            vec3 l = uniform_sphere(rand2(rng));
            float pp = KERNEL_PDF(l);
            float T = transmittance(Ray(x, l), 0.0, exit_distance(x, l), shadow_method(), rng);
            L += beta * pp * T * env * power_heuristic(env_pdf, pp) / env_pdf;
#endif
        }
        float pdf;
#ifdef HYBRID
        vec3 wo = brdf ? cosine_hemisphere(nrm, rand2(rng), pdf) : phase_sample(ph, wi, rand2(rng), pdf);
#else
        vec3 wo = phase_sample(ph, wi, rand2(rng), pdf);  // phase / pdf = 1: beta unchanged
#endif
        prev_pdf = pdf;
        r = Ray(x, wo);
        t = vec2(0.0, exit_distance(x, wo));
        inside = true;
        if (float(bounce) >= M.global_majorant.z) {
            // Roulette only a path whose throughput fell below 1 (as pbrt-v4), with survival
            // max β, so a survivor's weight returns to 1 and never grows. Capping survival at
            // 0.95 instead killed 5 % of every bright path (albedo ≈ 1) per event and let the
            // survivors' weights grow as 0.95⁻ⁿ. The number is drawn either way, so the random
            // streams of dimmer paths stay as they were.
            float q = max(max(beta.r, beta.g), beta.b);
            float u = rand01(rng);
            if (q < 1.0) {
                if (u >= q) break;
                beta /= q;
            }
        }
    }
    imageStore(frame_out, p, vec4(L, 1.0));
    if (g_fetches != 0u) atomicAdd(S.fetches, g_fetches);
}
