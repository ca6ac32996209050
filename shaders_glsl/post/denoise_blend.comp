#version 460
// The denoiser's input: this view's unbiased mean blended with the prior reprojected from earlier
// views (reproject.comp; age a samples, 0 without one) by sample count, c = (a·prior + n·mean) /
// (a + n) = mean + a / (a + n) · (prior − mean), so the prior's weight falls as the view's own paths accumulate and a stopped camera
// converges to the mean. Beside it, c's standard deviation (luminance) for the à-trous filter:
// the mean's from the moments image, M2 / (n (n − 1)) per channel, summed as standard
// deviations (an upper bound of the luminance's: the channels correlate); below 4 paths, where
// that estimate is itself noise, the spread of the 3×3 neighbourhood's means (SVGF's spatial
// fallback). The prior is taken to carry the same per-path variance: c's variance is then
// n·var(mean) / (a + n). The integrated colour and its age (capped) are kept for the next view.
// The filter's input is written as its difference from the mean, c − m (atrous.comp's storage):
// exactly 0 without a prior.
#include "features.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D mean_img;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D moments;
layout(set = 0, binding = 2, rgba16f) uniform readonly image2D prior;
layout(set = 0, binding = 3, rgba16f) uniform writeonly image2D integrated;
layout(set = 0, binding = 4, rgba16f) uniform writeonly image2D filter_in;
layout(push_constant) uniform Push { float age_cap; uint use_prior; } pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(mean_img);
    if (any(greaterThanEqual(p, size))) return;
    vec3 m = imageLoad(mean_img, p).rgb;
    vec4 s = imageLoad(moments, p);
    float n = s.a;
    float sd;
    if (n >= 4.0) {
        sd = dot(LUMINANCE, sqrt(max(s.rgb / (n * (n - 1.0)), 0.0)));
    } else {
        float l1 = 0.0, l2 = 0.0;
        for (int k = 0; k < 9; ++k) {
            ivec2 q = clamp(p + ivec2(k % 3 - 1, k / 3 - 1), ivec2(0), size - 1);
            float l = dot(LUMINANCE, imageLoad(mean_img, q).rgb);
            l1 += l;
            l2 += l * l;
        }
        sd = sqrt(max(l2 / 9.0 - l1 * l1 / 81.0, 0.0) * 9.0 / 8.0);
    }
    vec4 h = pc.use_prior != 0u ? imageLoad(prior, p) : vec4(0.0);
    float a = h.a;
    // The prior's share of its difference from the mean: exactly 0 without a prior.
    vec3 delta = a > 0.0 ? a / (a + n) * (h.rgb - m) : vec3(0.0);
    float nn = max(n, 1.0);
    imageStore(integrated, p, vec4(m + delta, min(a + n, pc.age_cap)));
    imageStore(filter_in, p, vec4(delta, sd * sqrt(nn / (a + nn))));
}
