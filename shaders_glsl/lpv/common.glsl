#ifndef LPV_COMMON_GLSL
#define LPV_COMMON_GLSL
// Shared by every LPV pass (engine/lpv/passes/mod.rs packs the block; std140).
// Light grids are three RGBA32F 3D images (R, G, B; the four SH coefficients in xyzw) with the
// cascades stacked along z: the layout device_limits measured fastest (storage-image loads run
// at twice the storage-buffer rate on llvmpipe), and the one shading samples directly. Passes
// that need atomics (injection, scatter propagation) add into flat buffers in the same cell
// order, 12 values per cell (channel·4 + coefficient), and a resolve pass copies them out.
// The geometry volume (monochrome blocking potential) is accumulated with integer atomics into
// a flat buffer (4 per cell, one volume per source: 0 RSM texels, 1 camera depth pixels) and
// resolved into a padded RGBA32F image that propagation samples with hardware filtering.
#include "sh.glsl"
const float PI = 3.14159265358979;

layout(set = 0, binding = 0, std140) uniform Lpv {
    vec4 cascade[4];  // xyz: minimum corner, w: cell edge
    uvec4 dims;       // x: N, y: cascades, z: RSM edge, w: flags (bit0 occlusion, bit1 truncate,
                      //   bit2 the thesis' swapped face weights, bit3 subsurface LPV)
    vec4 params;      // x: VPL offset (cells), y: light fixed-point scale, z: 1/scale, w: GV scale
    mat4 rsm_vp;      // the RSM light's world → clip
    vec4 rsm_light;   // x: 0 sun, 1 spot; y: sun texel area (m²) or spot tan(half angle); z: RSM edge
    vec4 light;       // sun: xyz direction the light travels; spot: xyz position
    mat4 inv_view_proj;  // camera clip → world (camera-depth GV)
    vec4 camera;         // xyz position; w: 2·tan(fov/2)/height (pixel angle)
    uvec4 gbuffer;       // x, y: size; z: pixel stride; w: 1 = camera GV on
} L;

// The six face neighbours of a cell.
const ivec3 DIRS[6] = ivec3[6](ivec3(1, 0, 0), ivec3(-1, 0, 0), ivec3(0, 1, 0), ivec3(0, -1, 0), ivec3(0, 0, 1), ivec3(0, 0, -1));

uint lpv_n() { return L.dims.x; }
uint cells() { return L.dims.x * L.dims.x * L.dims.x; }
uint cell_linear(ivec3 c) { return uint(c.x) + lpv_n() * (uint(c.y) + lpv_n() * uint(c.z)); }
bool in_grid(ivec3 c) { return all(greaterThanEqual(c, ivec3(0))) && all(lessThan(c, ivec3(lpv_n()))); }
// Flat light grids (lpv/images.glsl) keep their three channel blocks FLAT_PAD texels further
// apart than a grid's size: a grid of 32³ cells is a power of two of bytes, and a cell's three
// channels would fall into the same cache sets (gather steps ran 1.1× slower).
const uint FLAT_PAD = 68u;
// Texels from one channel block of a flat grid of all cascades to the next.
uint flat_channel() { return cells() * L.dims.y + FLAT_PAD; }
// Flat (atomic) light buffer: value k (channel·4 + coefficient) of a cell.
uint light_index(uint cascade, uint k, uint cell) { return (cascade * cells() + cell) * 12u + k; }
// The light images' texel of a cell.
ivec3 grid_texel(uint cascade, ivec3 cell) { return ivec3(cell.xy, cell.z + int(cascade * lpv_n())); }
// Flat (atomic) geometry-volume buffer: coefficient k of a lattice point.
uint gv_index(uint source, uint cascade, uint k, uint cell) {
    return ((source * L.dims.y + cascade) * cells() + cell) * 4u + k;
}
// The GV image holds, per source and cascade, an (N+1)³ block (lattice points 0..N; point N is
// outside the grid and stays zero), stacked along z, so filtering never mixes two blocks.
uint gv_block() { return lpv_n() + 1u; }

// A brick: a gather step's workgroup of 8 × 4 × 2 cells (propagate.comp's local size), the
// unit sparse steps run or skip (schedule.comp; engine/lpv/passes/mod.rs brick_grid).
const uvec3 BRICK = uvec3(8u, 4u, 2u);
// Bricks per cascade along each axis (a grid edge need not be a multiple of a brick's).
uvec3 brick_grid() { return (uvec3(lpv_n()) + BRICK - 1u) / BRICK; }
// Brick b of a cascade (x fastest).
uvec3 brick_coord(uint b) {
    uvec3 g = brick_grid();
    return uvec3(b % g.x, (b / g.x) % g.y, b / (g.x * g.y));
}

// Position in cell units of cascade `c` (cell centres at i + 0.5).
vec3 to_cells(uint c, vec3 p) { return (p - L.cascade[c].xyz) / L.cascade[c].w; }

// The VPL of an RSM texel, from its normal (w: the surface's translucency t) and reflected
// flux. The surface LPV takes the reflected share 1 − t; the subsurface LPV (flags bit 3) takes
// the share t that enters the object, its normal turned inward. False: no VPL for this LPV.
bool vpl(vec4 normal_t, vec3 flux_in, out vec3 n, out vec3 flux) {
    n = normalize(normal_t.xyz);
    float t = clamp(normal_t.w, 0.0, 1.0);
    if ((L.dims.w & 8u) != 0u) {
        n = -n;
        flux = flux_in * t;
        return t > 0.0;
    }
    flux = flux_in * (1.0 - t);
    return true;
}

// The cell a VPL at p with unit normal n lands in: offset along n by the VPL offset (cells).
ivec3 vpl_cell(uint c, vec3 p, vec3 n) { return ivec3(floor(to_cells(c, p) + n * L.params.x)); }
#endif
