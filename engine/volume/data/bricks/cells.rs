//! The occupancy and majorant grids' cells: one per 8³ brick while the brick grid is small, and
//! k³ bricks per cell (k a power of two) once it holds more than [`MAX_CELLS`], so the grids
//! stay small for boxes far larger than what they hold (a 1,055 × 1,039 × 1,028 cloud: 2.2 M
//! bricks, 35,937 cells at k = 4). A cell's range is the union of its bricks' (the lowest min,
//! the highest max), so the majorant over it bounds every brick's and its minimum stays below
//! each brick's: still valid bounds, only looser where one cell mixes thin and dense bricks.

use crate::volume::data::stats::BLOCK;

/// Most cells a grid keeps before bricks are merged into larger cells (64³: 2.3 MB of
/// occupancy and majorants).
pub const MAX_CELLS: u64 = 1 << 18;

/// Most cells along one axis: bounded-work Monte Carlo keeps its walk's cell in 10 bits per
/// axis (`volume/mc_bounded.comp`), and the grids are 3D images (2,048 is the smallest
/// `maxImageDimension3D` of the GPUs we know).
pub const MAX_CELLS_PER_AXIS: u32 = 1024;

/// Bricks per cell edge for a brick grid of `grid`: 1, or the smallest power of two that keeps
/// the cells at most [`MAX_CELLS`] and at most [`MAX_CELLS_PER_AXIS`] along each axis.
pub fn bricks_per_cell(grid: [u32; 3]) -> u32 {
    let mut k = 1u32;
    while grid.iter().map(|&g| u64::from(g.div_ceil(k))).product::<u64>() > MAX_CELLS
        || grid.iter().any(|&g| g.div_ceil(k) > MAX_CELLS_PER_AXIS)
    {
        k *= 2;
    }
    k
}

/// Cells along each axis for `dims` voxels in cells of `k` bricks.
pub fn cell_grid(dims: [u32; 3], k: u32) -> [u32; 3] {
    dims.map(|d| d.div_ceil(BLOCK * k))
}

/// Index of the cell holding brick `b` in a grid of `cells` cells of `k` bricks.
pub fn cell_of(b: [u32; 3], k: u32, cells: [u32; 3]) -> usize {
    let c = b.map(|v| (v / k) as usize);
    (c[2] * cells[1] as usize + c[1]) * cells[0] as usize + c[0]
}

/// Per-brick [min, max] ranges (x fastest over `grid`) merged into cells of `k` bricks.
pub fn coarsen(ranges: &[[f32; 2]], grid: [u32; 3], k: u32) -> Vec<[f32; 2]> {
    if k == 1 {
        return ranges.to_vec();
    }
    let cells = grid.map(|g| g.div_ceil(k));
    let mut out = vec![[f32::MAX, f32::MIN]; cells.iter().map(|&c| c as usize).product()];
    for (i, r) in ranges.iter().enumerate() {
        let i = i as u32;
        let b = [i % grid[0], i / grid[0] % grid[1], i / (grid[0] * grid[1])];
        let c = &mut out[cell_of(b, k, cells)];
        c[0] = c[0].min(r[0]);
        c[1] = c[1].max(r[1]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_grids_keep_a_cell_per_brick_and_large_ones_merge_bricks() {
        assert_eq!(bricks_per_cell([64, 64, 64]), 1);
        assert_eq!(bricks_per_cell([8, 8, 625]), 1);
        // Long and thin: few cells, but past 1,024 along one axis.
        assert_eq!(bricks_per_cell([2, 2, 4125]), 8);
        assert_eq!(bricks_per_cell([1100, 2, 2]), 2);
        assert_eq!(bricks_per_cell([65, 64, 64]), 2);
        assert_eq!(bricks_per_cell([132, 130, 129]), 4);
        assert_eq!(bricks_per_cell([164, 164, 164]), 4);
        assert_eq!(cell_grid([1055, 1039, 1028], 4), [33, 33, 33]);
    }

    #[test]
    fn a_cell_bounds_every_brick_it_covers() {
        // 5 × 3 × 2 bricks in cells of 2: partial cells on every axis.
        let grid = [5u32, 3, 2];
        let ranges: Vec<[f32; 2]> = (0..30).map(|i| [(i * 7 % 11) as f32, (i * 7 % 11 + i % 3) as f32]).collect();
        let c = coarsen(&ranges, grid, 2);
        assert_eq!(c.len(), 3 * 2);
        for (i, r) in ranges.iter().enumerate() {
            let i = i as u32;
            let b = [i % 5, i / 5 % 3, i / 15];
            let cell = c[cell_of(b, 2, [3, 2, 1])];
            assert!(cell[0] <= r[0] && r[1] <= cell[1], "brick {b:?} {r:?} outside its cell {cell:?}");
        }
        // Each cell's bounds are attained by one of its bricks (not looser than the union).
        assert_eq!(c[0], [0.0, 10.0]);
        assert_eq!(coarsen(&ranges, grid, 1), ranges);
    }
}
