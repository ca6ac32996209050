#version 460
// One propagation step (REFERENCE.md): a source cell's intensity I(ω) is evaluated toward the
// five faces of each neighbour that do not face it, times the face's solid angle from the
// source centre (front 0.4006696846 sr, side 0.4234313544 sr: 6 × (front + 4 sides) = 4π;
// REFERENCE.md misprints the side as 0.42344…),
// attenuated by 1 - B(ω) of the geometry volume at the face between the two cells, and
// re-emitted into the neighbour as a clamped cosine lobe along the face normal. GATHER: each
// cell pulls from its six neighbours and adds the result to the accumulation; SCATTER: each cell
// pushes into its six neighbours with float atomics into a flat buffer (resolve.comp turns it
// into the step's images and accumulates it).
#extension GL_EXT_shader_atomic_float : enable
#include "common.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits); y and z are scalar loops.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
#define SRC_BINDING 1
#ifdef SCATTER
layout(set = 0, binding = 4, std430) buffer Dst { float v[]; } B;
#else
#define DST_BINDING 4
#define ACC_BINDING 7
#endif
#include "images.glsl"
#ifdef SCATTER
layout(set = 0, binding = 5) uniform sampler3D gv;
#else
layout(set = 0, binding = 10) uniform sampler3D gv;
#endif
#ifdef DIRECTIONAL
layout(set = 0, binding = 11, rgba32f) readonly uniform image3D normals;
#endif

const float FRONT = 0.4006696846;
const float SIDE = 0.4234313544;

// Blocking SH of one GV source at a point in GV lattice units (lattice points at integer
// coordinates): trilinear, by the sampler. Face centres sit at whole and half lattice
// coordinates, so the filter weights (0, ½, 1) are exact at any sub-texel precision.
vec4 gv_at(uint source, uint c, vec3 q) {
    float m = float(gv_block());
    vec3 t = q + 0.5 + vec3(0.0, 0.0, float(source * L.dims.y + c) * m);
    return textureLod(gv, t / vec3(textureSize(gv, 0)), 0.0);
}

// Contribution of source coefficients `src` (3 channels) across the shared face toward a
// neighbour at offset d (from source to destination), added to `out3`.
void transfer(uint c, ivec3 src_cell, ivec3 d, vec4 src[3], inout vec4 out3[3]) {
    bool occlude = (L.dims.w & 1u) != 0u;
    // The face between the two cells, in GV lattice units.
    // Both sources see the same surfaces where they overlap: combine by max, not sum.
    vec3 q = vec3(src_cell) + 0.5 + 0.5 * vec3(d);
    vec4 gv_rsm = occlude ? gv_at(0u, c, q) : vec4(0.0);
    vec4 gv_cam = occlude && L.gbuffer.w != 0u ? gv_at(1u, c, q) : vec4(0.0);
    vec3 dn = vec3(d);
    bool swapped = (L.dims.w & 4u) != 0u;
    for (int f = 0; f < 5; ++f) {
        vec3 face_n;
        vec3 w;
        float solid;
        if (f == 0) {
            face_n = dn;
            w = dn;
            solid = swapped ? SIDE : FRONT;
        } else {
            // The four sides: axes perpendicular to d, both signs.
            int axis = (abs(d.x) == 1) ? (f <= 2 ? 1 : 2) : (abs(d.y) == 1 ? (f <= 2 ? 0 : 2) : (f <= 2 ? 0 : 1));
            vec3 side = vec3(0.0);
            side[axis] = (f % 2 == 1) ? 1.0 : -1.0;
            face_n = side;
            w = normalize(dn + 0.5 * side);
            solid = swapped ? FRONT : SIDE;
        }
        float blocking = max(sh_eval(gv_rsm, w), sh_eval(gv_cam, w));
        float vis = occlude ? 1.0 - clamp(blocking, 0.0, 1.0) : 1.0;
        vec4 lobe = sh_cosine_lobe(face_n) * (solid * vis / PI);
        for (int ch = 0; ch < 3; ++ch) out3[ch] += sh_eval(src[ch], w) * lobe;
    }
}

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    ivec3 cell = ivec3(id.x, id.y, id.z % n);
#ifdef SCATTER
    vec4 src[3];
    load_src(ivec3(id), src);
    for (int i = 0; i < 6; ++i) {
        ivec3 dst = cell + DIRS[i];
        if (!in_grid(dst)) continue;  // light leaving the grid is gone
        vec4 o[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
        transfer(c, cell, DIRS[i], src, o);
        uint cl = cell_linear(dst);
        for (uint ch = 0u; ch < 3u; ++ch) {
            for (uint k = 0u; k < 4u; ++k) atomicAdd(B.v[light_index(c, ch * 4u + k, cl)], o[ch][k]);
        }
    }
#else
    vec4 o[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
    for (int i = 0; i < 6; ++i) {
        ivec3 from = cell - DIRS[i];
        if (!in_grid(from)) continue;
        vec4 src[3];
        load_src(grid_texel(c, from), src);
        transfer(c, from, DIRS[i], src, o);
    }
#ifdef DIRECTIONAL
    // The thesis' second re-projection: keep only the intensity toward the cell's dilated VPL
    // normal, as a clamped-cosine lobe around it. Divided by the 2-band lobe's own value at its
    // axis (0.75, not 1), so a lobe along the normal passes unchanged; the thesis' version
    // without it removes a quarter of the light every step.
    vec4 nd = imageLoad(normals, ivec3(id));
    if (nd.w > 0.0) {
        vec4 lobe = sh_cosine_lobe(nd.xyz);
        vec4 unit = lobe / sh_eval(lobe, nd.xyz);
        for (int ch = 0; ch < 3; ++ch) o[ch] = max(0.0, sh_eval(o[ch], nd.xyz)) * unit;
    }
#endif
    store_dst(ivec3(id), o);
    accumulate(ivec3(id), o);
#endif
}
