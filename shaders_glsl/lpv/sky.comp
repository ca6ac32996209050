#version 460
// Sky light (the thesis' §5.3): a cell whose centre lies above the top-down height map is open
// to the sky and holds its light: radiance L from every direction of the upper hemisphere, so
// intensity I(ω) = L·s² for downward flow ω (the grid's intensity over the cell's cross-section
// is radiance, as in shading). Its 2-band projection is L·s²·(√π, π·Y₁ along −y): a floor then
// reads E = πL, the unoccluded sky's irradiance. Open cells get it in the accumulated grid
// directly — the sky is already there, propagating it would count it once more per step — and
// only open cells beside a covered one (horizontally) also inject it, so it spreads under
// overhangs.
#include "common.glsl"
layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;
layout(set = 0, binding = 1) uniform sampler2D height;
#define ACC_BINDING 5
#include "images.glsl"
layout(set = 0, binding = 2, rgba32f) uniform image3D inj_r;
layout(set = 0, binding = 3, rgba32f) uniform image3D inj_g;
layout(set = 0, binding = 4, rgba32f) uniform image3D inj_b;
layout(push_constant) uniform Sky {
    mat4 view_proj;  // world → clip of the height map
    vec4 radiance;   // rgb sky radiance
} P;

const float SKY_C0 = 1.7724538509;  // 2π·Y₀
const float SKY_C1 = 1.5349853318;  // π·Y₁

// Whether the cell's centre is above everything the height map saw (outside the map nothing
// covers it). The centre, not the bottom: a floor on a cell boundary must not make the open
// cell above it a coin toss of rounding.
bool open_sky(uint c, ivec3 cell) {
    float s = L.cascade[c].w;
    vec3 p = L.cascade[c].xyz + (vec3(cell) + 0.5) * s;
    vec4 clip = P.view_proj * vec4(p, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return true;
    return ndc.z <= textureLod(height, uv, 0.0).r;
}

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    ivec3 cell = ivec3(id.x, id.y, id.z % n);
    if (!open_sky(c, cell)) return;
    float s = L.cascade[c].w;
    // Basis order (Y₀₀, Y₁₋₁ ∝ −y, Y₁₀ ∝ z, Y₁₁ ∝ −x): the lobe around −y.
    vec4 field = vec4(SKY_C0, SKY_C1, 0.0, 0.0) * (s * s);
    vec4 v[3] = vec4[3](field * P.radiance.r, field * P.radiance.g, field * P.radiance.b);
    accumulate(ivec3(id), v);
    bool edge = false;
    for (int i = 0; i < 4; ++i) {
        ivec3 nb = cell + ivec3(i == 0 ? 1 : (i == 1 ? -1 : 0), 0, i == 2 ? 1 : (i == 3 ? -1 : 0));
        if (in_grid(nb) && !open_sky(c, nb)) edge = true;
    }
    if (edge) {
        ivec3 t = ivec3(id);
        imageStore(inj_r, t, imageLoad(inj_r, t) + v[0]);
        imageStore(inj_g, t, imageLoad(inj_g, t) + v[1]);
        imageStore(inj_b, t, imageLoad(inj_b, t) + v[2]);
    }
}
