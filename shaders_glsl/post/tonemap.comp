#version 460
// Linear HDR -> display: tone map (Reinhard with exposure, range, or ACES filmic fit), sRGB
// encode, write 8-bit. ADD_IMAGE: of hdr plus a second image (the denoiser's difference from the
// mean, post/atrous.comp).
#include "../common/color.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D hdr;
#ifdef ADD_IMAGE
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D added;
layout(set = 0, binding = 2, rgba8) uniform writeonly image2D ldr;
#else
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D ldr;
#endif
layout(push_constant) uniform Push { uint mode; float exposure; float lo; float hi; } pc;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(ldr)))) return;
    vec3 l = imageLoad(hdr, p).rgb;
#ifdef ADD_IMAGE
    l += imageLoad(added, p).rgb;
#endif
    vec3 t = pc.mode == 0u ? tonemap_reinhard(l, pc.exposure)
           : pc.mode == 1u ? tonemap_range(l, pc.lo, pc.hi)
           : tonemap_aces(l * pc.exposure);
    imageStore(ldr, p, vec4(srgb_encode(t), 1.0));
}
