#ifndef LPV_SH_GLSL
#define LPV_SH_GLSL
// Two-band SH (REFERENCE.md; CPU twin engine/lpv/sh.rs). Order: Y00, Y1-1, Y10, Y11.
const float SH_Y0 = 0.28209479177;
const float SH_Y1 = 0.48860251190;
const float SH_COS0 = 0.88622692545;  // √π / 2
const float SH_COS1 = 1.02332670795;  // √(π/3)

vec4 sh_basis(vec3 d) { return vec4(SH_Y0, -SH_Y1 * d.y, SH_Y1 * d.z, -SH_Y1 * d.x); }

// Clamped cosine lobe max(0, n·ω) around unit n.
vec4 sh_cosine_lobe(vec3 n) { return vec4(SH_COS0, -SH_COS1 * n.y, SH_COS1 * n.z, -SH_COS1 * n.x); }

float sh_eval(vec4 c, vec3 d) { return dot(c, sh_basis(d)); }
#endif
