#version 460
// The last step of the denoiser: shrink the filtered image's difference from the unbiased mean,
// d = f − m, by β = s² / E[d²] (a Wiener shrink, the MSE-optimal blend m + β (f − m)). With s²
// the variance of the mean and b the filter's bias, E[d²] ≈ s² + var(f) + b², so where the filter
// only removed noise β ≈ 1 and the filtered image is shown, and where it moved the image off the
// true value (b² ≫ s², which any fixed-strength filter does once enough paths make s small) β
// falls like s² / b² and the shown image goes to the mean: the filter stays consistent without a
// fixed fade, and is never worse than the mean by more than its estimate's error. Both sums run
// over the 5×5 neighbourhood (luminance), as the bias of a wide filter is smooth and one pixel's
// d² is mostly its own noise. Below 4 paths the moments' variance is noise itself: β = 1 there.
#include "features.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D moments;
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D filtered;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D dst;
// flags bit 3: no shrink (β = 1), for the tests that show their checks can fail.
layout(push_constant) uniform Push { uint flags; } pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(dst);
    if (any(greaterThanEqual(p, size))) return;
    vec4 d = imageLoad(filtered, p);
    float beta = 1.0;
    if ((pc.flags & 8u) == 0u && imageLoad(moments, p).a >= 4.0) {
        float dd = 0.0, ss = 0.0;
        for (int k = 0; k < 25; ++k) {
            ivec2 q = clamp(p + ivec2(k % 5 - 2, k / 5 - 2), ivec2(0), size - 1);
            vec4 s = imageLoad(moments, q);
            float n = max(s.a, 2.0);
            // The luminance's standard deviation as the channels' summed (an upper bound: they
            // correlate), as the blend does.
            float sd = dot(LUMINANCE, sqrt(max(s.rgb / (n * (n - 1.0)), 0.0)));
            float l = dot(LUMINANCE, imageLoad(filtered, q).rgb);
            dd += l * l;
            ss += sd * sd;
        }
        beta = dd > ss ? ss / dd : 1.0;
    }
    imageStore(dst, p, vec4(d.rgb * beta, 1.0));
}
