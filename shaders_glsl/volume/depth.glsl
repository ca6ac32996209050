#ifndef VOLUME_DEPTH_GLSL
#define VOLUME_DEPTH_GLSL
// Depth output for the ray marchers: the ray distance where the accumulated opacity 1 - T first
// reaches a threshold, solved inside the crossing segment from its own extinction (the segment
// is homogeneous in the marcher's model, so a homogeneous medium gets the exact distance rather
// than the segment's end), plus its Vulkan NDC depth for compositing with rasterized scenes.

// Updates `depth` (< 0 until found) with the segment [a, b] of extinction `sigma`, entered with
// transmittance `t0`; `target` = 1 - threshold.
void depth_segment(inout float depth, float t0, float sigma, float a, float b, float target) {
    if (depth >= 0.0 || t0 * exp(-sigma * (b - a)) > target) return;
    // t0 > target here (earlier segments did not cross), so the log is positive and finite.
    depth = a + (sigma > 0.0 ? min(log(t0 / target) / sigma, b - a) : 0.0);
}

// (ray distance, NDC depth, 1) for a hit, (-1, 1, 0) for a miss: NDC 1 is the far plane.
vec4 depth_texel(Ray r, float depth) {
    if (depth < 0.0) return vec4(-1.0, 1.0, 0.0, 0.0);
    vec4 clip = inverse(P.inv_view_proj) * vec4(r.o + r.d * depth, 1.0);
    return vec4(depth, clip.z / clip.w, 1.0, 0.0);
}
#endif
