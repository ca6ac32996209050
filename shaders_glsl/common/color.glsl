#ifndef COMMON_COLOR_GLSL
#define COMMON_COLOR_GLSL
// Display transforms (REFERENCE.md, "Tone mapping"): accumulate in linear HDR, tone-map only for display.

// Reinhard with exposure e: L / (1/e + L).
vec3 tonemap_reinhard(vec3 l, float exposure) { return l / (1.0 / max(exposure, 1e-6) + l); }

// Range mapping (L - lo) / (hi - lo), clamped.
vec3 tonemap_range(vec3 l, float lo, float hi) { return clamp((l - lo) / max(hi - lo, 1e-6), 0.0, 1.0); }

// ACES filmic curve, Narkowicz 2015 fit.
vec3 tonemap_aces(vec3 x) { return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }

// IEC 61966-2-1 sRGB encode of a linear value in [0,1].
vec3 srgb_encode(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}
#endif
