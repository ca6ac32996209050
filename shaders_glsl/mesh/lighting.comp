#version 460
// Deferred direct lighting: energy-normalised Blinn–Phong, f = ρ/π + ks·(s+8)/(8π)·(n·h)^s, lit
// by the sun (irradiance E, cascaded shadow maps) and spot lights (intensity I, E = I/d², cone
// falloff, one shadow tile each), plus an optional uniform ambient radiance.
// No per-draw constants: the pass pushes none.
#define MESH_FRAME_NO_DRAW
#include "frame.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 1) uniform sampler2D depth_tex;
layout(set = 0, binding = 2) uniform sampler2D albedo_tex;
layout(set = 0, binding = 3) uniform sampler2D normal_tex;
layout(set = 0, binding = 4) uniform sampler2D specular_tex;
layout(set = 0, binding = 5) uniform sampler2D shadow_atlas;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D hdr_out;
const float PI = 3.14159265358979;
#ifdef LPV
#include "../lpv/sh.glsl"
layout(set = 0, binding = 7) uniform sampler3D lpv_r;
layout(set = 0, binding = 8) uniform sampler3D lpv_g;
layout(set = 0, binding = 9) uniform sampler3D lpv_b;
// The subsurface LPV (the surface grids again when it is off: F.lpv_params.w = 0).
layout(set = 0, binding = 10) uniform sampler3D sslpv_r;
layout(set = 0, binding = 11) uniform sampler3D sslpv_g;
layout(set = 0, binding = 12) uniform sampler3D sslpv_b;

// Irradiance at x (normal n) from cascade c of the LPV: the cell's intensity I(ω) over the
// cell's cross-section s² is radiance, so E = (1/s²) ∫ I(ω) max(0, -n·ω) dω (the light flowing
// toward the surface), a dot product with the cosine lobe around -n. Sampled half a cell along
// the normal so a wall does not read the light on its other side.
vec3 lpv_cascade_irradiance(uint c, vec3 x, vec3 n, float offset, out float margin, bool sub) {
    float N = float(F.lpv_dims.x);
    float s = F.lpv_cascade[c].w;
    vec3 q = (x + n * (offset * s) - F.lpv_cascade[c].xyz) / s;
    margin = min(min(q.x, min(q.y, q.z)), N - max(q.x, max(q.y, q.z)));
    q = clamp(q, vec3(0.5), vec3(N - 0.5));
    // Trilinear by hand so each cell's irradiance is clamped before blending: two-band SH is
    // negative behind a lobe, and a cell whose light flows away from the surface (the
    // surface's own VPLs) would otherwise pull its neighbours below zero.
    vec4 lobe = sh_cosine_lobe(-n);
    vec3 b = floor(q - 0.5);
    vec3 f = q - 0.5 - b;
    vec3 e = vec3(0.0);
    for (int i = 0; i < 8; ++i) {
        ivec3 o = ivec3(i & 1, (i >> 1) & 1, (i >> 2) & 1);
        ivec3 cell = clamp(ivec3(b) + o, ivec3(0), ivec3(int(N) - 1));
        float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y) * (o.z == 1 ? f.z : 1.0 - f.z);
        ivec3 t = ivec3(cell.xy, cell.z + int(c) * int(N));
        vec3 ec = sub ? vec3(dot(texelFetch(sslpv_r, t, 0), lobe), dot(texelFetch(sslpv_g, t, 0), lobe),
                             dot(texelFetch(sslpv_b, t, 0), lobe))
                      : vec3(dot(texelFetch(lpv_r, t, 0), lobe), dot(texelFetch(lpv_g, t, 0), lobe),
                             dot(texelFetch(lpv_b, t, 0), lobe));
        e += w * max(ec, vec3(0.0));
    }
    return e / (s * s);
}

// Light-bleeding damping (optional): a surface lit through a thin wall sees the LPV brighter
// behind it than in front. Comparing the irradiance half a cell in front of and behind the
// surface, scale by front/back when the back is brighter.
vec3 lpv_damped(uint c, vec3 x, vec3 n, out float margin) {
    vec3 e = lpv_cascade_irradiance(c, x, n, F.lpv_params.y, margin, false);
    if (F.lpv_params.z == 0.0) return e;
    float m;
    vec3 back = lpv_cascade_irradiance(c, x, n, -F.lpv_params.y, m, false);
    float f = dot(e, vec3(1.0)), b = dot(back, vec3(1.0));
    return b > f && b > 0.0 ? e * (f / b) : e;
}

// The subsurface LPV's irradiance at x for normal n, from the finest cascade that holds x.
vec3 sslpv_irradiance(vec3 x, vec3 n) {
    for (uint c = 0u; c < F.lpv_dims.y; ++c) {
        float m;
        vec3 e = lpv_cascade_irradiance(c, x, n, F.lpv_params.y, m, true);
        if (m >= 0.0) return e;
    }
    return vec3(0.0);
}

// The finest cascade that holds x, blended into the next one over the last two cells.
vec3 lpv_irradiance(vec3 x, vec3 n) {
    uint count = F.lpv_dims.y;
    for (uint c = 0u; c < count; ++c) {
        float m;
        vec3 e = lpv_damped(c, x, n, m);
        if (m < 0.0 && c + 1u < count) continue;  // outside this cascade: try a coarser one
        if (m < 0.0) return vec3(0.0);            // outside every cascade
        if (m >= 2.0 || c + 1u == count) return e;
        float m2;
        vec3 coarse = lpv_damped(c + 1u, x, n, m2);
        // Blend only into a coarser cascade that itself holds the point.
        return m2 >= 1.0 ? mix(coarse, e, clamp(m * 0.5, 0.0, 1.0)) : e;
    }
    return vec3(0.0);
}
#ifdef GLOSSY
// Radiance flowing along d at world point w, from cascade c: the cell intensities toward d
// (trilinear by hand, each cell clamped at 0 as in the irradiance lookup) over the cell's
// cross-section s². margin < 0: w is outside the cascade.
vec3 lpv_cascade_radiance(uint c, vec3 w, vec4 basis, out float margin) {
    float N = float(F.lpv_dims.x);
    float s = F.lpv_cascade[c].w;
    vec3 q = (w - F.lpv_cascade[c].xyz) / s;
    margin = min(min(q.x, min(q.y, q.z)), N - max(q.x, max(q.y, q.z)));
    if (margin < 0.0) return vec3(0.0);
    q = clamp(q, vec3(0.5), vec3(N - 0.5));
    vec3 b = floor(q - 0.5);
    vec3 f = q - 0.5 - b;
    vec3 e = vec3(0.0);
    for (int i = 0; i < 8; ++i) {
        ivec3 o = ivec3(i & 1, (i >> 1) & 1, (i >> 2) & 1);
        ivec3 cell = clamp(ivec3(b) + o, ivec3(0), ivec3(int(N) - 1));
        float wt = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y) * (o.z == 1 ? f.z : 1.0 - f.z);
        ivec3 t = ivec3(cell.xy, cell.z + int(c) * int(N));
        vec3 ic = vec3(dot(texelFetch(lpv_r, t, 0), basis), dot(texelFetch(lpv_g, t, 0), basis),
                       dot(texelFetch(lpv_b, t, 0), basis));
        e += wt * max(ic, vec3(0.0));
    }
    return e / (s * s);
}

// Glossy reflection (Kaplanyan & Dachsbacher 2010; thesis §5.5): the radiance arriving at x
// from the reflection direction r, estimated by marching the LPV along r one cell per sample
// and reading each sample's light that flows back along -r (toward the surface, and so after
// the mirror reflection toward the viewer). A Blinn–Phong lobe of exponent s is about
// α = √(2/(s+2)) wide; a trilinear lookup already averages one cell, so samples are useful only
// while the lobe is narrower than a cell, up to 1/tan α cells out: 1 sample for s ≤ 4,
// 3 at s = 16, 6 at s = 64, at most 8. Each sample reads the finest cascade that holds it.
vec3 lpv_reflected_radiance(vec3 x, vec3 n, vec3 r, float shininess) {
    int samples = clamp(int(round(1.0 / tan(sqrt(2.0 / (shininess + 2.0))))), 1, 8);
    vec4 basis = sh_basis(-r);
    // March in cells of the finest cascade holding x (or the coarsest, if none does).
    uint count = F.lpv_dims.y;
    float s = F.lpv_cascade[count - 1u].w;
    for (uint c = 0u; c < count; ++c) {
        float N = float(F.lpv_dims.x);
        vec3 q = (x - F.lpv_cascade[c].xyz) / F.lpv_cascade[c].w;
        if (all(greaterThanEqual(q, vec3(0.0))) && all(lessThanEqual(q, vec3(N)))) {
            s = F.lpv_cascade[c].w;
            break;
        }
    }
    vec3 start = x + n * (F.lpv_params.y * s);
    vec3 sum = vec3(0.0);
    float seen = 0.0;
    for (int k = 0; k < samples; ++k) {
        vec3 w = start + r * (float(k + 1) * s);
        for (uint c = 0u; c < count; ++c) {
            float m;
            vec3 l = lpv_cascade_radiance(c, w, basis, m);
            if (m >= 0.0) {
                sum += l;
                seen += 1.0;
                break;
            }
        }
    }
    return seen > 0.0 ? sum / seen : vec3(0.0);
}
#endif
#endif

// Fraction of light reaching p through shadow tile `tile`: bilinear-weighted PCF over a
// (2r+2)² texel footprint, with a receiver normal offset of 1.5 texels against acne.
float shadow_factor(uint tile, vec3 p, vec3 n) {
    vec4 texel = F.shadow_texel[tile];
    vec4 c = F.shadow_vp[tile] * vec4(p + n * texel.x * 1.5, 1.0);
    vec3 ndc = c.xyz / c.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0) return 1.0;
    vec4 rect = F.shadow_rect[tile];
    vec2 uv = rect.xy + (ndc.xy * 0.5 + 0.5) * rect.zw;
    vec2 st = uv * F.atlas_size.xy - 0.5;
    vec2 base = floor(st);
    vec2 f = st - base;
    int r = int(F.counts.w);
    vec2 lo = rect.xy * F.atlas_size.xy, hi = (rect.xy + rect.zw) * F.atlas_size.xy - 1.0;
    float lit = 0.0, total = 0.0;
    for (int y = -r; y <= r + 1; ++y) {
        for (int x = -r; x <= r + 1; ++x) {
            // Edge taps carry the bilinear fraction, so the filter slides smoothly with p.
            float wx = x == -r ? 1.0 - f.x : (x == r + 1 ? f.x : 1.0);
            float wy = y == -r ? 1.0 - f.y : (y == r + 1 ? f.y : 1.0);
            vec2 q = clamp(base + vec2(x, y), lo, hi);
            float d = texelFetch(shadow_atlas, ivec2(q), 0).r;
            lit += wx * wy * (ndc.z - texel.y <= d ? 1.0 : 0.0);
            total += wx * wy;
        }
    }
    return lit / total;
}

#ifdef PCSS
// Distance along the light of shadow-map depth d in a tile: from the near plane for an
// orthographic tile (texel.zw = (far − near, 0)), from the light for a perspective one
// (texel.zw = (near, far), depth = far·(D − near) / ((far − near)·D)).
float light_distance(vec4 texel, float d) {
    return texel.w == 0.0 ? d * texel.z : texel.z * texel.w / (texel.w - d * (texel.w - texel.z));
}

// Box filter of half-width h texels centred at u (atlas texel coordinates, texel i covering
// [i, i+1)) over the depth test z ≤ depth: each texel weighted by its overlap with the box.
// With h = r + 0.5 these are exactly the PCF's taps and weights; wider boxes take one test per
// bin of `step` texels (weighted by the bin's overlap) so no box costs more than 12² taps.
float box_visibility(vec2 u, float h, float z, vec2 lo, vec2 hi) {
    float step = max(1.0, ceil(h / 5.0));
    vec2 a = u - h, b = u + h;
    vec2 first = floor(a / step) * step;
    ivec2 bins = ivec2(ceil((b - first) / step));
    float lit = 0.0, total = 0.0;
    for (int j = 0; j < bins.y; ++j) {
        for (int i = 0; i < bins.x; ++i) {
            vec2 bin = first + vec2(i, j) * step;
            vec2 o = max(min(bin + step, b) - max(bin, a), vec2(0.0));
            float w = o.x * o.y;
            vec2 q = clamp(bin + floor(step * 0.5), lo, hi);
            float d = texelFetch(shadow_atlas, ivec2(q), 0).r;
            lit += w * (z <= d ? 1.0 : 0.0);
            total += w;
        }
    }
    return total > 0.0 ? lit / total : 1.0;
}

// Percentage-closer soft shadows (Fernando 2005) through tile `tile`: the mean distance of the
// blockers found in a search region, the penumbra that a light of the configured size casts past
// them — sun (angular radius θ): (receiver − blocker)·tan θ; spot (radius R):
// (receiver − blocker)/blocker · R — and a box filter that wide (at least the PCF radius, at most
// F.soft_shadow.z texels). Same normal offset and bias as the PCF.
float shadow_factor_soft(uint tile, vec3 p, vec3 n) {
    vec4 texel = F.shadow_texel[tile];
    vec4 c = F.shadow_vp[tile] * vec4(p + n * texel.x * 1.5, 1.0);
    vec3 ndc = c.xyz / c.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0) return 1.0;
    vec4 rect = F.shadow_rect[tile];
    vec2 u = (rect.xy + (ndc.xy * 0.5 + 0.5) * rect.zw) * F.atlas_size.xy;
    vec2 lo = rect.xy * F.atlas_size.xy, hi = (rect.xy + rect.zw) * F.atlas_size.xy - 1.0;
    float z = ndc.z - texel.y;
    float max_r = F.soft_shadow.z;
    bool spot = texel.w != 0.0;
    float size = spot ? F.soft_shadow.y : F.soft_shadow.x;
    float zr = light_distance(texel, ndc.z);
    // World size of one texel at the receiver.
    float texel_r = spot ? texel.x * zr : texel.x;
    float radius = float(F.counts.w);
    if (size > 0.0) {
        // A blocker can hide part of the light only within the light's projection from the
        // receiver: for the sun the cone of half-angle θ, for a spot R·(zr − zb)/(zr·zb) at the
        // blocker's depth zb, widest at the near plane.
        float search = spot ? size * (zr - texel.z) / (zr * texel.z * texel.x) : zr * size / texel.x;
        search = clamp(search, 1.0, max_r);
        float sum = 0.0, found = 0.0;
        for (int j = -3; j <= 3; ++j) {
            for (int i = -3; i <= 3; ++i) {
                vec2 q = clamp(floor(u + vec2(i, j) * (search / 3.0)), lo, hi);
                float d = texelFetch(shadow_atlas, ivec2(q), 0).r;
                if (d < z) {
                    sum += light_distance(texel, d);
                    found += 1.0;
                }
            }
        }
        if (found > 0.0) {
            float zb = sum / found;
            float penumbra = spot ? (zr - zb) / max(zb, 1e-6) * size : (zr - zb) * size;
            radius = max(radius, penumbra / texel_r);
        }
    }
    return box_visibility(u, min(radius, max_r) + 0.5, z, lo, hi);
}
#define SHADOW shadow_factor_soft
#else
#define SHADOW shadow_factor
#endif

vec3 brdf(vec3 albedo, vec4 spec, vec3 n, vec3 v, vec3 l) {
    vec3 h = normalize(v + l);
    float s = spec.a;
    return albedo / PI + spec.rgb * (s + 8.0) / (8.0 * PI) * pow(max(dot(n, h), 0.0), s);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr_out);
    if (any(greaterThanEqual(p, size))) return;
    float depth = texelFetch(depth_tex, p, 0).r;
    if (depth >= 1.0) {
        imageStore(hdr_out, p, vec4(F.sky.rgb, 1.0));
        return;
    }
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    vec4 w = F.inv_view_proj * vec4(uv * 2.0 - 1.0, depth, 1.0);
    vec3 x = w.xyz / w.w;
    // A translucent surface (a: the share t of light that enters it) reflects only the rest,
    // as its VPLs do; what enters comes out through the subsurface LPV, if it is on.
    vec4 base = texelFetch(albedo_tex, p, 0);
    vec3 albedo = base.rgb * (1.0 - base.a);
    vec3 n = normalize(texelFetch(normal_tex, p, 0).xyz);
    vec4 spec = texelFetch(specular_tex, p, 0);
    spec.a = max(spec.a * 4096.0, 1.0);
    vec3 v = normalize(F.camera_pos.xyz - x);
    vec3 L = F.ambient.rgb * albedo;

    if (F.sun_dir.w > 0.0) {
        vec3 l = normalize(F.sun_dir.xyz);
        float cosine = dot(n, l);
        if (cosine > 0.0) {
            // Cascade: the first whose far distance covers this point's view depth.
            float view_depth = dot(x - F.camera_pos.xyz, F.camera_forward.xyz);
            uint cascade = 0u;
            while (cascade + 1u < F.counts.x && view_depth > F.cascade_far[cascade]) cascade++;
            float vis = F.counts.x > 0u ? SHADOW(cascade, x, n) : 1.0;
            L += brdf(albedo, spec, n, v, l) * F.sun_irradiance.rgb * cosine * vis;
        }
    }
    for (uint i = 0u; i < F.counts.y; ++i) {
        vec3 d = F.spot_pos[i].xyz - x;
        float dist2 = max(dot(d, d), 1e-8);
        vec3 l = d * inversesqrt(dist2);
        float cosine = dot(n, l);
        float cone = cone_falloff(dot(-l, F.spot_dir[i].xyz), F.spot_dir[i].w, F.spot_intensity[i].a);
        if (cosine <= 0.0 || cone <= 0.0) continue;
        float vis = SHADOW(uint(F.spot_pos[i].w), x, n);
        L += brdf(albedo, spec, n, v, l) * F.spot_intensity[i].rgb * cone / dist2 * cosine * vis;
    }
#ifdef LPV
    // Indirect diffuse from the LPV: ρ/π · E.
    L += albedo / PI * lpv_irradiance(x, n) * F.lpv_params.x;
    if (F.lpv_params.w > 0.0) {
        // Subsurface LPV: light that entered the object elsewhere and flows out through this
        // surface — the irradiance on its inner side (normal −n, sampled inside), let out in the
        // share t the surface lets through.
        if (base.a > 0.0) L += base.rgb / PI * base.a * sslpv_irradiance(x, -n) * F.lpv_params.x;
    }
#ifdef GLOSSY
    // Indirect specular: the energy-normalised lobe integrates to about ks over the hemisphere,
    // so under radiance that varies slowly across the lobe L = ks · L_in(r).
    L += spec.rgb * lpv_reflected_radiance(x, n, reflect(-v, n), spec.a) * F.lpv_params.x;
#endif
#endif
    imageStore(hdr_out, p, vec4(L, 1.0));
}
