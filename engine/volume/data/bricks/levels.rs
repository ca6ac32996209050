//! Every level of the brick pyramid kept together on the host, for view-dependent residency
//! (`residency`): each level's bricks (level k halved k times by block means, its gradient
//! magnitudes its own), the residency [`Pyramid`] over them, and the level-0 bricks' dilated
//! ranges, from which a mixed cut's occupancy and majorants are bounded ([`cut_ranges`]).

use super::pyramid::{coarsest, level_dims, Halver, MAX_LEVEL};
use super::residency::{Pyramid, Streamer};
use super::{Bricks, BRICK};
use crate::volume::data::stats::{block_ranges, gradient_magnitudes};

/// Levels above the volume a residency page word can name (`volume/common.glsl`'s 4-bit field).
pub const MAX_LOD: u32 = 15;

/// The pyramid's levels with their bricks.
#[derive(Clone, Debug)]
pub struct Levels {
    /// Voxels of level 0.
    pub dims: [u32; 3],
    /// Bricks of level 0, 1, … up to one brick along every axis.
    pub bricks: Vec<Bricks>,
    /// What residency needs of the levels (their grids and which bricks may vary).
    pub pyramid: Pyramid,
    /// Per level-0 brick (x fastest), [min, max] normalized value over it and a one-voxel apron.
    pub ranges: Vec<[f32; 2]>,
}

/// Level `values` (normalized, x fastest, `dims`) halved by block means.
fn halve(values: &[u16], dims: [u32; 3]) -> Result<Vec<u16>, String> {
    let mut h = Halver::new(dims, false)?;
    let mut out = Vec::new();
    h.push(values, &mut |s| {
        out.extend_from_slice(s);
        Ok(())
    })?;
    Ok(out)
}

impl Levels {
    /// Every level of a `dims` volume of normalized `values` (x fastest). Refused with the
    /// numbers past [`MAX_LOD`] levels.
    pub fn build(values: &[u16], dims: [u32; 3]) -> Result<Self, String> {
        let top = coarsest(dims);
        if top > MAX_LOD || top >= MAX_LEVEL {
            return Err(format!(
                "{}x{}x{} voxels need {top} levels to reach one brick; residency keeps at most {MAX_LOD}",
                dims[0], dims[1], dims[2]
            ));
        }
        let grid = dims.map(|d| d.div_ceil(BRICK));
        let ranges = block_ranges(values, dims, grid);
        let quantized: Vec<[u16; 2]> = ranges.iter().map(|r| r.map(|v| (v * 65535.0).round() as u16)).collect();
        let pyramid = Pyramid::from_ranges(&quantized, dims)?;
        let mut bricks = Vec::with_capacity(top as usize + 1);
        let mut level: Vec<u16> = values.to_vec();
        for k in 0..=top {
            let d = level_dims(dims, k);
            bricks.push(Bricks::build(&level, &gradient_magnitudes(&level, d), d)?);
            if k < top {
                level = halve(&level, d)?;
            }
        }
        Ok(Self { dims, bricks, pyramid, ranges })
    }

    /// The coarsest level.
    pub fn top(&self) -> u32 {
        self.pyramid.top()
    }
}

/// Per level-0 brick (x fastest), a [min, max] bounding every value the sample function can read
/// for points whose lower filter texel is in the brick, under the level it shows (`streamer`):
/// a level-L texel is a mean of level-0 voxels, and a point of level-0 brick b reads level-L
/// texels 8B − 1 ..= 8B + 8 of its level-L brick B = b / 2^L (the one before when it shows L
/// too), which cover level-0 voxels 2^L (8B − 1) ..< 2^L (8B + 9): the union of the ranges of
/// the level-0 bricks those voxels fall in (each range over its brick and a one-voxel apron).
pub fn cut_ranges(levels: &Levels, streamer: &Streamer) -> Vec<[f32; 2]> {
    let p = &levels.pyramid;
    let g = p.grid(0);
    let b8 = i64::from(BRICK);
    let index = |b: [u32; 3]| ((b[2] as usize * g[1] as usize) + b[1] as usize) * g[0] as usize + b[0] as usize;
    let mut out = Vec::with_capacity(levels.ranges.len());
    for z in 0..g[2] {
        for y in 0..g[1] {
            for x in 0..g[0] {
                let b = [x, y, z];
                let l = streamer.level_of(p, b);
                if l == 0 {
                    out.push(levels.ranges[index(b)]);
                    continue;
                }
                let s = 1i64 << l;
                // Level-0 bricks under voxels s (8B − 1) ..< s (8B + 9) along each axis.
                let span = |a: usize| {
                    let big = i64::from(b[a]) >> l;
                    let lo = (s * (b8 * big - 1)).max(0) / b8;
                    let hi = ((s * (b8 * big + 9) - 1) / b8).min(i64::from(g[a]) - 1);
                    lo as u32..=hi as u32
                };
                let (mut lo, mut hi) = (f32::MAX, f32::MIN);
                for cz in span(2) {
                    for cy in span(1) {
                        for cx in span(0) {
                            let r = levels.ranges[index([cx, cy, cz])];
                            lo = lo.min(r[0]);
                            hi = hi.max(r[1]);
                        }
                    }
                }
                out.push([lo, hi]);
            }
        }
    }
    out
}
