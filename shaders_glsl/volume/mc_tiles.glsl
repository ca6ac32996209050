#ifndef VOLUME_MC_TILES_GLSL
#define VOLUME_MC_TILES_GLSL
// Per 8×8-pixel tile of a Monte Carlo image (engine/volume/render/variance.rs reads it back),
// each tile in two halves, its pixels of even and of odd x + y (a checkerboard): the parts of the
// image's estimated relative error, written by mc_tiles.comp every frame, and adaptive sampling's
// decision for each half for the next frame, written by mc_adapt.comp (which decides a half from
// the other half's statistics only: mc_adapt.comp explains). An includer defines TILES_BINDING
// and TILES_ACCESS (readonly, or empty) first.
struct Half {
    float var;   // Σ over the half's foreground pixels and RGB of the variance of the pixel's mean
    float pvar;  // Σ over the same of the variance of one path, M2 / (n − 1)
    float sq;    // Σ over the same of the mean²
    uint n_min;  // fewest paths of any pixel of the half
    uint fg;     // foreground pixels: those whose paths have not all returned the same radiance
};
struct Tile {
    Half h[2];
    float weight[2];  // adaptive sampling, per half: 0 stopped; else its weight in bounded work's budget
};
// weight_sum: Σ of the halves' weights in 1/256 (mc_adapt.comp adds them with integer atomics).
layout(set = 0, binding = TILES_BINDING, std430) TILES_ACCESS buffer Tiles {
    uint weight_sum;
    uint tiles_x;
    uint tiles_y;
    uint pad;
    Tile t[];
} TS;

const uint TILE = 8u;
uint tile_index(ivec2 p) { return uint(p.y) / TILE * TS.tiles_x + uint(p.x) / TILE; }
uint tile_half(ivec2 p) { return uint(p.x + p.y) & 1u; }
float tile_weight(ivec2 p) { return TS.t[tile_index(p)].weight[tile_half(p)]; }
#endif
