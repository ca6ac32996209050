#version 460
// One iteration of the edge-avoiding à-trous wavelet filter (Dammertz et al. 2010; SVGF,
// Schied et al. 2017): a 5×5 B3-spline kernel whose taps lie pc.step pixels apart, each tap
// weighted by how much its features agree with the centre's (depth relative to the local depth
// slope, normal, albedo, transmittance to the background) and by its luminance difference over
// σ_l times the centre's standard deviation (3×3-prefiltered, as SVGF). The variance is filtered
// with the squared weights, so later iterations, and later frames of a view, filter less: as the
// samples accumulate the deviation, and with it every weight but the centre's, goes to 0, and the
// image to the unbiased mean.
// Storage: the filtered image is kept as its difference from the unbiased mean (fp32, `mean_img`)
// in half floats (rgb; a: the standard deviation), so 8 bytes a pixel carry it, a pixel the filter
// leaves alone holds an exact 0 (the shown image is then the mean bit for bit), and half floats'
// rounding, 2⁻¹² of the difference, stays far below the noise the filter removes.
#include "features.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D mean_img;
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D src;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D dst;
layout(set = 0, binding = 3, rg32ui) uniform readonly uimage2D features;
layout(push_constant) uniform Push { int step; float sigma_l; uint last; uint flags; } pc;

// Test switches (flags): bit 0 ignores the variance (a fixed luminance scale), bit 1 the
// features; the tests use them to show that their checks can fail.
const float KERNEL[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
// The feature terms are soft guides: a volume's image does not break where its features change a
// little (a CT's albedo and gradient normal vary from pixel to pixel with its texture), and SVGF's
// surface-strict scales (σ_z 1, σ_a 0.08, σ_t 0.15, normal power 4) kept 2–4× the error they
// could remove on the CT and MR scenes (docs/denoising.md). Ten times softer exponents still stop
// a real edge (an albedo step of 0.5, a depth step of a few voxels: tests/volume_denoise.rs),
// and the bias a soft guide lets through is the shrink's to take back (denoise_shrink.comp).
const float SIGMA_Z = 10.0;
const float SIGMA_A = 0.25;
const float SIGMA_T = 0.47;
const float NORMAL_POWER = 0.4;
const float TAU = 0.04;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(dst);
    if (any(greaterThanEqual(p, size))) return;
    vec4 d = imageLoad(src, p);
    vec3 mp = imageLoad(mean_img, p).rgb;
    vec3 c = mp + d.rgb;
    float var = 0.0;
    for (int k = 0; k < 9; ++k) {  // 3×3 Gaussian of the variance around p
        ivec2 o = ivec2(k % 3 - 1, k / 3 - 1);
        float sd = imageLoad(src, clamp(p + o, ivec2(0), size - 1)).a;
        float g = (o.x == 0 ? 0.5 : 0.25) * (o.y == 0 ? 0.5 : 0.25);  // 1/4, 1/8, 1/16
        var += g * sd * sd;
    }
    float l = dot(LUMINANCE, c);
    bool blind = (pc.flags & 1u) != 0u;
    float scale = blind ? 0.1 : pc.sigma_l * sqrt(var);
    // Consistency: the luminance test alone lets a flat region's taps through however many paths
    // the pixels have, and their small true differences add up to a bias that does not fall
    // with the noise. The shrink after the last iteration (denoise_shrink.comp) takes such a bias
    // back toward the mean; beside it every tap but the centre weighs (relative deviation / TAU)²,
    // capped at 1: full strength while the pixel's own relative error is above TAU, then fading
    // as 1/n, faster than the noise (1/√n), and off below TAU / 4 (1 %), where the little it could
    // still remove is not worth the bias it risks: the filtered image equals the mean from there.
    float rel2 = var / max(l * l, 1e-30);
    float fade = blind ? 1.0 : (rel2 < TAU * TAU / 16.0 ? 0.0 : min(1.0, rel2 / (TAU * TAU)));
    if (fade == 0.0) {  // only the centre weighs: the pixel passes unchanged, its deviation too
        imageStore(dst, p, vec4(d.rgb, pc.last != 0u ? 1.0 : d.a));
        return;
    }
    Feature f = unpack_feature(imageLoad(features, p).xy);
    // The depth's slope per pixel here, the smaller one-sided difference along each axis (a
    // pixel beside a depth edge keeps its own side's slope): how far a tap may lie on its surface.
    float z[4];
    for (int k = 0; k < 4; ++k) {
        ivec2 o = ivec2(k < 2 ? 2 * k - 1 : 0, k < 2 ? 0 : 2 * k - 5);
        z[k] = abs(uintBitsToFloat(imageLoad(features, clamp(p + o, ivec2(0), size - 1)).x) - f.depth);
    }
    float slope = max(min(z[0], z[1]), min(z[2], z[3]));
    float inv_scale = 1.0 / max(scale, 1e-20);
    bool use_features = (pc.flags & 2u) == 0u;
    vec3 sum = vec3(0.0);
    float wsum = 0.0, vsum = 0.0;
    for (int k = 0; k < 25; ++k) {
        ivec2 o = ivec2(k % 5 - 2, k / 5 - 2);
        ivec2 q = p + o * pc.step;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        vec4 dq = imageLoad(src, q);
        float w = KERNEL[abs(o.x)] * KERNEL[abs(o.y)];
        vec3 diff = dq.rgb - d.rgb;
        if (o != ivec2(0)) {
            diff += imageLoad(mean_img, q).rgb - mp;
            // Every edge-stopping term is a Gaussian or Laplacian factor: their product is one
            // exponential of the summed exponents (and the normal's cosine to the 4th power).
            float e = abs(dot(LUMINANCE, diff)) * inv_scale;
            float wn = 1.0;
            if (use_features) {
                Feature g = unpack_feature(imageLoad(features, q).xy);
                bool hits = (f.depth >= 0.0) == (g.depth >= 0.0);
                e += abs(f.depth - g.depth) / (SIGMA_Z * slope * length(vec2(o * pc.step)) + 1e-3);
                vec3 da = abs(f.albedo - g.albedo);
                float dt = f.transmittance - g.transmittance;
                e += dot(da, da) * (1.0 / (SIGMA_A * SIGMA_A)) + dt * dt * (1.0 / (SIGMA_T * SIGMA_T));
                wn = hits ? pow(max(dot(f.normal, g.normal), 0.0), NORMAL_POWER) : 0.0;
            }
            w *= exp(-e) * wn * fade;
        }
        sum += w * diff;
        wsum += w;
        vsum += w * w * dq.a * dq.a;
    }
    // The centre plus the taps' weighted differences from it (the centre's weight is never 0):
    // where every other tap weighs 0 the pixel passes unchanged, not rounded through w·c / w.
    float out_sd = sqrt(vsum) / wsum;
    imageStore(dst, p, vec4(d.rgb + sum / wsum, pc.last != 0u ? 1.0 : out_sd));
}
