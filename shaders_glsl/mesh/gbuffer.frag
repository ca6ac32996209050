#version 460
// G-buffer: albedo, world normal, Blinn–Phong specular (rgb; a = log2(shininess) / 12, shininess
// in [1, 4096]: 8 bits give steps of 2^(12/255), 3.3 %, at every shininess — s / 4096 stored
// linearly had steps of 16, so every s below 8 came back as 1 and s = 100 as 96.4).
#include "frame.glsl"
#include "material.glsl"
layout(location = 0) in vec3 v_pos;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;
layout(location = 3) in vec4 v_tangent;
layout(location = 0) out vec4 out_albedo;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_specular;

void main() {
    vec4 albedo = material_albedo(v_uv);
    out_albedo = vec4(albedo.rgb, D.translucency);  // a: shading adds the subsurface LPV by it
    out_normal = vec4(material_normal(v_normal, v_tangent, v_uv, gl_FrontFacing), 1.0);
    vec3 ks = material_specular(v_uv);
    out_specular = vec4(ks, clamp(log2(max(D.specular.a, 1.0)) / 12.0, 0.0, 1.0));
}
