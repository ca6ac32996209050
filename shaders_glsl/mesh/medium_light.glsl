#ifndef MESH_MEDIUM_LIGHT_GLSL
#define MESH_MEDIUM_LIGHT_GLSL
// Light arriving at points of a participating medium (no surface, so no normal): shadow-map
// visibility and the LPV's radiance in one direction. Needs frame.glsl included first.
#include "../lpv/sh.glsl"

// Fraction of light reaching p through shadow tile `tile`. A medium point has no normal to
// offset along, so only the tile's depth bias guards against self-shadowing; a 2×2 bilinear
// comparison turns a shadow edge crossed by a ray into a ramp instead of a one-texel step.
float medium_shadow(sampler2D atlas, uint tile, vec3 p) {
    vec4 c = F.shadow_vp[tile] * vec4(p, 1.0);
    if (c.w <= 0.0) return 1.0;
    vec3 ndc = c.xyz / c.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0) return 1.0;
    vec4 rect = F.shadow_rect[tile];
    vec2 st = (rect.xy + (ndc.xy * 0.5 + 0.5) * rect.zw) * F.atlas_size.xy - 0.5;
    vec2 base = floor(st);
    vec2 f = st - base;
    vec2 lo = rect.xy * F.atlas_size.xy, hi = (rect.xy + rect.zw) * F.atlas_size.xy - 1.0;
    float z = ndc.z - F.shadow_texel[tile].y;
    vec4 d = vec4(texelFetch(atlas, ivec2(clamp(base, lo, hi)), 0).r,
                  texelFetch(atlas, ivec2(clamp(base + vec2(1, 0), lo, hi)), 0).r,
                  texelFetch(atlas, ivec2(clamp(base + vec2(0, 1), lo, hi)), 0).r,
                  texelFetch(atlas, ivec2(clamp(base + vec2(1, 1), lo, hi)), 0).r);
    vec4 lit = step(vec4(z), d);
    return mix(mix(lit.x, lit.y, f.x), mix(lit.z, lit.w, f.x), f.y);
}

// Sun visibility at p: the cascade whose far distance covers p's view depth (the last one
// beyond them; outside its tile the sun is unshadowed, as for surfaces).
float medium_sun_shadow(sampler2D atlas, vec3 p) {
    if (F.counts.x == 0u) return 1.0;
    float view_depth = dot(p - F.camera_pos.xyz, F.camera_forward.xyz);
    uint cascade = 0u;
    while (cascade + 1u < F.counts.x && view_depth > F.cascade_far[cascade]) cascade++;
    return medium_shadow(atlas, cascade, p);
}

// The LPV's radiance at x scattered by a Henyey–Greenstein medium into propagation direction
// w: the cell's intensity over its cross-section s² is radiance, and convolving two-band SH
// with HG scales band l by g^l (Funk–Hecke), so band 0 alone is the mean over the sphere —
// the isotropic answer. Hardware trilinear inside the finest cascade that holds x (the fog's
// own averaging hides the missing blend between cascades); clamped at 0 because two-band SH
// dips below zero behind a lobe.
vec3 medium_lpv_radiance(sampler3D r, sampler3D g, sampler3D b, vec3 x, vec3 w, float hg) {
    uint count = F.lpv_dims.y;
    float N = float(F.lpv_dims.x);
    vec4 basis = sh_basis(w) * vec4(1.0, hg, hg, hg);
    for (uint c = 0u; c < count; ++c) {
        float s = F.lpv_cascade[c].w;
        vec3 q = (x - F.lpv_cascade[c].xyz) / s;
        if (any(lessThan(q, vec3(0.0))) || any(greaterThan(q, vec3(N)))) continue;
        // Clamped to cell centres so the filter never reads the neighbouring cascade's slab.
        q = clamp(q, vec3(0.5), vec3(N - 0.5));
        vec3 uvw = vec3(q.xy / N, (q.z + float(c) * N) / (N * float(count)));
        vec3 L = vec3(dot(textureLod(r, uvw, 0.0), basis), dot(textureLod(g, uvw, 0.0), basis),
                      dot(textureLod(b, uvw, 0.0), basis));
        return max(L, vec3(0.0)) / (s * s);
    }
    return vec3(0.0);
}
#endif
