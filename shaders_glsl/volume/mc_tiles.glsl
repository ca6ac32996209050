#ifndef VOLUME_MC_TILES_GLSL
#define VOLUME_MC_TILES_GLSL
// Per 8×8-pixel tile of a Monte Carlo image (engine/volume/variance.rs reads it back): the parts
// of the image's estimated relative error, written by mc_tiles.comp every frame, and adaptive
// sampling's decision for the next frame, written by mc_adapt.comp. An includer defines
// TILES_BINDING and TILES_ACCESS (readonly, or empty) first.
struct Tile {
    float var;     // Σ over the tile's foreground pixels and RGB of the variance of the pixel's mean
    float sq;      // Σ over the same of the mean²
    uint n_min;    // fewest paths of any pixel of the tile
    uint fg;       // foreground pixels: those whose paths have not all returned the same radiance
    float weight;  // adaptive sampling: 0 stopped; else its weight in bounded work's budget
    uint pad0;
    uint pad1;
    uint pad2;
};
// weight_sum: Σ of the tiles' weights in 1/256 (mc_adapt.comp adds them with integer atomics).
layout(set = 0, binding = TILES_BINDING, std430) TILES_ACCESS buffer Tiles {
    uint weight_sum;
    uint tiles_x;
    uint tiles_y;
    uint pad;
    Tile t[];
} TS;

const uint TILE = 8u;
uint tile_index(ivec2 p) { return uint(p.y) / TILE * TS.tiles_x + uint(p.x) / TILE; }
#endif
