#version 460
// Which bricks (a propagation step's 8 × 4 × 2-cell workgroups) each sparse gather step runs.
// Light moves one cell a step, so after k Horner steps (propagate.comp) only cells within k
// face-steps of an injected cell hold light: a brick whose cells are all further than k from
// every occupied brick would compute exact zeros, and its step buffer already holds what it
// would write (propagate.comp, SPARSE).
//   OCCUPANCY   per brick: the bounding box of its cells with injected light (0: none);
//   ACTIVATION  per brick: its first step, the fewest face-steps from any brick's lit box to
//               one of its cells (a lower bound on the distance to a lit cell);
//   otherwise   per cascade and step k: the list of bricks whose first step is at most
//               k, in index order (the order a dense dispatch runs them: neighbours share the
//               caches; a list sorted by first step in arbitrary order made steps 1.5× slower),
//               and its VkDispatchIndirectCommand (count, 1, 1).
#include "common.glsl"
layout(local_size_x = 8) in;

// window.xyz: the radius in bricks within which an occupied brick reaches this one in w steps;
// w: the steps.
layout(push_constant) uniform Schedule { ivec4 window; } P;

// BRICK, signed: the window search works in signed brick and cell offsets.
const ivec3 EDGE = ivec3(BRICK);
uint per_cascade() {
    uvec3 g = brick_grid();
    return g.x * g.y * g.z;
}

#ifdef OCCUPANCY
#ifdef INT
// Integer injection's own fixed-point buffer (a cell's three channels are consecutive texels),
// which propagation reads without a resolve (propagate.comp, SEED_INT).
layout(set = 0, binding = 1, rgba32i) readonly uniform iimageBuffer injected;
#else
layout(set = 0, binding = 1, rgba32f) readonly uniform imageBuffer injected;
#endif
layout(set = 0, binding = 2, std430) writeonly buffer Occupancy { uint v[]; } occ;
#elif defined(ACTIVATION)
// The lit boxes, read as texels: one vector gather where a storage-buffer load loops over the
// lanes.
layout(set = 0, binding = 1, r32ui) readonly uniform uimageBuffer occ;
layout(set = 0, binding = 2, std430) writeonly buffer First { uint v[]; } first;
#else
layout(set = 0, binding = 1, std430) readonly buffer First { uint v[]; } first;
// Per cascade and step, a list as long as a cascade's bricks.
layout(set = 0, binding = 2, std430) writeonly buffer List { uint v[]; } list;
layout(set = 0, binding = 3, std430) writeonly buffer Commands { uint v[]; } cmds;
#endif

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint per = per_cascade();
    uint w = uint(P.window.w);
#ifdef OCCUPANCY
    uint c = i / per;
    if (c >= L.dims.y) return;
    ivec3 o = ivec3(brick_coord(i % per)) * EDGE;
#ifndef INT
    int block = int(flat_channel());
#endif
    ivec3 lo = EDGE, hi = ivec3(-1);
    for (int k = 0; k < 64; ++k) {
        ivec3 at = ivec3(k & 7, (k >> 3) & 3, k >> 5);
        ivec3 cell = o + at;
        // A partial brick's cells past the grid read its last cell (and count for nothing).
        int t = int(c * cells() + cell_linear(min(cell, ivec3(lpv_n() - 1u))));
#ifdef INT
        t *= 3;
        ivec4 q = imageLoad(injected, t) | imageLoad(injected, t + 1) | imageLoad(injected, t + 2);
        bool lit = in_grid(cell) && any(notEqual(q, ivec4(0)));
#else
        vec4 v = abs(imageLoad(injected, t)) + abs(imageLoad(injected, t + block)) + abs(imageLoad(injected, t + 2 * block));
        bool lit = in_grid(cell) && any(greaterThan(v, vec4(0.0)));
#endif
        lo = lit ? min(lo, at) : lo;
        hi = lit ? max(hi, at) : hi;
    }
    // Packed: x in 3 bits, y in 2, z in 1 (a brick's 8 × 4 × 2), lit flag in bit 31.
    uint box = uint(lo.x) | uint(lo.y) << 3 | uint(lo.z) << 5 | uint(hi.x) << 6 | uint(hi.y) << 9 | uint(hi.z) << 11;
    occ.v[i] = hi.x >= 0 ? box | 0x80000000u : 0u;
#elif defined(ACTIVATION)
    uint c = i / per;
    if (c >= L.dims.y) return;
    uint b = i % per;
    ivec3 me = ivec3(brick_coord(b));
    ivec3 grid = ivec3(brick_grid());
    ivec3 mine = me * EDGE;
    ivec3 r = P.window.xyz;
    int best = int(w) + 1;
    // Nested loops: a flat index's divisions are scalar per lane on llvmpipe.
    for (int dz = -r.z; dz <= r.z; ++dz) {
        for (int dy = -r.y; dy <= r.y; ++dy) {
            for (int dx = -r.x; dx <= r.x; ++dx) {
                ivec3 other = me + ivec3(dx, dy, dz);
                bool inside = all(greaterThanEqual(other, ivec3(0))) && all(lessThan(other, grid));
                uint ob = inside ? uint(other.x + grid.x * (other.y + grid.y * other.z)) : b;
                uint box = imageLoad(occ, int(c * per + ob)).x;
                // The other brick's lit box and this brick's cells, in cells: fewest face-steps
                // between them is the sum over the axes of the gap between their ranges.
                ivec3 lit_lo = other * EDGE + ivec3(box & 7u, (box >> 3) & 3u, (box >> 5) & 1u);
                ivec3 lit_hi = other * EDGE + ivec3((box >> 6) & 7u, (box >> 9) & 3u, (box >> 11) & 1u);
                ivec3 gap = max(ivec3(0), max(lit_lo - (mine + EDGE - 1), mine - lit_hi));
                if (inside && (box >> 31) != 0u) best = min(best, gap.x + gap.y + gap.z);
            }
        }
    }
    first.v[i] = uint(best);
#else
    // Invocation i: cascade i / w, step i % w + 1.
    uint c = i / w;
    if (c >= L.dims.y) return;
    uint step = i % w + 1u;
    uint count = 0u;
    for (uint b = 0u; b < per; ++b) {
        if (first.v[c * per + b] <= step) {
            list.v[i * per + count] = b;
            count += 1u;
        }
    }
    cmds.v[3u * i] = count;
    cmds.v[3u * i + 1u] = 1u;
    cmds.v[3u * i + 2u] = 1u;
#endif
}
