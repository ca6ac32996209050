#version 460
// Isosurface, pass 2 (deferred): gradient normal at the hit, Lambert + ambient from a
// directional light, albedo from the transfer function at the iso value.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D hit;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image2D hdr;
void main() {
    load_params();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr);
    if (any(greaterThanEqual(p, size))) return;
    vec4 h = imageLoad(hit, p);
    if (h.w < 0.0) { imageStore(hdr, p, vec4(P.background.rgb, 1.0)); return; }
    // Gradient points towards higher values; the outward normal points down it. Texture-space
    // derivatives are rescaled to world space by the box size per voxel.
    vec3 g = gradient(h.xyz) / (P.voxel.xyz * (P.box_max.xyz - P.box_min.xyz));
    vec3 n = length(g) > 1e-12 ? -normalize(g) : -camera_ray(p, size).d;
    vec3 albedo = label_medium(transfer(P.box_max.w, 0.0), h.xyz).rgb;
    float lambert = max(dot(n, normalize(P.light_dir.xyz)), 0.0);
    imageStore(hdr, p, vec4(albedo * (0.1 + P.background.a * lambert), 1.0));
}
