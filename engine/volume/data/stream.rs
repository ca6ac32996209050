//! Streaming decode of large volumes: the voxel bytes are read twice in slabs, once for the value
//! range (and the sanitizing rules of the module docs), once to write the normalized u16 output,
//! so the host holds the output and one slab instead of the file's bytes, their `f32` values and
//! the output at once (3× the dense size and more).

use super::bricked::{BlockRanges, LevelBricker, Room, Want};
use super::orient::Plan;
use super::voxel::{self, Endian, VoxelType};
use super::{coord, VolumeError};

/// Reports progress: bytes handled so far and the total, over both passes.
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64);

/// One pass over the voxel bytes, handing each slab (whole voxels) to the callback.
pub(crate) type Pass<'a> =
    &'a mut dyn FnMut(&mut dyn FnMut(&[u8]) -> Result<(), VolumeError>) -> Result<(), VolumeError>;

/// How to turn the file's voxel bytes into values.
pub(crate) struct Decode {
    pub voxel: VoxelType,
    pub endian: Endian,
    /// Linear rescale (`value * slope + inter`), e.g. NIfTI's `scl_slope` / `scl_inter`.
    pub rescale: Option<(f64, f64)>,
}

impl Decode {
    fn values(&self, bytes: &[u8]) -> Vec<f32> {
        let mut v = voxel::decode(bytes, self.voxel, self.endian);
        if let Some((slope, inter)) = self.rescale {
            for x in &mut v {
                *x = (f64::from(*x) * slope + inter) as f32;
            }
        }
        v
    }
}

/// Offending voxels of a kind: how many, and the first in output order (index and value).
#[derive(Default)]
struct Count {
    n: u64,
    first: Option<(u64, f32)>,
}

impl Count {
    fn add(&mut self, i: u64, v: f32) {
        self.n += 1;
        if self.first.is_none_or(|(j, _)| i < j) {
            self.first = Some((i, v));
        }
    }
}

/// What the first pass learns: the sanitizing counts and the finite range.
#[derive(Default)]
struct Stats {
    nan: Count,
    inf: Count,
    neg: Count,
    min: Option<f32>,
    max: Option<f32>,
}

/// The normalized output of a streamed load, with what `Volume` records about it.
pub(crate) struct Streamed {
    pub dims: [u32; 3],
    pub spacing: [f32; 3],
    /// The dense normalized volume, unless `bricks` holds it.
    pub normalized: Option<Vec<u16>>,
    /// The bricks built as the slabs arrived.
    pub bricks: Option<super::bricks::builder::SparseBuild>,
    pub value_range: [f32; 2],
    pub warnings: Vec<String>,
    /// The pyramid level `bricks` holds when it is not the volume itself (`dims` and `spacing`
    /// stay the volume's).
    pub lod: Option<super::Lod>,
}

/// Maps `v` in `[lo, hi]` to u16 the way [`super::Volume::normalized_u16`] does (the one rule for both paths).
pub(crate) fn quantize(v: f32, lo: f64, hi: f64) -> u16 {
    if hi <= lo {
        return if lo > 0.0 { u16::MAX } else { 0 };
    }
    ((f64::from(v) - lo) * (65535.0 / (hi - lo))).round().clamp(0.0, 65535.0) as u16
}

/// The value a normalized sample stands for (exact at both ends of the range).
pub(crate) fn dequantize(q: u16, [lo, hi]: [f32; 2]) -> f32 {
    if hi <= lo {
        return lo;
    }
    (f64::from(lo) + f64::from(q) * (f64::from(hi) - f64::from(lo)) / 65535.0) as f32
}

/// Streams `dims` voxels (source order, x fastest) through two passes into normalized u16,
/// reordered by `plan` when the file's axes are not the output's; into bricks as `want` says
/// (slice by slice, in either order; a volume whose slice axis is another output axis is
/// normalized whole first),
/// refused after the first pass when its bricks cannot fit `room`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn normalize(
    file: &str,
    dims: [u32; 3],
    spacing: [f32; 3],
    decode: &Decode,
    plan: Option<&Plan>,
    allow_negative: bool,
    (want, room): (Want, &Room),
    progress: Progress<'_>,
    pass: Pass<'_>,
) -> Result<Streamed, VolumeError> {
    let count = dims.iter().map(|&d| u64::from(d)).product::<u64>();
    let total = 2 * count * decode.voxel.bytes() as u64;
    let mut done = 0u64;
    let mut stats = Stats::default();
    let mut index = 0u64;
    let mut walk = plan.map(|p| p.walker(dims));
    let out_dims = plan.map_or(dims, |p| p.dims);
    // The blocks' ranges decide `auto`'s layout and bound the bricks' size before they are built.
    // Allocated with the first slab, once the file's size has been checked against the header
    // (a header claiming more voxels than the file holds is refused as truncated, allocating
    // nothing), and only where the host has room for them.
    let mut blocks: Option<BlockRanges> = None;
    pass(&mut |slab| {
        if want != Want::No && blocks.is_none() {
            blocks = Some(
                BlockRanges::within(out_dims, room)
                    .map_err(|e| VolumeError::Invalid { file: file.to_owned(), message: e })?,
            );
        }
        let values = decode.values(slab);
        if let (Some(b), None) = (&mut blocks, &walk) {
            b.add_run(index, &values);
        }
        for v in values {
            // Indices are the output's, so the first offending voxel is the one the in-memory path names.
            let index = match &mut walk {
                Some(w) => {
                    let i = w.next_index() as u64;
                    if let Some(b) = &mut blocks {
                        b.add(i, v);
                    }
                    i
                }
                None => {
                    index += 1;
                    index - 1
                }
            };
            if v.is_nan() {
                stats.nan.add(index, v);
            } else if v.is_infinite() {
                stats.inf.add(index, v);
            } else {
                stats.min = Some(stats.min.map_or(v, |m| m.min(v)));
                stats.max = Some(stats.max.map_or(v, |m| m.max(v)));
                if v < 0.0 {
                    stats.neg.add(index, v);
                }
            }
        }
        done += slab.len() as u64;
        progress(done, total);
        Ok(())
    })?;
    let at = |i: u64| coord(out_dims, i as usize);
    if let Some((i, v)) = stats.inf.first {
        return Err(VolumeError::NonFinite { file: file.to_owned(), count: stats.inf.n, value: v, first: at(i) });
    }
    let Some((lo, hi)) = stats.min.zip(stats.max) else {
        let i = stats.nan.first.map_or(0, |(i, _)| i);
        return Err(VolumeError::NonFinite {
            file: file.to_owned(),
            count: stats.nan.n,
            value: f32::NAN,
            first: at(i),
        });
    };
    if let (false, Some((i, _))) = (allow_negative, stats.neg.first) {
        return Err(VolumeError::Negative { file: file.to_owned(), count: stats.neg.n, min: lo, first: at(i) });
    }
    let mut warnings = Vec::new();
    if let Some((i, _)) = stats.nan.first {
        let [x, y, z] = at(i);
        warnings.push(format!(
            "{file}: {} NaN voxel(s) replaced by the minimum finite value {lo}, first at ({x}, {y}, {z})",
            stats.nan.n
        ));
    }

    let (flo, fhi) = (f64::from(lo), f64::from(hi));
    let q = |v: f32| quantize(if v.is_nan() { lo } else { v }, flo, fhi);
    let bricks = match want {
        Want::No => false,
        Want::Yes => true,
        Want::IfSparse => blocks.as_ref().is_some_and(|b| b.sparse(lo, hi)),
    };
    let lod = match (bricks, &blocks) {
        (true, Some(b)) => room.level(file, b, (lo, hi))?,
        _ => None,
    };
    let level = lod.as_ref().map_or(0, |l| l.level);
    drop(blocks);
    let invalid = |e: &str| VolumeError::Invalid { file: file.to_owned(), message: e.to_owned() };
    if bricks && plan.is_none_or(|p| p.keeps_slices() || p.reverses_slices()) {
        // Slices arrive in output order, or its reverse (bricked from the top down); a
        // reordering within the slice (axes flipped or swapped in plane, as RAS files need) is
        // applied a slice at a time.
        let reversed = plan.is_some_and(Plan::reverses_slices);
        let mut b = LevelBricker::new(out_dims, reversed, level).map_err(|e| invalid(&e))?;
        let mut walk = plan.map(|p| p.walker([dims[0], dims[1], 1]));
        let plane = dims[0] as usize * dims[1] as usize;
        let mut out_plane = vec![0u16; if walk.is_some() { plane } else { 0 }];
        let mut slice = Vec::new();
        pass(&mut |slab| {
            slice.extend(decode.values(slab).into_iter().map(q));
            let whole = match &mut walk {
                None => slice.len(),
                Some(w) => {
                    let whole = slice.len() / plane * plane;
                    for src in slice[..whole].chunks_exact(plane) {
                        for &v in src {
                            // The walker stays inside the plane: it visits each of its indices once.
                            if let Some(o) = out_plane.get_mut(w.next_index()) {
                                *o = v;
                            }
                        }
                        b.push(&out_plane).map_err(|e| invalid(&e))?;
                    }
                    whole
                }
            };
            if walk.is_none() {
                b.push(&slice).map_err(|e| invalid(&e))?;
            }
            slice.drain(..whole);
            done += slab.len() as u64;
            progress(done, total);
            Ok(())
        })?;
        let built = b.finish().map_err(|e| VolumeError::Invalid { file: file.to_owned(), message: e })?;
        let spacing = plan.map_or(spacing, |p| p.spacing);
        return Ok(Streamed {
            dims: out_dims,
            spacing,
            normalized: None,
            bricks: Some(built),
            value_range: [lo, hi],
            warnings,
            lod,
        });
    }
    if count > super::MAX_VOXELS {
        // Only bricks built slice by slice hold such a volume; normalizing it whole would not fit.
        return Err(invalid(&format!(
            "its {count} voxels are past the {} a dense volume may hold, and its axes are reordered across slices, which bricks cannot be built from slice by slice",
            super::MAX_VOXELS
        )));
    }
    let mut out = Vec::new();
    let len = usize::try_from(count).ok();
    if len.is_none_or(|n| out.try_reserve_exact(n).is_err()) {
        return Err(invalid(&format!("cannot allocate {} bytes for the normalized volume", count * 2)));
    }
    let mut walk = plan.map(|p| p.walker(dims));
    if walk.is_some() {
        out.resize(count as usize, 0);
    }
    pass(&mut |slab| {
        let values = decode.values(slab);
        match &mut walk {
            None => out.extend(values.into_iter().map(q)),
            Some(w) => {
                for v in values {
                    // The walker stays inside the output: it visits each of `count` indices once.
                    if let Some(slot) = out.get_mut(w.next_index()) {
                        *slot = q(v);
                    }
                }
            }
        }
        done += slab.len() as u64;
        progress(done, total);
        Ok(())
    })?;
    if out.len() as u64 != count {
        return Err(VolumeError::DataLength { file: file.to_owned(), expected: count, got: out.len() as u64 });
    }
    let spacing = plan.map_or(spacing, |p| p.spacing);
    let (normalized, bricks) = if bricks {
        let mut b = LevelBricker::new(out_dims, false, level).map_err(|e| invalid(&e))?;
        b.push(&out).map_err(|e| invalid(&e))?;
        drop(out);
        (None, Some(b.finish().map_err(|e| VolumeError::Invalid { file: file.to_owned(), message: e })?))
    } else {
        (Some(out), None)
    };
    Ok(Streamed { dims: out_dims, spacing, normalized, bricks, value_range: [lo, hi], warnings, lod })
}
