//! The brick pyramid's levels: level k is the volume halved k times, each voxel the mean of the
//! 2 × 2 × 2 voxels of the level below (fewer at an odd upper edge), so its bricks cover the same
//! box with voxels 2^k times larger. Slices are halved as they stream in ([`Halver`]), so a
//! level is bricked from the same pass that reads the file, holding one plane of sums per level.
//! Which level fits the device is decided before bricking from the first pass's block ranges
//! ([`stored_at_most`]).

use super::BRICK;

/// Most levels above the volume: enough to bring a 2³⁰-voxel axis down to one brick.
pub const MAX_LEVEL: u32 = 27;

/// Voxels along each axis of level `k` of a `dims` volume (each halving rounds up).
pub fn level_dims(dims: [u32; 3], k: u32) -> [u32; 3] {
    dims.map(|d| if k >= 32 { 1 } else { d.div_ceil(1 << k) })
}

/// The coarsest level worth building: the first whose bricks number one along every axis.
pub fn coarsest(dims: [u32; 3]) -> u32 {
    (0..=MAX_LEVEL).find(|&k| level_dims(dims, k).iter().all(|&d| d <= BRICK)).unwrap_or(MAX_LEVEL)
}

/// Halves slices of normalized voxels as they arrive (x fastest, slices by ascending z or, when
/// `reversed`, descending), handing each slice of the level above to a callback as soon as its
/// (one or two) slices are in.
pub(crate) struct Halver {
    dims: [u32; 3],
    reversed: bool,
    /// Sums of the output slice being gathered, x fastest.
    sum: Vec<u32>,
    out: Vec<u16>,
    /// Voxels of the current input slice seen so far, and that slice's z.
    pos: usize,
    z: u32,
}

impl Halver {
    /// A halver of a `dims` volume's slices; the error names what could not be allocated.
    pub fn new(dims: [u32; 3], reversed: bool) -> Result<Self, String> {
        let [mx, my, _] = level_dims(dims, 1).map(|d| d as usize);
        let mut sum = Vec::new();
        sum.try_reserve_exact(mx * my).map_err(|_| format!("cannot allocate a {mx}x{my} plane of sums"))?;
        sum.resize(mx * my, 0);
        Ok(Self {
            dims,
            reversed,
            sum,
            out: vec![0; mx * my],
            pos: 0,
            z: if reversed { dims[2].saturating_sub(1) } else { 0 },
        })
    }

    /// Takes the next voxels (any count), calling `emit` with each output slice they complete.
    pub fn push(&mut self, values: &[u16], emit: &mut dyn FnMut(&[u16]) -> Result<(), String>) -> Result<(), String> {
        let [nx, ny, nz] = self.dims.map(|d| d as usize);
        let mx = nx.div_ceil(2);
        let plane = nx * ny;
        let mut rest = values;
        while !rest.is_empty() {
            let (x, y) = (self.pos % nx, self.pos / nx);
            let (run, later) = rest.split_at((nx - x).min(rest.len()));
            let row = &mut self.sum[y / 2 * mx..][..mx];
            for (i, &v) in run.iter().enumerate() {
                row[(x + i) / 2] += u32::from(v);
            }
            self.pos += run.len();
            rest = later;
            if self.pos < plane {
                continue;
            }
            self.pos = 0;
            let z = self.z as usize;
            // The pair (2z', 2z' + 1) is complete after its upper slice going up, its lower one
            // going down; a lone top slice (odd depth) ends its pair either way.
            let (done, cz) = match self.reversed {
                false => (z % 2 == 1 || z + 1 == nz, 1 + z % 2),
                true => (z.is_multiple_of(2), if z + 1 < nz { 2 } else { 1 }),
            };
            self.z = if self.reversed { self.z.saturating_sub(1) } else { self.z + 1 };
            if !done {
                continue;
            }
            let my = ny.div_ceil(2);
            for oy in 0..my {
                let cy = (ny - 2 * oy).min(2);
                for ox in 0..mx {
                    let c = ((nx - 2 * ox).min(2) * cy * cz) as u32;
                    let s = &mut self.sum[oy * mx + ox];
                    // Rounded to nearest, halves up.
                    self.out[oy * mx + ox] = ((*s + c / 2) / c) as u16;
                    *s = 0;
                }
            }
            emit(&self.out)?;
        }
        Ok(())
    }
}

/// Bricks of level `k` that may vary, at most: those whose reach (voxels 8b − 1 ..= 8b + 9 of
/// level k) covers level-0 bricks whose dilated ranges `ranges` (quantized, x fastest over
/// `grid`, each over its block and a one-voxel apron) are not all one and the same value. A
/// level-k voxel is a mean of the level-0 voxels it covers, so a reach over level-0 voxels of one
/// value is one value with no gradient: a uniform brick.
pub fn stored_at_most(ranges: &[[u16; 2]], grid: [u32; 3], k: u32) -> u64 {
    let mut n = 0;
    for_each_varies(ranges, grid, k, |v| n += u64::from(v));
    n
}

/// Whether each brick of level `k` may vary (x fastest over level k's brick grid), as
/// [`stored_at_most`] counts them. A brick's reach holds its 2 × 2 × 2 children's reaches, so a
/// brick that cannot vary has no child that can.
pub fn varies(ranges: &[[u16; 2]], grid: [u32; 3], k: u32) -> Vec<bool> {
    let mut out = Vec::new();
    for_each_varies(ranges, grid, k, |v| out.push(v));
    out
}

fn for_each_varies(ranges: &[[u16; 2]], grid: [u32; 3], k: u32, mut f: impl FnMut(bool)) {
    let b8 = u64::from(BRICK);
    let s = 1u64 << k.min(40);
    let coarse = grid.map(|g| g.div_ceil(1 << k.min(31)));
    // Level-0 bricks under the reach of coarse brick b along one axis: voxels
    // [s (8b − 1), s (8b + 10)) of level 0, clamped to the grid.
    let span = |a: usize, b: u32| {
        let lo = (s * (b8 * u64::from(b)).saturating_sub(1)) / b8;
        let hi = ((s * (b8 * u64::from(b) + 10) - 1) / b8).min(u64::from(grid[a]) - 1);
        lo as usize..=hi as usize
    };
    let (gx, gy) = (grid[0] as usize, grid[1] as usize);
    for bz in 0..coarse[2] {
        for by in 0..coarse[1] {
            for bx in 0..coarse[0] {
                let first = ranges[(*span(2, bz).start() * gy + *span(1, by).start()) * gx + *span(0, bx).start()][0];
                let varies = span(2, bz).any(|z| {
                    span(1, by).any(|y| ranges[(z * gy + y) * gx..][span(0, bx)].iter().any(|r| r != &[first; 2]))
                });
                f(varies);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Means of 2 × 2 × 2 blocks (fewer at odd edges) of a `dims` volume, in f64: what each
    /// halved voxel must be within half a unit of.
    fn halved_exactly(v: &[u16], dims: [u32; 3]) -> Vec<f64> {
        let [nx, ny, nz] = dims.map(|d| d as usize);
        let [mx, my, mz] = [nx, ny, nz].map(|d| d.div_ceil(2));
        let mut out = Vec::new();
        for z in 0..mz {
            for y in 0..my {
                for x in 0..mx {
                    let (mut s, mut c) = (0.0, 0.0);
                    for (dz, dy, dx) in (0..8).map(|i| (i / 4, i / 2 % 2, i % 2)) {
                        let p = [2 * x + dx, 2 * y + dy, 2 * z + dz];
                        if p[0] < nx && p[1] < ny && p[2] < nz {
                            s += f64::from(v[(p[2] * ny + p[1]) * nx + p[0]]);
                            c += 1.0;
                        }
                    }
                    out.push(s / c);
                }
            }
        }
        out
    }

    #[test]
    fn halved_slices_are_block_means_in_any_chunks_and_either_order() {
        // Odd sizes on every axis: partial blocks of 1, 2 and 4 voxels at the upper edges.
        for dims in [[7u32, 5, 9], [6, 4, 8], [1, 3, 1]] {
            let [nx, ny, nz] = dims.map(|d| d as usize);
            let v: Vec<u16> = (0..nx * ny * nz).map(|i| ((i * 7919 + i * i * 31) % 65536) as u16).collect();
            let want = halved_exactly(&v, dims);
            let plane = nx * ny;
            let top_down: Vec<u16> = v.chunks(plane).rev().flatten().copied().collect();
            for (reversed, input) in [(false, &v), (true, &top_down)] {
                for chunk in [1, 3, nx, plane + 1, v.len()] {
                    let mut h = Halver::new(dims, reversed).expect("halver");
                    let mut slices: Vec<Vec<u16>> = Vec::new();
                    for c in input.chunks(chunk) {
                        h.push(c, &mut |s| {
                            slices.push(s.to_vec());
                            Ok(())
                        })
                        .expect("push");
                    }
                    if reversed {
                        slices.reverse();
                    }
                    let got: Vec<u16> = slices.concat();
                    assert_eq!(got.len(), want.len(), "{dims:?} chunks of {chunk}, reversed {reversed}");
                    for (i, (&g, &w)) in got.iter().zip(&want).enumerate() {
                        assert!((f64::from(g) - w).abs() <= 0.5, "{dims:?} voxel {i}: {g}, mean {w}");
                    }
                }
            }
        }
    }

    #[test]
    fn levels_halve_dims_up_to_one_brick() {
        assert_eq!(level_dims([1024, 1024, 1100], 1), [512, 512, 550]);
        assert_eq!(level_dims([9, 8, 1], 1), [5, 4, 1]);
        assert_eq!(level_dims([1024, 1024, 1100], 3), [128, 128, 138]);
        assert_eq!(coarsest([1024, 1024, 1100]), 8);
        assert_eq!(coarsest([8, 8, 8]), 0);
        assert_eq!(coarsest([9, 1, 1]), 1);
    }
}
