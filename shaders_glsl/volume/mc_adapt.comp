#version 460
// Adaptive sampling's decision, one invocation per 8×8 tile, for each half of the tile (its pixels
// of even and of odd x + y, mc_tiles.glsl) and the next frame of the mean: mc.comp and
// mc_bounded.comp skip a half of weight 0, and bounded work shares its budget among the others
// by weight.
// A half is decided from the other half's statistics and its own path count, not from its own
// paths' values: stopping pixels when their own paths happen to look converged biases them (with
// rare bright paths, a stop at a given error is a stop at a given number of hits, and k hits
// over the N paths they took estimate p·k/(k − 1): an inverse-sampling bias of about one over
// the hits the decision saw). The two halves interleave, so each sees the same content, and
// their paths are independent; what remains is second order (the other half's own stop depends
// on this half's figures, which changes how long it runs, not what it estimates).
// A half stops once each of its pixels has pc.min_paths paths and
// - the other half has foreground and predicts this one's relative error, sqrt(Σ per-path
//   variance / n / Σ mean²) with this half's fewest paths n, at most the target; or
// - the other half has none (every pixel's paths so far returned one radiance), nor has any
//   half of the eight neighbouring tiles: a tile beside light that has seen none yet is not
//   converged, it is unlucky (a thin or dark region whose first paths all missed the light).
// A running half's weight is its predicted squared error over the target's, 1 to 16: bounded
// work gives the noisiest tiles most of the stopped ones' budget.
layout(local_size_x = 64) in;
#define TILES_BINDING 0
#define TILES_ACCESS
#include "mc_tiles.glsl"
layout(push_constant) uniform Push { float target2; uint min_paths; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint tx = TS.tiles_x, ty = TS.tiles_y;
    if (i >= tx * ty) return;
    ivec2 c = ivec2(i % tx, i / tx);
    bool lit_neighbour = false;
    for (int k = 0; k < 9; ++k) {  // the 3×3 neighbourhood, the tile itself left out
        ivec2 q = c + ivec2(k % 3 - 1, k / 3 - 1);
        if (k != 4 && all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(tx, ty)))) {
            Tile n = TS.t[uint(q.y) * tx + uint(q.x)];
            lit_neighbour = lit_neighbour || n.h[0].fg + n.h[1].fg > 0u;
        }
    }
    for (uint h = 0u; h < 2u; ++h) {
        Half me = TS.t[i].h[h];
        Half other = TS.t[i].h[1u - h];
        float n = float(me.n_min);
        // The other half's paths per pixel must be two or more for its variance to exist.
        bool ready = me.n_min >= pc.min_paths && other.n_min >= 2u;
        float predicted2 = other.pvar / max(n * other.sq, 1e-30);  // this half's relative error²
        bool converged = other.fg > 0u ? predicted2 <= pc.target2 : !lit_neighbour;
        float w = 0.0;
        if (!(ready && converged)) {
            w = other.fg > 0u ? clamp(predicted2 / pc.target2, 1.0, 16.0) : 1.0;
        }
        TS.t[i].weight[h] = w;
        if (w > 0.0) atomicAdd(TS.weight_sum, uint(w * 256.0 + 0.5));
    }
}
