#version 460
// Placeholder scene until the renderers land: an analytic sphere lit by a directional light
// over a sky gradient, in linear HDR. Exercises the engine path end to end (graph, tone map, PNG).
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform writeonly image2D hdr;
layout(push_constant) uniform Push { vec4 light_dir; float time; } pc;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(hdr);
    if (any(greaterThanEqual(p, size))) return;
    vec2 uv = (vec2(p) + 0.5) / vec2(size) * 2.0 - 1.0;
    uv.x *= float(size.x) / float(size.y);
    vec3 ro = vec3(0.0, 0.0, 3.0);
    vec3 rd = normalize(vec3(uv.x, -uv.y, -2.0));
    vec3 sky = mix(vec3(0.9, 0.95, 1.0), vec3(0.25, 0.45, 0.9), clamp(-rd.y * 0.5 + 0.5, 0.0, 1.0));
    float b = dot(ro, rd);
    float c = dot(ro, ro) - 1.0;
    float h = b * b - c;
    vec3 col = sky;
    if (h > 0.0) {
        vec3 n = normalize(ro + rd * (-b - sqrt(h)));
        vec3 l = normalize(pc.light_dir.xyz);
        col = vec3(0.9, 0.35, 0.2) * (max(dot(n, l), 0.0) * 3.0 + 0.15 * (0.5 + 0.5 * n.y));
    }
    imageStore(hdr, p, vec4(col, 1.0));
}
