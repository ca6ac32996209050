#version 460
// Transfer factors of one frame: for every cell, direction and face, solid(f)·(1 − B(ω_f))/π
// with B the geometry volume's blocking toward the face direction at the face between the two
// cells. The GV does not change between propagation steps, so its 12 trilinear fetches per cell
// run once here instead of in every step; propagation reads 8 plain texels.
// GV_SOURCES (1 or 2): volumes to combine (by max: where both see a surface it is the same one).
// Gather (default) indexes the factors by the cell that receives, SCATTER by the cell that sends.
#ifndef GV_SOURCES
#define GV_SOURCES 1
#endif
#include "common.glsl"
#include "transfer.glsl"
// 8 wide: llvmpipe vectorizes only along x (8 lanes at 256 bits); y and z are scalar loops.
layout(local_size_x = 8, local_size_y = 4, local_size_z = 2) in;
layout(set = 0, binding = 1) uniform sampler3D gv;
layout(set = 0, binding = 2, rgba32f) writeonly uniform image3D f0;
layout(set = 0, binding = 3, rgba32f) writeonly uniform image3D f1;
layout(set = 0, binding = 4, rgba32f) writeonly uniform image3D f2;
layout(set = 0, binding = 5, rgba32f) writeonly uniform image3D f3;
layout(set = 0, binding = 6, rgba32f) writeonly uniform image3D f4;
layout(set = 0, binding = 7, rgba32f) writeonly uniform image3D f5;
layout(set = 0, binding = 8, rgba32f) writeonly uniform image3D f6;
layout(set = 0, binding = 9, rgba32f) writeonly uniform image3D f7;

// Blocking SH of one GV source at a point in GV lattice units (lattice points at integer
// coordinates): trilinear, by the sampler. Face centres sit at whole and half lattice
// coordinates, so the filter weights (0, ½, 1) are exact at any sub-texel precision.
vec4 gv_at(uint source, uint c, vec3 q) {
    float m = float(gv_block());
    vec3 t = q + 0.5 + vec3(0.0, 0.0, float(source * L.dims.y + c) * m);
    return textureLod(gv, t / vec3(textureSize(gv, 0)), 0.0);
}

#if GV_SOURCES == 1
#define BLOCKING(f, A, S, B1, B2) E_F##f(g0, A, S, B1, B2)
#else
#define BLOCKING(f, A, S, B1, B2) max(E_F##f(g0, A, S, B1, B2), E_F##f(g1, A, S, B1, B2))
#endif
#define FACE(f, D, A, S, B1, B2) \
    FACTOR(fv, D, f) = ((f) == 0 ? solid_front : solid_side) * (1.0 - clamp(BLOCKING(f, A, S, B1, B2), 0.0, 1.0)) / PI;
#ifdef SCATTER
#define SOURCE_CELL(A, S) cell
#else
#define SOURCE_CELL(A, S) (cell - (S) * vec3(equal(ivec3(A), ivec3(0, 1, 2))))
#endif
// The face between the source cell and its neighbour along S·e_A, in GV lattice units.
#define DIRECTION(D, A, S, B1, B2)                                \
    {                                                             \
        vec3 q = SOURCE_CELL(A, S) + 0.5;                         \
        q[A] += 0.5 * (S);                                        \
        vec4 g0 = gv_at(0u, c, q);                                \
        vec4 g1 = GV_SOURCES > 1 ? gv_at(1u, c, q) : vec4(0.0);   \
        FACE(0, D, A, S, B1, B2)                                  \
        FACE(1, D, A, S, B1, B2)                                  \
        FACE(2, D, A, S, B1, B2)                                  \
        FACE(3, D, A, S, B1, B2)                                  \
        FACE(4, D, A, S, B1, B2)                                  \
    }

void main() {
    uint n = lpv_n();
    uvec3 id = gl_GlobalInvocationID;
    uint c = id.z / n;
    if (id.x >= n || id.y >= n || c >= L.dims.y) return;
    vec3 cell = vec3(id.x, id.y, id.z % n);
    bool swapped = (L.dims.w & 4u) != 0u;
    float solid_front = swapped ? SIDE : FRONT;
    float solid_side = swapped ? FRONT : SIDE;
    vec4 fv[8];
    fv[7] = vec4(0.0);
    FOR_EACH_DIRECTION(DIRECTION)
    ivec3 t = ivec3(id);
    imageStore(f0, t, fv[0]);
    imageStore(f1, t, fv[1]);
    imageStore(f2, t, fv[2]);
    imageStore(f3, t, fv[3]);
    imageStore(f4, t, fv[4]);
    imageStore(f5, t, fv[5]);
    imageStore(f6, t, fv[6]);
    imageStore(f7, t, fv[7]);
}
