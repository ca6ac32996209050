#version 460
// Monte Carlo volume path tracing (REFERENCE.md). Scatter points by delta tracking; at each,
// next-event estimation of the sun (delta light) and of the constant environment (uniform sphere
// sampling, MIS with phase sampling by the power heuristic); paths continue by phase sampling.
// opts.x = 1 is single scattering (MCS); larger is multiple scattering (MCM) with Russian
// roulette. One sample per pixel per frame; random numbers keyed by pixel, frame and stream.
#include "tracking.glsl"
#include "phase.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D frame_out;
const float PI = 3.14159265358979;

float power_heuristic(float a, float b) { return (a * a) / max(a * a + b * b, 1e-30); }

vec3 uniform_sphere(vec2 xi) {
    float z = 1.0 - 2.0 * xi.x;
    float s = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * xi.y;
    return vec3(s * cos(phi), s * sin(phi), z);
}

float exit_distance(vec3 o, vec3 d) { return intersect_box(Ray(o, d), P.box_min.xyz, P.box_max.xyz).y; }

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(frame_out);
    if (any(greaterThanEqual(p, size))) return;
    uint rng = rng_state(uvec2(p), P.flags.y, 0u);
    Ray r = camera_ray(p, size);
    vec2 t = intersect_box(r, P.box_min.xyz, P.box_max.xyz);
    bool inside = t.x < t.y;

    if (M.opts.y == 1u) {  // estimator test mode: transmittance of the camera ray through the box
        float T = inside ? transmittance(r, t.x, t.y, M.opts.w, rng) : 1.0;
        imageStore(frame_out, p, vec4(T, T, T, 1.0));
        if (g_fetches != 0u) atomicAdd(S.fetches, g_fetches);
        return;
    }

    Phase ph = Phase(M.phase.x, uintBitsToFloat(M.phase.y), uintBitsToFloat(M.phase.z), uintBitsToFloat(M.phase.w));
    vec3 env = M.env_radiance.rgb;
    bool has_env = any(greaterThan(env, vec3(0.0)));
    const float env_pdf = PHASE_INV_4PI;  // uniform sphere
    vec3 L = vec3(0.0);
    vec3 beta = vec3(1.0);
    float prev_pdf = 0.0;
    uint max_events = M.opts.x;
    for (uint bounce = 0u; bounce <= max_events; ++bounce) {
        float th;
        vec4 med;
        if (!(inside && delta_track(r, t.x, t.y, rng, th, med))) {
            // Escaped: the camera sees the environment directly; later vertices already sampled
            // it by NEE, so this direction counts with its MIS weight.
            L += beta * env * (bounce == 0u ? 1.0 : power_heuristic(prev_pdf, env_pdf));
            break;
        }
        if (bounce == max_events) break;  // one more scattering than this renderer estimates
        beta *= med.rgb;                  // σs/σt: the collision was real, absorption weights it
        vec3 x = r.o + r.d * th;
        vec3 wi = r.d;
        if (M.sun_dir.w > 0.0) {
            vec3 l = normalize(M.sun_dir.xyz);
            float T = transmittance(Ray(x, l), 0.0, exit_distance(x, l), M.opts.w, rng);
            L += beta * phase_eval(ph, dot(wi, l)) * T * M.sun_radiance.rgb;
        }
        if (M.point_pos.w > 0.0) {
            vec3 to = M.point_pos.xyz - x;
            float dist = length(to);
            vec3 l = to / max(dist, 1e-6);
            // Only the medium inside the box attenuates; the light may sit outside it.
            float T = transmittance(Ray(x, l), 0.0, min(dist, exit_distance(x, l)), M.opts.w, rng);
            L += beta * phase_eval(ph, dot(wi, l)) * T * M.point_intensity.rgb / max(dist * dist, 1e-6);
        }
        if (has_env) {
            vec3 l = uniform_sphere(rand2(rng));
            float pp = phase_pdf(ph, wi, l);
            float T = transmittance(Ray(x, l), 0.0, exit_distance(x, l), M.opts.w, rng);
            L += beta * pp * T * env * power_heuristic(env_pdf, pp) / env_pdf;
        }
        float pdf;
        vec3 wo = phase_sample(ph, wi, rand2(rng), pdf);  // phase / pdf = 1: beta unchanged
        prev_pdf = pdf;
        r = Ray(x, wo);
        t = vec2(0.0, exit_distance(x, wo));
        inside = true;
        if (float(bounce) >= M.global_majorant.z) {
            float q = min(max(max(beta.r, beta.g), beta.b), 0.95);
            if (rand01(rng) >= q) break;
            beta /= q;
        }
    }
    imageStore(frame_out, p, vec4(L, 1.0));
    if (g_fetches != 0u) atomicAdd(S.fetches, g_fetches);
}
