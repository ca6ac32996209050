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
#ifdef SCATTER
#define SRC_BINDING 1
layout(set = 0, binding = 4, std430) buffer Dst { float v[]; } B;
#else
// Gather reads the previous step as a flat buffer (the injected light, all cascades, or this
// cascade's own last step) and writes its own for the next step: no copy pass between steps.
#define SRC_TEXELS_BINDING 1
#ifdef DST_IMAGES
// DST_IMAGES (the last stacked Horner step): the accumulation goes straight into the three grid
// images shading samples (bindings 2–4), at each cascade's slot: no copy pass after the steps.
#define DST_BINDING 2
#define SEED_BINDING 5
#else
#define DST_BUFFER_BINDING 2
#define SEED_BINDING 3
#endif
#ifdef HORNER
// HORNER (propagation without the directional re-projection is linear, P): each step adds the
// injected light I to what it propagated, r ← I + P·r, so after k steps r = Σ_{j≤k} P^j·I, the
// accumulated grid itself, and no step reads or writes an accumulation (its read-modify-write
// cost more than the extra read of I). The last step adds the accumulation's own start instead
// (the injected light plus what the sky pass put straight into the accumulation).
#ifdef SEED_INT
// SEED_INT: the injected light is integer injection's own fixed-point buffer (common.glsl's
// light_index: a cell's 12 values together), scaled as it is read, and also step 1's source: no
// resolve pass writes a float copy of every cell (on llvmpipe its stores cost more than the
// injection). Binding 1 is then not read in step 1.
layout(set = 0, binding = SEED_BINDING, rgba32i) readonly uniform iimageBuffer seed_i;
#else
layout(set = 0, binding = SEED_BINDING, rgba32f) readonly uniform imageBuffer seed_t;
#endif
#else
#define ACC_BINDING 3
// The accumulated grid again, read as texels: its read-modify-write reads through this binding
// (a storage-buffer load loops over lanes per component on llvmpipe) and writes through A.
layout(set = 0, binding = 4, rgba32f) readonly uniform imageBuffer acc_t;
#endif
#endif
#include "images.glsl"
#include "transfer.glsl"
// GV_SOURCES (1 or 2; 0 without): geometry volumes that attenuate the light (RSM texels, camera
// pixels), read at the face between the two cells (the mean of four lattice points). A
// compile-time variant, because llvmpipe runs both sides of a branch under a lane mask: a
// runtime "occlusion off" would still pay the loads. (Transfer factors precomputed once per
// frame were tried: 128 bytes per cell and step streamed from memory cost more than reading the
// small, cache-resident GV every step, at 4 × 32³.)
#ifndef GV_SOURCES
#define GV_SOURCES 0
#endif
#ifdef HORNER
#define GV_BINDING (SEED_BINDING + 1)
#else
#define GV_BINDING 5
#endif
#if GV_SOURCES > 0
layout(set = 0, binding = GV_BINDING, rgba32f) readonly uniform image3D gv;
#define NORMALS_BINDING (GV_BINDING + 1)
// The geometry volume at every face of a cell: a face centre lies on a lattice plane and
// halfway between lattice points across it, so its trilinear value is the mean of four lattice
// points, which are corners of the cell. Each cell reads its 8 corners once per source as
// storage-image texels (llvmpipe's filtered fetch of 8 texels through the sampler, once per face
// and source, cost more) and averages them per face.
// Corner i of a cell is lattice point cell + (i & 1, (i >> 1) & 1, i >> 2).
void gv_corners(uint source, uint c, ivec3 cell, out vec4 k[8]) {
    ivec3 l = ivec3(cell.xy, cell.z + int((source * L.dims.y + c) * gv_block()));
    for (int i = 0; i < 8; ++i) k[i] = imageLoad(gv, l + ivec3(i & 1, (i >> 1) & 1, i >> 2));
}
// The j-th corner (0–3, the two other axes' bits in order) on the cell's plane P (0, 1) along A.
#define CORNER(A, P, j) ((A) == 0 ? (P) + 2 * (j) : ((A) == 1 ? 2 * (P) + ((j) & 1) + 4 * ((j) >> 1) : 4 * (P) + (j)))
#define FACE_GV(k, A, P) (0.25 * (k[CORNER(A, P, 0)] + k[CORNER(A, P, 1)] + k[CORNER(A, P, 2)] + k[CORNER(A, P, 3)]))
// The face the light crosses toward S·e_A lies on the cell's plane: gather's cell receives
// (the face behind it, plane 0 for S > 0), scatter's cell sends (the face ahead, plane 1).
#ifdef SCATTER
#define FACE_PLANE(S) ((S) > 0.0 ? 1 : 0)
#else
#define FACE_PLANE(S) ((S) > 0.0 ? 0 : 1)
#endif
// Both sources see the same surfaces where they overlap: combine by max, not sum.
#if GV_SOURCES == 1
#define BLOCKING(f, A, S, B1, B2) E_F##f(g0, A, S, B1, B2)
#define FETCH_GV(src_cell, A, S, B1, B2) vec4 g0 = FACE_GV(k0, A, FACE_PLANE(S));
#define LOAD_GV(cell) \
    vec4 k0[8];       \
    gv_corners(0u, c, cell, k0);
#else
#define BLOCKING(f, A, S, B1, B2) max(E_F##f(g0, A, S, B1, B2), E_F##f(g1, A, S, B1, B2))
#define FETCH_GV(src_cell, A, S, B1, B2)      \
    vec4 g0 = FACE_GV(k0, A, FACE_PLANE(S)); \
    vec4 g1 = FACE_GV(k1, A, FACE_PLANE(S));
#define LOAD_GV(cell)              \
    vec4 k0[8], k1[8];             \
    gv_corners(0u, c, cell, k0);   \
    gv_corners(1u, c, cell, k1);
#endif
// Face f's share: solid angle × visibility 1 − B(ω_f) / π.
#define SCALE(D, f, A, S, B1, B2) \
    (((f) == 0 ? solid_front : solid_side) * (1.0 - clamp(BLOCKING(f, A, S, B1, B2), 0.0, 1.0)) / PI)
#else
#define NORMALS_BINDING GV_BINDING
#define SCALE(D, f, A, S, B1, B2) (((f) == 0 ? solid_front : solid_side) / PI)
#define FETCH_GV(src_cell, A, S, B1, B2)
#define LOAD_GV(cell)
#endif
#ifndef SCATTER
// Gather's step schedule (specialization constants): ACCUMULATE 0 leaves the accumulated grid
// alone, 1 adds this step, 2 adds the previous step's light at this cell and this step's — the
// read-modify-write of the accumulation is a large share of a step on llvmpipe, so steps
// accumulate in pairs. STORE_STEP false: the last step, whose grid nobody reads but the
// accumulation.
layout(constant_id = 0) const uint ACCUMULATE = 1u;
layout(constant_id = 1) const bool STORE_STEP = true;
// Gather runs one cascade per dispatch (its step grids stay in the caches from step to step).
// CASCADE is the one; SRC_STACKED says the source holds all cascades (the injected grid, stacked
// along z) rather than this cascade's own n³ step grid.
layout(constant_id = 2) const uint CASCADE = 0u;
layout(constant_id = 3) const bool SRC_STACKED = true;
// HORNER: the step writes its cascade's share of a grid that holds all cascades (the last step
// of a cascade writes the accumulated grid).
layout(constant_id = 4) const bool DST_STACKED = false;
// STACKED: one dispatch runs every cascade (z spans them all, as in the stacked images) and the
// step grids hold all cascades too: a quarter of the dispatches and barriers, where a GPU pays
// per dispatch; llvmpipe runs one cascade at a time faster (its steps stay in the caches), so
// the engine picks per device by measurement (engine/lpv/passes/calibrate.rs).
layout(constant_id = 6) const bool STACKED = false;
// This invocation's cascade (main sets it: CASCADE, or from z when STACKED).
uint C = CASCADE;
// A flat grid's first texel of this cascade and its channel stride.
ivec2 flat_at(bool stacked) {
    int n3 = int(cells());
    return stacked ? ivec2(int(C) * n3, int(flat_channel())) : ivec2(0, n3 + int(FLAT_PAD));
}
// A step grid's layout: this cascade's own, or all cascades' when STACKED.
ivec2 step_at() { return flat_at(STACKED); }
#ifdef HORNER
// The seed (the injected light, or the accumulation's start in the last step) at a cell of this
// cascade.
void load_seed(ivec3 cell, out vec4 v[3]) {
#ifdef SEED_INT
    // A cell's three channels are consecutive texels (light_index / 4).
    int t = int(C * cells() + cell_linear(cell)) * 3;
    for (int ch = 0; ch < 3; ++ch) v[ch] = vec4(imageLoad(seed_i, t + ch)) * L.params.z;
#else
    ivec2 s = flat_at(true);
    int cl = s.x + int(cell_linear(cell));
    for (int ch = 0; ch < 3; ++ch) v[ch] = imageLoad(seed_t, cl + ch * s.y);
#endif
}
#endif
// The source's light at a cell of this cascade.
void load_src(ivec3 cell, out vec4 v[3]) {
#ifdef SEED_INT
    if (SRC_STACKED) {
        load_seed(cell, v);
        return;
    }
#endif
    ivec2 f = SRC_STACKED ? flat_at(true) : step_at();
    load_src_texels(f.x + int(cell_linear(cell)), f.y, v);
}
#endif
#ifdef DIRECTIONAL
layout(set = 0, binding = NORMALS_BINDING, rgba32f) readonly uniform image3D normals;
#endif
#ifdef HORNER
// SPARSE: the dispatch runs only the bricks (workgroups) that light can have reached by this
// step, listed by schedule.comp, one brick per workgroup. The rest of the step's buffer holds
// what those bricks would compute: the zeros it was cleared to, or, in the last step, which
// writes over the accumulation's start, that start.
layout(constant_id = 5) const bool SPARSE = false;
layout(set = 0, binding = NORMALS_BINDING, std430) readonly buffer Bricks { uint v[]; } bricks;
// This step's list in the bricks buffer (a push constant: a specialization would compile a
// pipeline per cascade and step). slots (DST_IMAGES, whose dispatch is dense): each cascade's
// place in the images (persistent images keep cascades that were not recomputed).
layout(push_constant) uniform Step {
    uint list_at;
    uint pad0;
    uvec2 pad;
    uvec4 slots;
} S;
#endif

// Face f of direction D: the source's light toward the face times its transfer factor,
// re-emitted into the neighbour as a clamped cosine lobe along the face normal (SH_COS0 at 0,
// ±SH_COS1 at the normal's axis), for the three channels.
#define EMIT(f, D, A, S, B1, B2)                                                                  \
    {                                                                                              \
        float sc = SCALE(D, f, A, S, B1, B2);                                                                    \
        float e0 = E_F##f(src[0], A, S, B1, B2) * sc;                                              \
        float e1 = E_F##f(src[1], A, S, B1, B2) * sc;                                              \
        float e2 = E_F##f(src[2], A, S, B1, B2) * sc;                                              \
        const float lobe = SH_SGN(LOBE_A##f(A, B1, B2)) * LOBE_N##f(S) * SH_COS1;                 \
        o[0].x += e0 * SH_COS0;                                                                    \
        o[1].x += e1 * SH_COS0;                                                                    \
        o[2].x += e2 * SH_COS0;                                                                    \
        o[0][SH_K(LOBE_A##f(A, B1, B2))] += e0 * lobe;                                             \
        o[1][SH_K(LOBE_A##f(A, B1, B2))] += e1 * lobe;                                             \
        o[2][SH_K(LOBE_A##f(A, B1, B2))] += e2 * lobe;                                             \
    }
#define TRANSFER(D, A, S, B1, B2) \
    EMIT(0, D, A, S, B1, B2)      \
    EMIT(1, D, A, S, B1, B2)      \
    EMIT(2, D, A, S, B1, B2)      \
    EMIT(3, D, A, S, B1, B2)      \
    EMIT(4, D, A, S, B1, B2)

#ifdef SCATTER
// Push into the neighbour along S·e_A, if it is in the grid (light leaving it is gone).
#define DIRECTION(D, A, S, B1, B2)                                                                  \
    {                                                                                               \
        ivec3 dst = cell;                                                                           \
        dst[A] += int(S);                                                                           \
        if (in_grid(dst)) {                                                                         \
            vec4 o[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));                                   \
            FETCH_GV(cell, A, S, B1, B2)                                                                    \
            TRANSFER(D, A, S, B1, B2)                                                               \
            uint cl = cell_linear(dst);                                                             \
            for (uint ch = 0u; ch < 3u; ++ch) {                                                     \
                for (uint k = 0u; k < 4u; ++k) atomicAdd(B.v[light_index(c, ch * 4u + k, cl)], o[ch][k]); \
            }                                                                                       \
        }                                                                                           \
    }
#else
#if GV_SOURCES == 0
// Without a geometry volume every face of a direction has the same visibility, so the five faces
// fold into one term per SH coefficient (the two side faces of an axis cancel in the constant
// and along-direction parts and add in the side's own): 6 multiply-adds per channel instead of
// about 25, and the transfer's arithmetic was half of a step on llvmpipe. The constants are
// uniform per dispatch (K below); same sums in another order, so results agree to float rounding.
#undef TRANSFER
#define TRANSFER(D, A, S, B1, B2)                                                                  \
    {                                                                                              \
        const float sa = SH_SGN(A) * (S);                                                          \
        for (int ch = 0; ch < 3; ++ch) {                                                           \
            vec4 c = src[ch];                                                                      \
            o[ch].x += K.x * c.x + (sa * K.y) * c[SH_K(A)];                                         \
            o[ch][SH_K(A)] += (sa * K.z) * c.x + K.w * c[SH_K(A)];                                  \
            o[ch][SH_K(B1)] += k_side * c[SH_K(B1)];                                                \
            o[ch][SH_K(B2)] += k_side * c[SH_K(B2)];                                                \
        }                                                                                          \
    }
#endif
// Pull from the neighbour at −S·e_A, whose light flows along S·e_A into this cell. Only axis A
// can leave the grid: a cell on that face reads its own texel instead and weighs it 0 (cheaper on
// llvmpipe than a branch, whose mask it would run anyway).
#define DIRECTION(D, A, S, B1, B2)                                      \
    {                                                                   \
        ivec3 from = cell;                                              \
        bool inside = (S) > 0.0 ? cell[A] > 0 : cell[A] < int(n) - 1;    \
        from[A] -= inside ? int(S) : 0;                                 \
        vec4 src[3];                                                    \
        load_src(from, src);                                            \
        float w = inside ? 1.0 : 0.0;                                   \
        src[0] *= w;                                                    \
        src[1] *= w;                                                    \
        src[2] *= w;                                                    \
        FETCH_GV(from, A, S, B1, B2)                                    \
        TRANSFER(D, A, S, B1, B2)                                       \
    }
#endif

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
#ifdef SCATTER
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    ivec3 cell = ivec3(id.x, id.y, id.z % n);
#else
    if (STACKED) {
        C = id.z / n;
        id.z %= n;
    }
    uint c = C;
#if defined(HORNER) && !defined(DST_IMAGES)
    if (SPARSE) {
        id = brick_coord(bricks.v[S.list_at + gl_WorkGroupID.x]) * BRICK + gl_LocalInvocationID;
    }
#endif
    if (id.x >= n || id.y >= n || id.z >= n || c >= L.dims.y) return;
    ivec3 cell = ivec3(id);
#endif
    bool swapped = (L.dims.w & 4u) != 0u;
    float solid_front = swapped ? SIDE : FRONT;
    float solid_side = swapped ? FRONT : SIDE;
    LOAD_GV(cell)
#ifdef SCATTER
    vec4 src[3];
    load_src(ivec3(id), src);
#else
    vec4 o[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
#if GV_SOURCES == 0
    // The folded faces' factors: sc_f = solid angle / π; front E = Y0·c0 + sa·Y1·cA, side
    // E = Y0·c0 + sa·Y1·W_D·cA ± Y1·W_S·cB. Constant lobe part (COS0) over the five faces; the
    // front's lobe along A (sa·COS1); a side pair's lobes ±COS1 along B keep only 2·W_S·Y1·cB.
    float scf = solid_front / PI, scs = solid_side / PI;
    vec4 K = vec4(SH_COS0 * (scf + 4.0 * scs) * SH_Y0, SH_COS0 * (scf + 4.0 * scs * W_D) * SH_Y1,
                  SH_COS1 * scf * SH_Y0, SH_COS1 * scf * SH_Y1);
    float k_side = 2.0 * scs * SH_COS1 * SH_Y1 * W_S;
#endif
#endif
    FOR_EACH_DIRECTION(DIRECTION)
#ifndef SCATTER
#ifdef DIRECTIONAL
    // The thesis' second re-projection: keep only the intensity toward the cell's dilated VPL
    // normal, as a clamped-cosine lobe around it. Divided by the 2-band lobe's own value at its
    // axis (0.75, not 1), so a lobe along the normal passes unchanged; the thesis' version
    // without it removes a quarter of the light every step.
    vec4 nd = imageLoad(normals, grid_texel(c, cell));
    if (nd.w > 0.0) {
        vec4 lobe = sh_cosine_lobe(nd.xyz);
        vec4 unit = lobe / sh_eval(lobe, nd.xyz);
        for (int ch = 0; ch < 3; ++ch) o[ch] = max(0.0, sh_eval(o[ch], nd.xyz)) * unit;
    }
#endif
#ifdef HORNER
    vec4 seed[3];
    load_seed(cell, seed);
    for (int ch = 0; ch < 3; ++ch) o[ch] += seed[ch];
#ifdef DST_IMAGES
    store_dst(grid_texel(S.slots[c], cell), o);
#else
    ivec2 f = DST_STACKED ? flat_at(true) : step_at();
    store_dst(uint(f.x), uint(f.y), cell, o);
#endif
#else
    if (STORE_STEP) {
        ivec2 f = step_at();
        store_dst(uint(f.x), uint(f.y), cell, o);
    }
    if (ACCUMULATE == 2u) {
        // This step and the previous one (which did not accumulate): one read-modify-write of
        // the accumulated grid per two steps.
        vec4 prev[3];
        load_src(cell, prev);
        for (int ch = 0; ch < 3; ++ch) o[ch] += prev[ch];
    }
    if (ACCUMULATE != 0u) {
        // Each texel is read and written by its own invocation only.
        int texels = int(flat_channel());
        int i = int(cell_linear(grid_texel(c, cell)));
        for (int ch = 0; ch < 3; ++ch) A.v[ch * texels + i] = imageLoad(acc_t, ch * texels + i) + o[ch];
    }
#endif
#endif
}
