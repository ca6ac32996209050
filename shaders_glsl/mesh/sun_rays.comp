#version 460
// Screen-space sun rays (Mitchell, "Volumetric light scattering as a post-process", GPU Gems 3):
// every pixel marches toward the sun's screen position and sums, with a weight that decays per
// sample, the samples that see the sky (depth 1: nothing occludes the view, and so the sun's
// direction past the geometry); the sum times the sun's colour is added to the HDR image.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) uniform sampler2D depth_tex;
layout(set = 0, binding = 1, rgba32f) uniform image2D hdr;
layout(push_constant) uniform Rays {
    vec4 sun;    // xy: the sun's screen position (uv, may lie off screen)
    vec4 color;  // rgb: radiance added per sample that sees the sky (already / samples), a: decay
    uint samples;
} P;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr);
    if (any(greaterThanEqual(p, size))) return;
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    vec2 delta = P.sun.xy - uv;
    // Toward an off-screen sun, march one screen length at most: farther samples would all be
    // off screen, and the blur's length would otherwise jump as the sun nears the horizon of
    // the view.
    float len = length(delta);
    if (len > 1.0) delta /= len;
    delta /= float(P.samples);
    vec2 q = uv;
    float w = 1.0, sum = 0.0;
    for (uint i = 0u; i < P.samples; ++i) {
        q += delta;
        // Off screen nothing is known about occlusion: stop, adding nothing.
        if (any(lessThan(q, vec2(0.0))) || any(greaterThanEqual(q, vec2(1.0)))) break;
        float d = texelFetch(depth_tex, min(ivec2(q * vec2(size)), size - 1), 0).r;
        sum += d >= 1.0 ? w : 0.0;
        w *= P.color.a;
    }
    if (sum > 0.0) {
        vec4 c = imageLoad(hdr, p);
        imageStore(hdr, p, vec4(c.rgb + P.color.rgb * sum, c.a));
    }
}
