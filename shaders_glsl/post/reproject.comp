#version 460
// Temporal reuse, once per new view: the previous view's integrated image (denoise_blend.comp's
// output: colour and its age in samples) reprojected into this view through the feature depth.
// Each pixel's feature point is projected into the previous view; of the four pixels around it,
// those whose own feature point lies within a tolerance of it and whose normal and albedo agree
// (not a disocclusion, not another layer of a thin structure) are blended bilinearly. The result
// is clamped to the box of mean ± γσ of this view's first samples in the pixel's 3×3
// neighbourhood (what the history may still say) and written with its age as this view's prior.
// Nothing here touches the unbiased mean: the prior feeds only the shown image.
#include "features.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, std140) uniform Params { mat4 inv_view_proj; } P;  // volume/common.glsl's prefix
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D mean_img;
layout(set = 0, binding = 2, rg32ui) uniform readonly uimage2D feat_cur;
layout(set = 0, binding = 3, rg32ui) uniform readonly uimage2D feat_prev;
layout(set = 0, binding = 4, rgba16f) uniform readonly image2D integrated;
layout(set = 0, binding = 5, rgba16f) uniform writeonly image2D prior;
// flags bit 2 (DenoiseSettings::debug_flags): accept every tap, unclamped (a test shows a ghost).
layout(push_constant) uniform Push { mat4 inv_view_proj_prev; uint flags; } pc;

const float GAMMA = 2.0;

vec3 ray_point(mat4 inv, vec2 pixel, ivec2 size, float depth) {
    vec2 ndc = pixel / vec2(size) * 2.0 - 1.0;
    ndc.y = -ndc.y;
    vec4 n = inv * vec4(ndc, 0.0, 1.0);
    vec4 f = inv * vec4(ndc, 1.0, 1.0);
    vec3 o = n.xyz / n.w;
    return o + normalize(f.xyz / f.w - o) * depth;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(mean_img);
    if (any(greaterThanEqual(p, size))) return;
    Feature f = unpack_feature(imageLoad(feat_cur, p).xy);
    vec4 result = vec4(0.0);  // age 0: no history
    if (f.depth >= 0.0) {
        vec3 x = ray_point(P.inv_view_proj, vec2(p) + 0.5, size, f.depth);
        vec4 clip = inverse(pc.inv_view_proj_prev) * vec4(x, 1.0);
        bool keep_all = (pc.flags & 4u) != 0u;
        vec2 ndc = clip.xy / clip.w;
        vec2 q = vec2(ndc.x, -ndc.y) * 0.5 + 0.5;
        q = q * vec2(size) - 0.5;  // continuous pixel coordinates (centres at integers)
        ivec2 q0 = ivec2(floor(q));
        vec2 fr = q - vec2(q0);
        float tol = 0.01 + 0.03 * f.depth;
        vec4 acc = vec4(0.0);
        float wsum = 0.0;
        for (int k = 0; k < 4; ++k) {  // the four pixels around the reprojected point
            ivec2 o = ivec2(k & 1, k >> 1);
            ivec2 s = q0 + o;
            if (clip.w <= 0.0 || any(lessThan(s, ivec2(0))) || any(greaterThanEqual(s, size))) continue;
            Feature g = unpack_feature(imageLoad(feat_prev, s).xy);
            if (g.depth < 0.0 && !keep_all) continue;
            vec3 y = ray_point(pc.inv_view_proj_prev, vec2(s) + 0.5, size, g.depth);
            bool same = distance(x, y) <= tol && dot(f.normal, g.normal) >= 0.3
                && all(lessThanEqual(abs(f.albedo - g.albedo), vec3(0.1)));
            if (!same && !keep_all) continue;
            float w = (o.x == 1 ? fr.x : 1.0 - fr.x) * (o.y == 1 ? fr.y : 1.0 - fr.y);
            acc += w * imageLoad(integrated, s);
            wsum += w;
        }
        if (wsum > 1e-3) {
            vec4 h = acc / wsum;
            vec3 m1 = vec3(0.0), m2 = vec3(0.0);
            for (int k = 0; k < 9; ++k) {  // this view's first samples around p
                ivec2 s = clamp(p + ivec2(k % 3 - 1, k / 3 - 1), ivec2(0), size - 1);
                vec3 c = imageLoad(mean_img, s).rgb;
                m1 += c;
                m2 += c * c;
            }
            m1 /= 9.0;
            vec3 sd = sqrt(max(m2 / 9.0 - m1 * m1, 0.0));
            result = keep_all ? h : vec4(clamp(h.rgb, m1 - GAMMA * sd, m1 + GAMMA * sd), h.a);
        }
    }
    imageStore(prior, p, result);
}
