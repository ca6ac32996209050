// Temperature-driven emission (`engine/volume/render/temperature.rs`): kelvin per voxel on the
// volume's grid, and the blackbody table over a range of kelvin. Read by the Monte Carlo
// renderers' emission (`mc_common.glsl`) and by EAM's colour.
layout(set = 0, binding = 27) uniform sampler3D temperature_tex;
layout(set = 0, binding = 28) uniform sampler2D planck_tex;

// The blackbody radiance at texture-space point `uvw`'s temperature over `range` kelvin (normalised
// to luminance 1 at its top): nothing below the range, the hottest texel's above it.
vec3 blackbody_at(vec3 uvw, vec2 range) {
    float u = (texture(temperature_tex, uvw).r - range.x) / (range.y - range.x);
    float n = float(textureSize(planck_tex, 0).x);
    vec3 b = texture(planck_tex, vec2((clamp(u, 0.0, 1.0) * (n - 1.0) + 0.5) / n, 0.5)).rgb;
    return u < 0.0 ? vec3(0.0) : b;
}
