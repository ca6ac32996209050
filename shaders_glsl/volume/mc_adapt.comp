#version 460
// Adaptive sampling's decision, one invocation per 8×8 tile, for the next frame of the mean
// (mc.comp and mc_bounded.comp skip a tile of weight 0; bounded work shares its budget among the
// others by weight). A tile stops once every pixel has pc.min_paths paths and
// - it has foreground and its relative error sqrt(var / sq) is at most the target, or
// - it has none (every pixel's paths so far returned one radiance) and neither has any of its
//   eight neighbours: a tile beside light that has seen none yet is not converged, it is unlucky
//   (a thin or dark region whose first few paths all missed the light), and keeps sampling.
// Stopping never changes a pixel's estimator: its mean stays the mean of whole independent paths.
// A running tile's weight is its squared error over the target's, 1 to 16: bounded work gives
// the noisiest tiles most of the stopped ones' budget.
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
    Tile me = TS.t[i];
    bool lit_neighbour = false;
    for (int k = 0; k < 9; ++k) {  // the 3×3 neighbourhood
        ivec2 q = c + ivec2(k % 3 - 1, k / 3 - 1);
        if (all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(tx, ty)))) {
            lit_neighbour = lit_neighbour || TS.t[uint(q.y) * tx + uint(q.x)].fg > 0u;
        }
    }
    bool ready = me.n_min >= pc.min_paths;
    bool converged = me.fg > 0u ? me.var <= pc.target2 * me.sq : !lit_neighbour;
    float w = 0.0;
    if (!(ready && converged)) {
        w = me.fg > 0u ? clamp(me.var / max(pc.target2 * me.sq, 1e-30), 1.0, 16.0) : 1.0;
    }
    TS.t[i].weight = w;
    if (w > 0.0) atomicAdd(TS.weight_sum, uint(w * 256.0 + 0.5));
}
