#version 460
// Sky light (the thesis' §5.3, with visibility): each cell holds the sky radiance L arriving
// from the directions of the upper hemisphere that reach the sky, as intensity I(ω) = L·s² per
// flow direction ω (the grid's intensity over the cell's cross-section is radiance, as in
// shading). Visibility is marched through the top-down height map, one map texel (a coarsest
// cell) per step, for 32 direction bins; each bin's SH integrals are exact, so a fully open
// cell holds exactly L·s²·(√π, π·Y₁ along −y, 0, 0) and a floor there reads E = πL. The
// height map is a height field: whatever is under a roof is inside it, so covered cells get
// nothing here; cells beside a covered one (horizontally) also inject their light, so
// propagation carries it under overhangs. Open cells are not injected: the sky is already
// there, and propagating it would count it once more per step.
#include "common.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits); y and z are scalar loops.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
layout(set = 0, binding = 1) uniform sampler2D height;
#define ACC_BINDING 3
#include "images.glsl"
// The injected light, flat (the accumulated grid's layout): edge cells add theirs.
layout(set = 0, binding = 2, std430) buffer Injected { vec4 v[]; } I;
layout(push_constant) uniform Sky {
    mat4 view_proj;  // world → clip of the (reduced) height map
    vec4 radiance;   // rgb sky radiance; w: the map's texel edge in metres
} P;

const int AZIMUTHS = 8;
const float BANDS[5] = float[5](0.0, 0.5235988, 0.9599311, 1.3089969, 1.5707963);  // 0, 30, 55, 75, 90°

// Depth of a world point in the map and whether it lies over the map.
bool project(vec3 p, out vec2 uv, out float depth) {
    vec4 clip = P.view_proj * vec4(p, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    uv = ndc.xy * 0.5 + 0.5;
    depth = ndc.z;
    return all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)));
}

// Below the highest surface of its map column (outside the map nothing covers it).
bool covered(vec3 p) {
    vec2 uv;
    float depth;
    return project(p, uv, depth) && depth > textureLod(height, uv, 0.0).r;
}

// Whether the ray from p along unit d (d.y > 0) escapes: leaves the map or rises above
// everything (depth 0 is the map's top), never passing under a column's top.
bool escapes(vec3 p, vec3 d) {
    float step_len = P.radiance.w * 0.5;
    for (int i = 1; i < 512; ++i) {
        vec2 uv;
        float depth;
        if (!project(p + d * (step_len * float(i)), uv, depth) || depth <= 0.0) return true;
        if (depth > textureLod(height, uv, 0.0).r) return false;
    }
    return true;
}

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    ivec3 cell = ivec3(id.x, id.y, id.z % n);
    float s = L.cascade[c].w;
    vec3 centre = L.cascade[c].xyz + (vec3(cell) + 0.5) * s;
    if (covered(centre)) return;
    // Σ over visible bins of ∫ Y(ω) dω with ω = −d, in the basis order (Y₀₀, Y₁₋₁ ∝ −y,
    // Y₁₀ ∝ z, Y₁₁ ∝ −x): (Y₀·A, Y₁·∫d.y, −Y₁·∫d.z, Y₁·∫d.x).
    vec4 field = vec4(0.0);
    for (int b = 0; b < 4; ++b) {
        float ta = BANDS[b], tb = BANDS[b + 1];
        float i_sin2 = 0.5 * (tb - ta) - 0.25 * (sin(2.0 * tb) - sin(2.0 * ta));
        for (int a = 0; a < AZIMUTHS; ++a) {
            float pa = 2.0 * PI * float(a) / float(AZIMUTHS), pb = 2.0 * PI * float(a + 1) / float(AZIMUTHS);
            float t = 0.5 * (ta + tb), ph = 0.5 * (pa + pb);
            vec3 d = vec3(sin(t) * cos(ph), cos(t), sin(t) * sin(ph));
            if (!escapes(centre, d)) continue;
            float dphi = pb - pa;
            float area = dphi * (cos(ta) - cos(tb));
            float iy = dphi * 0.5 * (sin(tb) * sin(tb) - sin(ta) * sin(ta));
            float ix = (sin(pb) - sin(pa)) * i_sin2;
            float iz = (cos(pa) - cos(pb)) * i_sin2;
            field += vec4(SH_Y0 * area, SH_Y1 * iy, -SH_Y1 * iz, SH_Y1 * ix);
        }
    }
    field *= s * s;
    vec4 v[3] = vec4[3](field * P.radiance.r, field * P.radiance.g, field * P.radiance.b);
    accumulate(ivec3(id), v);
    bool edge = false;
    for (int i = 0; i < 6; ++i) {
        if (DIRS[i].y != 0) continue;  // horizontal neighbours only
        if (in_grid(cell + DIRS[i]) && covered(centre + vec3(DIRS[i]) * s)) edge = true;
    }
    if (edge) {
        uint texels = flat_channel();
        uint i = cell_linear(ivec3(id));
        for (uint ch = 0u; ch < 3u; ++ch) I.v[ch * texels + i] += v[ch];
    }
}
