#ifndef VOLUME_SKIP_GLSL
#define VOLUME_SKIP_GLSL
// Empty-space skipping for marchers (eam.comp, features.comp): whether the occupancy block or
// sparse brick holding a sample is empty under the transfer function, and where the ray leaves
// it. The includer declares `usampler3D occupancy` (the renderer's occupancy grid) first.

// Exit distance of the ray from the texel-space box [lo, hi) (texel positions).
float exit_texels(Ray r, vec3 lo, vec3 hi) {
    return intersect_box(r, H.box_min + lo / H.dims * H.box_extent, H.box_min + hi / H.dims * H.box_extent).y;
}

// Exit distance of the ray from the occupancy block containing `uvw`, if that block is empty.
bool empty_block(Ray r, vec3 uvw, out float t_exit) {
    vec3 cell = clamp(floor(uvw * cells_per_tex()), vec3(0.0), H.grid - 1.0);
    if (texelFetch(occupancy, ivec3(cell), 0).r != 0u) return false;
    vec3 lo = H.box_min + cell / cells_per_tex() * H.box_extent;
    vec3 hi = H.box_min + (cell + 1.0) / cells_per_tex() * H.box_extent;
    t_exit = intersect_box(r, lo, hi).y;
    return true;
}

// Sparse layout: the same test from the page-table word `e` of brick `b`. The bit is that of
// the occupancy cell holding the brick (k³ bricks, k = block / 8), so the whole cell is empty:
// the ray leaves the cell's points (texel positions whose lower filter texel is in one of its
// bricks), [8kc + ½, 8k(c + 1) + ½), from 0 for the first cell and to the volume's edge for the
// last; their footprints are the bricks' slots, within the cell's dilated range.
bool empty_brick(Ray r, ivec3 b, uint e, out float t_exit) {
    if ((e & PAGE_OCCUPIED) != 0u) return false;
    // Floats: llvmpipe would divide integers lane by lane (k is a power of two, so exact).
    float k = H.cell_bricks;
    vec3 first = floor(vec3(b) * (1.0 / k)) * (k * float(BRICK));
    vec3 lo = mix(first + 0.5, vec3(0.0), equal(first, vec3(0.0)));
    vec3 hi = min(first + k * float(BRICK) + 0.5, H.dims);
    t_exit = exit_texels(r, lo, hi);
    return true;
}

// The sample at `uvw`: its atlas coordinates `at` (sparse layout; `uvw` itself when dense) and,
// when `skip`, whether its occupancy block (sparse: brick) is empty, with the ray's exit from it.
bool empty_at(Ray r, vec3 uvw, bool skip, out vec4 at, out float t_exit) {
    at = vec4(uvw, 0.0);
    if (SPARSE) {
        vec3 x = texel_position(uvw);
        vec3 bf = brick_at(x);
        ivec3 brick = ivec3(bf);
        uint e = page_word(brick);
        at = atlas_at(x, bf, e);
        return skip && empty_brick(r, brick, e, t_exit);
    }
    return skip && empty_block(r, uvw, t_exit);
}
#endif
