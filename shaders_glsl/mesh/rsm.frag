#version 460
// Reflective shadow map (Dachsbacher & Stamminger 2005): per texel the first surface the light
// sees, its normal, and the flux it reflects diffusely. Sun: the texel's beam carries E·A_texel
// whatever the surface's orientation; spot: I·dω of the texel's solid angle, with the cone's
// falloff. Reflected flux = albedo × incident flux. Surfaces are double-sided: the light lights
// the side it sees, so the stored normal is the one facing the light.
#include "frame.glsl"
#include "material.glsl"
layout(location = 0) in vec3 v_pos;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) in vec4 v_tangent;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_flux;

void main() {
    vec4 albedo = material_albedo(v_uv);
    vec3 n = normalize(v_normal);
    vec3 incident;
    vec3 to_light;
    if (F.rsm_light.x == 0.0) {
        to_light = normalize(F.sun_dir.xyz);
        incident = F.sun_irradiance.rgb * F.rsm_light.y;
    } else {
        uint s = uint(F.rsm_light.w);
        vec3 d = v_pos - F.spot_pos[s].xyz;
        float dist = length(d);
        vec3 w = d / max(dist, 1e-9);
        to_light = -w;
        // Solid angle of this texel: (2 tan(θ/2) / N)² · cos³ of the angle off the axis.
        float cos_axis = dot(w, F.spot_dir[s].xyz);
        float texel = 2.0 * F.rsm_light.y / F.rsm_light.z;
        float d_omega = texel * texel * cos_axis * cos_axis * cos_axis;
        float cone = cone_falloff(cos_axis, F.spot_dir[s].w, F.spot_intensity[s].a);
        incident = F.spot_intensity[s].rgb * cone * d_omega;
    }
    if (dot(n, to_light) < 0.0) n = -n;
    out_position = vec4(v_pos, 1.0);
    out_normal = vec4(n, D.translucency);  // w: the LPVs split the flux by it
    out_flux = vec4(albedo.rgb * incident, 1.0);
}
