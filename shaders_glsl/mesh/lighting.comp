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
#ifdef BLEND
// BLEND: the cascade-blend pass, which adds the coarser cascade's share at the pixels the
// lighting pass listed (see lpv_irradiance).
layout(set = 0, binding = 6, rgba32f) uniform image2D hdr_out;
#else
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D hdr_out;
#endif
const float PI = 3.14159265358979;
#ifdef LPV
#extension GL_KHR_shader_subgroup_ballot : require
#include "../lpv/sh.glsl"
// LPV features a frame may leave out, as specialization constants: llvmpipe runs both sides of
// a branch under a lane mask, so a uniform flag would still pay for the lookups it skips.
layout(constant_id = 0) const bool LPV_DAMPING = false;
layout(constant_id = 1) const bool LPV_SUBSURFACE = false;
// The lighting pass leaves the coarser cascade's share of a cascade blend to the blend pass,
// over a list of just those pixels: llvmpipe runs the second lookup of an `if` for every lane (a
// third of the LPV read, for the tenth of the pixels that blend); the list runs it densely.
// The blend list: the blend pass's VkDispatchIndirectCommand (x, y grow with the list from the
// host's 0 × 1 × 1), the entries' count, then per entry the pixel (x | y << 14 | finer cascade
// << 28) and the finer cascade's weight t.
layout(set = 0, binding = 13, std430) buffer BlendList { uint groups[3]; uint count; uvec2 entry[]; } blend;
// Entries per blend-pass workgroup (its 8 × 8 invocations, one entry each), and the most
// workgroups along x (65,535, Vulkan's least maxComputeWorkGroupCount; tests lower it): a list
// longer than that many groups dispatches rows of them along y. BLEND_ROWS: the image has more
// pixels than that many groups hold (the rows' atomic would cost every SIMD row its loop over the
// lanes on llvmpipe).
const uint BLEND_GROUP = 64u;
layout(constant_id = 2) const bool BLEND_ROWS = false;
layout(constant_id = 3) const uint BLEND_MAX_GROUPS = 65535u;
// The grids as storage images: llvmpipe's imageLoad costs well under half a texelFetch through
// the sampler (the LPV read measured 2.3× faster), and the lookup filters by hand anyway.
layout(set = 0, binding = 7, rgba32f) readonly uniform image3D lpv_r;
layout(set = 0, binding = 8, rgba32f) readonly uniform image3D lpv_g;
layout(set = 0, binding = 9, rgba32f) readonly uniform image3D lpv_b;
// The subsurface LPV (the surface grids again when it is off).
layout(set = 0, binding = 10, rgba32f) readonly uniform image3D sslpv_r;
layout(set = 0, binding = 11, rgba32f) readonly uniform image3D sslpv_g;
layout(set = 0, binding = 12, rgba32f) readonly uniform image3D sslpv_b;

// Position of x + offset·s·n in cascade c's cell units (cell centres at i + 0.5), s its cell edge.
vec3 lpv_cell_coords(uint c, vec3 x, vec3 n, float offset) {
    float s = F.lpv_cascade[c].w;
    return (x + n * (offset * s) - F.lpv_cascade[c].xyz) / s;
}

// Distance in cells from q to the cascade's nearest face (< 0: outside it).
float lpv_margin(vec3 q) {
    float N = float(F.lpv_dims.x);
    return min(min(q.x, min(q.y, q.z)), N - max(q.x, max(q.y, q.z)));
}

// Trilinear by hand of each cell's max(0, SH·v) (v: a lobe or basis) around q in cascade c:
// two-band SH is negative behind a lobe, and a cell whose light flows away from the surface
// (the surface's own VPLs) would otherwise pull its neighbours below zero. Written out per
// corner (the order and weights of a loop over i = x + 2y + 4z) so the offsets are constants;
// a macro per grid, since GLSL cannot pass a storage image with its format to a function.
#define LPV_CORNER(TR, TG, TB, X, Y, Z, W)                                                            \
    {                                                                                                \
        ivec3 t = ivec3(X.x, Y.y, Z.z + z0);                                                         \
        vec3 ec = vec3(dot(imageLoad(TR, t), v), dot(imageLoad(TG, t), v), dot(imageLoad(TB, t), v)); \
        e += (W) * max(ec, vec3(0.0));                                                               \
    }
#define LPV_CLAMPED_TRILINEAR(NAME, TR, TG, TB)                 \
    vec3 NAME(uint c, vec3 q, vec4 v) {                         \
        int N = int(F.lpv_dims.x);                              \
        q = clamp(q, vec3(0.5), vec3(float(N) - 0.5));          \
        vec3 b = floor(q - 0.5);                                \
        vec3 f = q - 0.5 - b;                                   \
        vec3 g = 1.0 - f;                                       \
        ivec3 lo = clamp(ivec3(b), ivec3(0), ivec3(N - 1));     \
        ivec3 hi = clamp(ivec3(b) + 1, ivec3(0), ivec3(N - 1)); \
        int z0 = int(c) * N;                                    \
        vec3 e = vec3(0.0);                                     \
        LPV_CORNER(TR, TG, TB, lo, lo, lo, g.x * g.y * g.z)     \
        LPV_CORNER(TR, TG, TB, hi, lo, lo, f.x * g.y * g.z)     \
        LPV_CORNER(TR, TG, TB, lo, hi, lo, g.x * f.y * g.z)     \
        LPV_CORNER(TR, TG, TB, hi, hi, lo, f.x * f.y * g.z)     \
        LPV_CORNER(TR, TG, TB, lo, lo, hi, g.x * g.y * f.z)     \
        LPV_CORNER(TR, TG, TB, hi, lo, hi, f.x * g.y * f.z)     \
        LPV_CORNER(TR, TG, TB, lo, hi, hi, g.x * f.y * f.z)     \
        LPV_CORNER(TR, TG, TB, hi, hi, hi, f.x * f.y * f.z)     \
        return e;                                               \
    }
LPV_CLAMPED_TRILINEAR(lpv_trilinear, lpv_r, lpv_g, lpv_b)
LPV_CLAMPED_TRILINEAR(sslpv_trilinear, sslpv_r, sslpv_g, sslpv_b)

// Irradiance at x (normal n) from cascade c of an LPV: the cell's intensity I(ω) over the
// cell's cross-section s² is radiance, so E = (1/s²) ∫ I(ω) max(0, -n·ω) dω (the light flowing
// toward the surface), a dot product with the cosine lobe around -n. Sampled `offset` cells
// along the normal so a wall does not read the light on its other side.
// `sub`: the subsurface LPV (a constant at every call, so the other grid's loads fold away).
vec3 lpv_cascade_irradiance(bool sub, uint c, vec3 x, vec3 n, float offset) {
    float s = F.lpv_cascade[c].w;
    vec3 q = lpv_cell_coords(c, x, n, offset);
    vec3 e;
    if (sub) {
        e = sslpv_trilinear(c, q, sh_cosine_lobe(-n));
    } else {
        e = lpv_trilinear(c, q, sh_cosine_lobe(-n));
    }
    return e / (s * s);
}

// Light-bleeding damping (optional): a surface lit through a thin wall sees the LPV brighter
// behind it than in front. Comparing the irradiance half a cell in front of and behind the
// surface, scale by front/back when the back is brighter.
vec3 lpv_damped(uint c, vec3 x, vec3 n) {
    vec3 e = lpv_cascade_irradiance(false, c, x, n, F.lpv_params.y);
    if (!LPV_DAMPING) return e;
    vec3 back = lpv_cascade_irradiance(false, c, x, n, -F.lpv_params.y);
    float f = dot(e, vec3(1.0)), b = dot(back, vec3(1.0));
    return b > f && b > 0.0 ? e * (f / b) : e;
}

// The finest cascade whose cells hold x + offset·n (its margin in m; the coarsest, with m < 0,
// if none does). Chosen before any texel is read: llvmpipe runs a loop's body for the whole
// SIMD row while any lane is still in it, so reading inside the search would cost one lookup
// per cascade tried.
uint lpv_find_cascade(vec3 x, vec3 n, float offset, out float m) {
    uint count = F.lpv_dims.y;
    uint c = 0u;
    m = lpv_margin(lpv_cell_coords(0u, x, n, offset));
    while (m < 0.0 && c + 1u < count) {
        c++;
        m = lpv_margin(lpv_cell_coords(c, x, n, offset));
    }
    return c;
}

// The subsurface LPV's irradiance at x for normal n, from the finest cascade that holds x.
vec3 sslpv_irradiance(vec3 x, vec3 n) {
    float m;
    uint c = lpv_find_cascade(x, n, F.lpv_params.y, m);
    return m >= 0.0 ? lpv_cascade_irradiance(true, c, x, n, F.lpv_params.y) : vec3(0.0);
}

// The finest cascade that holds x, blended into the next one over the last two cells: the
// finer cascade c weighs t, the coarser (1 − t). Returns only the finer share, and `c`, `t` for
// the blend pass where it blends (`blends`).
vec3 lpv_irradiance(vec3 x, vec3 n, out bool blends, out uint c, out float t) {
    uint count = F.lpv_dims.y;
    float m;
    c = lpv_find_cascade(x, n, F.lpv_params.y, m);
    blends = false;
    t = 1.0;
    if (m < 0.0) return vec3(0.0);  // outside every cascade
    vec3 e = lpv_damped(c, x, n);
    if (m >= 2.0 || c + 1u == count) return e;
    // Blend only into a coarser cascade that itself holds the point.
    float m2 = lpv_margin(lpv_cell_coords(c + 1u, x, n, F.lpv_params.y));
    if (m2 < 1.0) return e;
    t = clamp(m * 0.5, 0.0, 1.0);
    blends = true;
    return t * e;
}

// Appends pixel p (finer cascade c, weight t) to the blend list where `blends`: one atomic per
// SIMD row (llvmpipe loops over the lanes for an atomic, masked or not).
void blend_append(bool blends, ivec2 p, uint c, float t) {
    uvec4 ballot = subgroupBallot(blends);
    uint k = subgroupBallotBitCount(ballot);
    uint at = 0u;
    if (subgroupElect() && k > 0u) {
        at = atomicAdd(blend.count, k);
        uint groups = (at + k + BLEND_GROUP - 1u) / BLEND_GROUP;
        atomicMax(blend.groups[0], min(groups, BLEND_MAX_GROUPS));
        if (BLEND_ROWS) atomicMax(blend.groups[1], (groups + BLEND_MAX_GROUPS - 1u) / BLEND_MAX_GROUPS);
    }
    at = subgroupBroadcastFirst(at) + subgroupBallotExclusiveBitCount(ballot);
    if (blends) blend.entry[at] = uvec2(uint(p.x) | uint(p.y) << 14 | c << 28, floatBitsToUint(t));
}
#ifdef GLOSSY
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
        // The sample's light toward -r (each cell clamped at 0 as in the irradiance lookup)
        // over the cell's cross-section s², from the finest cascade holding it.
        vec3 w = start + r * (float(k + 1) * s);
        float m;
        uint c = lpv_find_cascade(w, n, 0.0, m);
        if (m >= 0.0) {
            float sc = F.lpv_cascade[c].w;
            sum += lpv_trilinear(c, lpv_cell_coords(c, w, n, 0.0), basis) / (sc * sc);
            seen += 1.0;
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

// The G-buffer's surface at pixel p (depth < 1): position, unit normal, and the base colour
// (a: translucency t). A translucent surface reflects only the share 1 − t, as its VPLs do;
// what enters comes out through the subsurface LPV, if it is on.
void gbuffer_surface(ivec2 p, ivec2 size, float depth, out vec3 x, out vec3 n, out vec4 base) {
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    vec4 w = F.inv_view_proj * vec4(uv * 2.0 - 1.0, depth, 1.0);
    x = w.xyz / w.w;
    base = texelFetch(albedo_tex, p, 0);
    n = normalize(texelFetch(normal_tex, p, 0).xyz);
}

#ifdef BLEND
// One listed pixel per invocation: add the coarser cascade's share (1 − t)·ρ/π·E_{c+1}.
void main() {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint i = group * BLEND_GROUP + gl_LocalInvocationIndex;
    if (i >= blend.count) return;
    uvec2 e = blend.entry[i];
    ivec2 p = ivec2(e.x & 0x3fffu, (e.x >> 14) & 0x3fffu);
    uint c = e.x >> 28;
    float t = uintBitsToFloat(e.y);
    vec3 x, n;
    vec4 base;
    gbuffer_surface(p, imageSize(hdr_out), texelFetch(depth_tex, p, 0).r, x, n, base);
    vec3 albedo = base.rgb * (1.0 - base.a);
    vec3 add = albedo / PI * ((1.0 - t) * lpv_damped(c + 1u, x, n)) * F.lpv_params.x;
    imageStore(hdr_out, p, imageLoad(hdr_out, p) + vec4(add, 0.0));
}
#else
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr_out);
    if (any(greaterThanEqual(p, size))) return;
    float depth = texelFetch(depth_tex, p, 0).r;
    if (depth >= 1.0) {
        imageStore(hdr_out, p, vec4(F.sky.rgb, 1.0));
        return;
    }
    vec3 x, n;
    vec4 base;
    gbuffer_surface(p, size, depth, x, n, base);
    vec3 albedo = base.rgb * (1.0 - base.a);
    vec4 spec = texelFetch(specular_tex, p, 0);
    spec.a = exp2(spec.a * 12.0);  // gbuffer.frag: a = log2(shininess) / 12
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
    bool blends;
    uint c;
    float t;
    L += albedo / PI * lpv_irradiance(x, n, blends, c, t) * F.lpv_params.x;
    blend_append(blends, p, c, t);
    if (LPV_SUBSURFACE) {
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
#endif
