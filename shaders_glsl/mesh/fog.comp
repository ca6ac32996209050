#version 460
// Homogeneous participating medium between the camera and the G-buffer surface (or the far
// plane for sky pixels), in place over the lit HDR image: L = T·L_surface + ∫ T(t) σs S(t) dt.
// The source S is the sun (cascaded shadow maps) and the spot lights (their tiles) through a
// Henyey–Greenstein phase function, the uniform ambient radiance and, with LPV, the light
// grid's radiance (Kaplanyan & Dachsbacher 2010). The ray is cut into equal segments; over
// one segment S is taken at its midpoint and the rest is exact for a homogeneous medium:
// ∫_0^Δ e^{-σt s} ds = (1 - e^{-σt Δ}) / σt, so the only error is S's variation within it.
#define MESH_FRAME_NO_DRAW
#include "frame.glsl"
#include "medium_light.glsl"
#include "../volume/phase.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 1) uniform sampler2D depth_tex;
layout(set = 0, binding = 2) uniform sampler2D shadow_atlas;
layout(set = 0, binding = 3, rgba32f) uniform image2D hdr;
#ifdef LPV
layout(set = 0, binding = 4) uniform sampler3D lpv_r;
layout(set = 0, binding = 5) uniform sampler3D lpv_g;
layout(set = 0, binding = 6) uniform sampler3D lpv_b;
#endif

layout(push_constant) uniform Fog {
    vec4 medium;   // x: σt (1/m), y: single-scattering albedo, z: HG g, w: segments
    vec4 box_min;  // xyz: medium bounds; w: 1 = bounded, 0 = fills all space
    vec4 box_max;  // xyz
} G;

// Slab test of the ray o + t·d against the medium's box: (enter, exit), empty if enter >= exit.
vec2 box_span(vec3 o, vec3 d) {
    vec3 inv = 1.0 / d;
    vec3 t0 = (G.box_min.xyz - o) * inv, t1 = (G.box_max.xyz - o) * inv;
    vec3 lo = min(t0, t1), hi = max(t0, t1);
    return vec2(max(max(lo.x, lo.y), lo.z), min(min(hi.x, hi.y), hi.z));
}

// Transmittance of the medium between x (inside it) and a light `dist` away along l (dist < 0:
// the sun, infinitely far). The sun through a medium filling all space would see none at all,
// so unbounded fog is taken as local: the sun arrives unattenuated, spot lights are attenuated.
float light_transmittance(vec3 x, vec3 l, float dist) {
    float sigma = G.medium.x;
    if (G.box_min.w > 0.0) {
        float exit = max(box_span(x, l).y, 0.0);
        return exp(-sigma * (dist < 0.0 ? exit : min(exit, dist)));
    }
    return dist < 0.0 ? 1.0 : exp(-sigma * dist);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr);
    if (any(greaterThanEqual(p, size))) return;
    float depth = texelFetch(depth_tex, p, 0).r;
    vec2 ndc = (vec2(p) + 0.5) / vec2(size) * 2.0 - 1.0;
    // Sky pixels (depth 1) end at the far plane, which is where their unprojection lands.
    vec4 w = F.inv_view_proj * vec4(ndc, min(depth, 1.0), 1.0);
    vec3 o = F.camera_pos.xyz;
    vec3 end = w.xyz / w.w;
    float t1 = length(end - o);
    vec3 d = (end - o) / max(t1, 1e-30);
    float t0 = 0.0;
    if (G.box_min.w > 0.0) {
        vec2 span = box_span(o, d);
        t0 = max(span.x, 0.0);
        t1 = min(span.y, t1);
    }
    if (!(t1 > t0)) return;  // the ray misses the medium: the pixel keeps its radiance

    float sigma = G.medium.x;
    float sigma_s = sigma * G.medium.y;
    float g = G.medium.z;
    uint n = max(uint(G.medium.w), 1u);
    float dt = (t1 - t0) / float(n);
    float seg_t = exp(-sigma * dt);
    // (1 - e^{-x})/σt loses every digit as x → 0: its series there (exactly dt at σt = 0).
    float x = sigma * dt;
    float seg_w = x < 1e-3 ? dt * (1.0 - x * (0.5 - x / 6.0)) : (1.0 - seg_t) / sigma;

    vec3 sun_l = normalize(F.sun_dir.xyz);
    float sun_phase = phase_hg_eval(g, dot(d, sun_l));
    vec3 scattered = vec3(0.0);
    float T = 1.0;
    for (uint i = 0u; i < n; ++i) {
        vec3 xi = o + d * (t0 + (float(i) + 0.5) * dt);
        // Uniform ambient radiance: the phase function integrates to 1 over it.
        vec3 S = F.ambient.rgb;
        if (F.sun_dir.w > 0.0) {
            float vis = medium_sun_shadow(shadow_atlas, xi);
            if (vis > 0.0) S += sun_phase * F.sun_irradiance.rgb * vis * light_transmittance(xi, sun_l, -1.0);
        }
        for (uint k = 0u; k < F.counts.y; ++k) {
            vec3 to = F.spot_pos[k].xyz - xi;
            float dist2 = max(dot(to, to), 1e-8);
            float dist = sqrt(dist2);
            vec3 l = to / dist;
            float cone = cone_falloff(dot(-l, F.spot_dir[k].xyz), F.spot_dir[k].w, F.spot_intensity[k].a);
            if (cone <= 0.0) continue;
            float vis = medium_shadow(shadow_atlas, uint(F.spot_pos[k].w), xi);
            S += phase_hg_eval(g, dot(d, l)) * F.spot_intensity[k].rgb * (cone * vis / dist2) *
                 light_transmittance(xi, l, dist);
        }
#ifdef LPV
        // Light reaching the camera travels along -d.
        S += medium_lpv_radiance(lpv_r, lpv_g, lpv_b, xi, -d, g) * F.lpv_params.x;
#endif
        scattered += T * seg_w * sigma_s * S;
        T *= seg_t;
    }
    vec4 L = imageLoad(hdr, p);
    imageStore(hdr, p, vec4(L.rgb * T + scattered, L.a));
}
