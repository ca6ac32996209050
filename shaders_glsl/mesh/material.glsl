#ifndef MESH_MATERIAL_GLSL
#define MESH_MATERIAL_GLSL
// Material textures (fallbacks are bound when a material has none: white colour, flat normal).
layout(set = 0, binding = 1) uniform sampler2D base_color_tex;
layout(set = 0, binding = 2) uniform sampler2D normal_tex;
layout(set = 0, binding = 3) uniform sampler2D specular_tex;

// Base colour × texture; discards alpha-masked fragments below the cutoff.
vec4 material_albedo(vec2 uv) {
    vec4 c = D.base_color * texture(base_color_tex, uv);
    if ((D.flags & 1u) != 0u && c.a < D.cutoff) discard;
    return c;
}

// NO_MAPS: a variant for materials with neither normal nor specular map (the renderer picks it),
// which leaves out both lookups: llvmpipe runs a branch on the material's flags for every
// fragment whichever way it goes.

// Shading normal from the interpolated normal, tangent and the tangent-space normal map.
vec3 material_normal(vec3 n, vec4 t, vec2 uv, bool front) {
    n = normalize(n);
    if (!front) n = -n;  // double-sided: light the side the viewer sees
#ifdef NO_MAPS
    return n;
#else
    if ((D.flags & 2u) == 0u || dot(t.xyz, t.xyz) < 1e-12) return n;
    vec3 T = normalize(t.xyz - n * dot(n, t.xyz));
    vec3 B = cross(n, T) * (t.w < 0.0 ? -1.0 : 1.0);
    vec3 m = texture(normal_tex, uv).xyz * 2.0 - 1.0;
    vec3 r = normalize(T * m.x + B * m.y + n * max(m.z, 1e-3));
    return r;
#endif
}

// Specular colour: the material's times its specular map (the white fallback when it has none).
vec3 material_specular(vec2 uv) {
#ifdef NO_MAPS
    return D.specular.rgb;
#else
    return D.specular.rgb * texture(specular_tex, uv).rgb;
#endif
}
#endif
