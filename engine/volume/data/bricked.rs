//! Loads straight into the sparse layout's bricks: the normalized voxels arrive slice by slice
//! (x fastest, z ascending) and each layer of bricks is built as soon as the slices its slots
//! and gradient stencil reach (8b − 1 ..= 8b + 9) are in, so the host holds the bricks and a
//! window of at most 11 slices (plus the slab being read), never the dense volume.

use super::{image_bytes, LoadOptions};
use crate::volume::bricks::{Bricks, BRICK, SLOT, SLOT_TEXELS};
use crate::volume::layout::AUTO_DENSE_BYTES;
use crate::volume::sparse_bricks::{Builder, SparseBuild, REACH};

/// When a load builds bricks instead of the dense volume (see [`LoadOptions::bricks`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IntoBricks {
    /// Always (`volume_layout=sparse`); otherwise only where `auto` may store the volume
    /// sparse: past `max_image_3d` on an axis, past one allocation, or past
    /// [`AUTO_DENSE_BYTES`] (where the bricks' occupancy decides).
    pub always: bool,
    /// The device's `maxImageDimension3D`.
    pub max_image_3d: u32,
}

/// Whether a `dims` volume loaded with `opts` is built into bricks.
pub(crate) fn wanted(dims: [u32; 3], opts: &LoadOptions) -> bool {
    let Some(rule) = opts.bricks else { return false };
    let image = image_bytes(dims);
    let max_allocation = opts.device.map_or(u64::MAX, |d| d.max_allocation);
    rule.always || dims.iter().any(|&d| d > rule.max_image_3d) || image > max_allocation || image > AUTO_DENSE_BYTES
}

/// The normalized value of voxel `p` in `b` (inside its dims).
pub(crate) fn value(b: &Bricks, p: [u32; 3]) -> u16 {
    let (g, c) = (p.map(|c| c / BRICK), p.map(|c| c % BRICK));
    let slot = b.slot_of[((g[2] * b.grid[1] + g[1]) * b.grid[0] + g[0]) as usize] as usize;
    b.values[slot * SLOT_TEXELS + ((c[2] * SLOT + c[1]) * SLOT + c[0]) as usize]
}

/// Every voxel coordinate of a `dims` volume, x fastest.
pub(crate) fn voxels(dims: [u32; 3]) -> impl Iterator<Item = [u32; 3]> {
    let [nx, ny, nz] = dims;
    (0..nz).flat_map(move |z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])))
}

/// Builds bricks from normalized voxels pushed in order.
pub(crate) struct SliceBricker {
    builder: Builder,
    dims: [u32; 3],
    /// Slices `first..` received so far (the last one possibly partial), x fastest.
    window: Vec<u16>,
    first: u32,
    /// Next layer of bricks to build.
    layer: u32,
    reach: Vec<u16>,
    pushed: u64,
}

impl SliceBricker {
    /// A builder for a `dims` volume; the error names what could not be allocated.
    pub fn new(dims: [u32; 3]) -> Result<Self, String> {
        Ok(Self {
            builder: Builder::new(dims)?,
            dims,
            window: Vec::new(),
            first: 0,
            layer: 0,
            reach: vec![0; REACH.pow(3)],
            pushed: 0,
        })
    }

    fn plane(&self) -> usize {
        self.dims[0] as usize * self.dims[1] as usize
    }

    /// Takes the next normalized voxels (any count), building the layers they complete; the
    /// error names what could not be allocated.
    pub fn push(&mut self, values: &[u16]) -> Result<(), String> {
        // At most a layer's slices ahead of the one being built, so memory holds a window
        // however large the pushed slab.
        let plane = self.plane();
        self.pushed += values.len() as u64;
        let mut rest = values;
        while !rest.is_empty() {
            let room = (12 * plane).saturating_sub(self.window.len()).max(plane);
            let (now, later) = rest.split_at(room.min(rest.len()));
            self.window.extend_from_slice(now);
            rest = later;
            self.build_ready(false)?;
        }
        Ok(())
    }

    /// Builds layers whose slices are all in (all of them at the end).
    fn build_ready(&mut self, end: bool) -> Result<(), String> {
        let grid_z = self.dims[2].div_ceil(BRICK);
        let plane = self.plane();
        while self.layer < grid_z {
            let last = (self.layer * BRICK + BRICK + 1).min(self.dims[2] - 1);
            let complete = (self.window.len() / plane) as u32;
            if !end && self.first + complete <= last {
                return Ok(());
            }
            self.build_layer()?;
            self.layer += 1;
            // The next layer reaches down to slice 8b − 1.
            let keep = (self.layer * BRICK).saturating_sub(1).min(self.dims[2] - 1);
            let drop = ((keep - self.first) as usize * plane).min(self.window.len());
            self.window.drain(..drop);
            self.first = keep;
        }
        Ok(())
    }

    fn build_layer(&mut self) -> Result<(), String> {
        let [nx, ny, nz] = self.dims.map(i64::from);
        let b8 = i64::from(BRICK);
        let bz = i64::from(self.layer);
        let plane = self.plane();
        let first = i64::from(self.first);
        let r = REACH as i64;
        let grid = self.dims.map(|d| i64::from(d.div_ceil(BRICK)));
        for by in 0..grid[1] {
            for bx in 0..grid[0] {
                let mut t = 0;
                for kz in 0..r {
                    let z = (b8 * bz - 1 + kz).clamp(0, nz - 1) - first;
                    for ky in 0..r {
                        let y = (b8 * by - 1 + ky).clamp(0, ny - 1);
                        let row = z as usize * plane + (y * nx) as usize;
                        for kx in 0..r {
                            let x = (b8 * bx - 1 + kx).clamp(0, nx - 1);
                            self.reach[t] = self.window[row + x as usize];
                            t += 1;
                        }
                    }
                }
                self.builder.brick([bx, by, bz], Some(&self.reach), 0)?;
            }
        }
        Ok(())
    }

    /// The bricks, once every voxel was pushed (otherwise the error says how many were).
    pub fn finish(mut self) -> Result<SparseBuild, String> {
        let want = self.plane() as u64 * u64::from(self.dims[2]);
        if self.pushed != want {
            return Err(format!("{} voxels for a {want}-voxel volume", self.pushed));
        }
        self.build_ready(true)?;
        Ok(self.builder.finish())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::gpu_data::{block_ranges, gradient_magnitudes, histogram};

    #[test]
    fn slices_pushed_in_any_chunks_brick_as_the_dense_volume_does() {
        // Partial bricks on every axis (21 = 2·8 + 5, 18 = 2·8 + 2, 35 = 4·8 + 3); a ramp in
        // one corner, a constant slab and zero elsewhere, so bricks of all kinds meet.
        let dims = [21u32, 18, 35];
        let dense: Vec<u16> = voxels(dims)
            .map(|[x, y, z]| match (x, y, z) {
                (0..=9, 0..=6, _) => (x * 3001 + y * 707 + z * 97) as u16,
                (_, _, 20..=27) => 40000,
                _ => 0,
            })
            .collect();
        let grad = gradient_magnitudes(&dense, dims);
        let grid = dims.map(|d| d.div_ceil(BRICK));
        let want = Bricks::build(&dense, &grad, dims).expect("dense bricks");
        let max = grad.iter().copied().max().unwrap_or(0) as f32 / 65535.0;
        for chunk in [1usize, 7, 21 * 18 - 1, 1000, dense.len()] {
            let mut b = SliceBricker::new(dims).expect("builder");
            for c in dense.chunks(chunk) {
                b.push(c).expect("push");
            }
            let got = b.finish().expect("bricks");
            assert_eq!(got.bricks, want, "chunks of {chunk}: bricks");
            assert_eq!(got.block_ranges, block_ranges(&dense, dims, grid), "chunks of {chunk}: block ranges");
            assert_eq!(got.max_gradient, max, "chunks of {chunk}: max gradient");
            assert_eq!(got.histogram, histogram(&dense, &grad, max), "chunks of {chunk}: histogram");
            assert!(voxels(dims).zip(&dense).all(|(p, &v)| value(&got.bricks, p) == v), "chunks of {chunk}: voxels");
        }
        // Too few or too many voxels are an error, not bricks.
        let mut short = SliceBricker::new(dims).expect("builder");
        short.push(&dense[1..]).expect("push");
        assert!(short.finish().expect_err("short").contains(&format!("{} voxels", dense.len() - 1)));
        let mut long = SliceBricker::new(dims).expect("builder");
        long.push(&dense).expect("push");
        long.push(&[0]).expect("push");
        assert!(long.finish().is_err());
    }
}
