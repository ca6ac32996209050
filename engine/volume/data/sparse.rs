//! A sparse grid as OpenVDB stores it, kept sparse: 8³ leaves of normalized values, constant
//! tiles and a background, over a bounding box that may be far larger than the leaves. The
//! brick builder reads it voxel by voxel ([`SparseGrid::value`]) without a dense copy, so host
//! memory grows with the leaves, not with the box.

use std::collections::HashMap;

/// Edge of a leaf in voxels (OpenVDB's `LeafNode<_, 3>`, the same as a brick).
pub const LEAF: i64 = 8;

/// A sparse grid's voxels, normalized to u16 by the volume's value range.
#[derive(Debug, Clone, PartialEq)]
pub struct SparseGrid {
    /// Voxels of the bounding box along x, y, z.
    pub dims: [u32; 3],
    /// Index-space coordinate of voxel (0, 0, 0).
    pub origin: [i64; 3],
    /// Normalized value of every voxel no leaf or tile covers.
    pub background: u16,
    /// Leaves by origin / 8, each 512 values x fastest (inactive voxels hold the background).
    pub leaves: HashMap<[i64; 3], Box<[u16; 512]>>,
    /// Active tiles by (edge, origin / edge): 8, 128 or 4096 voxels on a side, aligned to it.
    pub tiles: HashMap<(i64, [i64; 3]), u16>,
}

impl SparseGrid {
    /// Normalized value at voxel `p` of the box (callers keep `p` inside `dims`).
    pub fn value(&self, p: [i64; 3]) -> u16 {
        let q = [0, 1, 2].map(|a| p[a] + self.origin[a]);
        if let Some(leaf) = self.leaves.get(&q.map(|c| c.div_euclid(LEAF))) {
            let l = q.map(|c| c.rem_euclid(LEAF) as usize);
            return leaf[(l[2] * 8 + l[1]) * 8 + l[0]];
        }
        self.tile(q).unwrap_or(self.background)
    }

    fn tile(&self, q: [i64; 3]) -> Option<u16> {
        if self.tiles.is_empty() {
            return None;
        }
        [8, 128, 4096].iter().find_map(|&e| self.tiles.get(&(e, q.map(|c| c.div_euclid(e)))).copied())
    }

    /// Voxel boxes (lower corner in box coordinates, edge) of the leaves and tiles: everything
    /// that may differ from the background.
    pub fn regions(&self) -> impl Iterator<Item = ([i64; 3], i64)> + '_ {
        let at = move |k: [i64; 3], e: i64| [0, 1, 2].map(|a| k[a] * e - self.origin[a]);
        self.leaves
            .keys()
            .map(move |k| (at(*k, LEAF), LEAF))
            .chain(self.tiles.keys().map(move |(e, k)| (at(*k, *e), *e)))
    }

    /// Each distinct stored value with how many voxels of the box hold it (leaf voxels outside
    /// the box, which only an inactive voxel can be, are not counted).
    pub fn value_counts(&self) -> Vec<(u16, u64)> {
        let mut counts: HashMap<u16, u64> = HashMap::new();
        let box_voxels = self.dims.iter().map(|&d| u64::from(d)).product::<u64>();
        let mut covered = 0u64;
        let d = self.dims.map(i64::from);
        for (k, leaf) in &self.leaves {
            let o = [0, 1, 2].map(|a| k[a] * LEAF - self.origin[a]);
            for (i, &v) in leaf.iter().enumerate() {
                let p = [o[0] + (i % 8) as i64, o[1] + (i / 8 % 8) as i64, o[2] + (i / 64) as i64];
                if (0..3).all(|a| (0..d[a]).contains(&p[a])) {
                    *counts.entry(v).or_default() += 1;
                    covered += 1;
                }
            }
        }
        for ((e, _), &v) in &self.tiles {
            let n = (*e as u64).pow(3);
            *counts.entry(v).or_default() += n;
            covered += n;
        }
        if box_voxels > covered {
            *counts.entry(self.background).or_default() += box_voxels - covered;
        }
        counts.into_iter().collect()
    }

    /// The smallest box (lower and upper voxel, inclusive) holding every voxel whose value
    /// passes `keep`: the whole box when the background does.
    pub fn bounds(&self, keep: impl Fn(u16) -> bool) -> Option<([i64; 3], [i64; 3])> {
        let d = self.dims.map(|v| i64::from(v) - 1);
        if keep(self.background) {
            return Some(([0; 3], d));
        }
        let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
        let mut grow = |p: [i64; 3], q: [i64; 3]| {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a].max(0));
                hi[a] = hi[a].max(q[a].min(d[a]));
            }
        };
        for (k, leaf) in &self.leaves {
            let o = [0, 1, 2].map(|a| k[a] * LEAF - self.origin[a]);
            for (i, _) in leaf.iter().enumerate().filter(|(_, &v)| keep(v)) {
                let p = [o[0] + (i % 8) as i64, o[1] + (i / 8 % 8) as i64, o[2] + (i / 64) as i64];
                if (0..3).all(|a| (0..=d[a]).contains(&p[a])) {
                    grow(p, p);
                }
            }
        }
        for ((e, k), &v) in &self.tiles {
            if keep(v) {
                let o = [0, 1, 2].map(|a| k[a] * e - self.origin[a]);
                grow(o, o.map(|c| c + e - 1));
            }
        }
        (lo[0] <= hi[0]).then_some((lo, hi))
    }

    /// Host bytes the leaves take (what the sparse grid holds instead of the box).
    pub fn leaf_bytes(&self) -> u64 {
        self.leaves.len() as u64 * 1024
    }
}

/// A grid as read from the file, values not yet normalized.
pub(crate) struct RawSparse {
    /// Index-space coordinate of the bounding box's first voxel.
    pub lo: [i64; 3],
    /// Voxels of the bounding box.
    pub dims: [u64; 3],
    pub background: f32,
    /// Active tiles: origin, edge, value.
    pub tiles: Vec<([i64; 3], i64, f32)>,
    /// Leaves: origin, active mask and 512 values, both numbered z fastest as OpenVDB does.
    pub leaves: Vec<([i64; 3], Vec<u64>, Vec<f32>)>,
}

fn active(mask: &[u64], i: usize) -> bool {
    mask[i / 64] >> (i % 64) & 1 == 1
}

impl RawSparse {
    /// Voxels of the box no leaf voxel or tile covers (they hold the background).
    fn uncovered(&self) -> bool {
        let leaf: u64 =
            self.leaves.iter().map(|(_, m, _)| m.iter().map(|w| u64::from(w.count_ones())).sum::<u64>()).sum();
        let tiles = self.tiles.iter().try_fold(0u64, |acc, (_, e, _)| acc.checked_add((*e as u64).pow(3)));
        let total = self.dims.iter().try_fold(1u64, |acc, &d| acc.checked_mul(d));
        match (tiles.and_then(|t| t.checked_add(leaf)), total) {
            (Some(c), Some(t)) => c < t,
            _ => true,
        }
    }

    /// The value range as the dense path's sanitizing would find it over the box: the active
    /// values, the tiles' and, where some voxel is uncovered, the background. NaN values count
    /// as the smallest finite one (with a warning), infinite ones and (unless allowed) negative
    /// ones are refused.
    pub fn value_range(&self, file: &str, allow_negative: bool) -> Result<([f32; 2], Vec<String>), super::VolumeError> {
        let bg = self.uncovered().then_some(self.background);
        let actives = self.leaves.iter().flat_map(|(_, m, v)| (0..512).filter(|&i| active(m, i)).map(|i| v[i]));
        let all = actives.chain(self.tiles.iter().map(|t| t.2)).chain(bg);
        let (mut lo, mut hi, mut nan, mut inf, mut neg) = (f32::INFINITY, f32::NEG_INFINITY, 0u64, 0u64, 0u64);
        let mut first_inf = 0.0;
        for v in all {
            if v.is_nan() {
                nan += 1;
            } else if v.is_infinite() {
                if inf == 0 {
                    first_inf = v;
                }
                inf += 1;
            } else {
                lo = lo.min(v);
                hi = hi.max(v);
                neg += u64::from(v < 0.0);
            }
        }
        let err = |m: String| super::VolumeError::Invalid { file: file.to_owned(), message: m };
        if inf > 0 {
            return Err(err(format!(
                "{inf} infinite voxel values (the first {first_inf}): there is no value range to map them to"
            )));
        }
        if !lo.is_finite() {
            return Err(err("no finite voxel value".into()));
        }
        if neg > 0 && !allow_negative {
            return Err(err(format!("{neg} negative voxel values, the smallest {lo} (allow_negative accepts them)")));
        }
        let mut warnings = Vec::new();
        if nan > 0 {
            warnings.push(format!("{file}: {nan} NaN voxel(s) replaced by the minimum finite value {lo}"));
        }
        Ok(([lo, hi], warnings))
    }

    /// The grid normalized by `range` (as [`super::Volume::normalized_u16`] maps values; NaN
    /// maps to the range's minimum); errors on leaves or tiles not aligned to their size.
    pub fn normalize(&self, range: [f32; 2]) -> Result<SparseGrid, String> {
        let (lo, hi) = (f64::from(range[0]), f64::from(range[1]));
        let q = |v: f32| super::stream::quantize(v, lo, hi);
        let background = q(self.background);
        let mut leaves = HashMap::new();
        leaves.try_reserve(self.leaves.len()).map_err(|_| format!("cannot allocate {} leaves", self.leaves.len()))?;
        for (o, mask, values) in &self.leaves {
            if o.iter().any(|c| c.rem_euclid(LEAF) != 0) {
                return Err(format!("a leaf at {o:?} is not aligned to 8 voxels (corrupt file)"));
            }
            let mut leaf = Box::new([background; 512]);
            for i in (0..512).filter(|&i| active(mask, i)) {
                // OpenVDB numbers a leaf's voxels z fastest; bricks are x fastest.
                leaf[((i & 7) * 8 + ((i >> 3) & 7)) * 8 + (i >> 6)] = q(values[i]);
            }
            if leaves.insert(o.map(|c| c.div_euclid(LEAF)), leaf).is_some() {
                return Err(format!("two leaves at {o:?} (corrupt file)"));
            }
        }
        let mut tiles = HashMap::new();
        for (o, e, v) in &self.tiles {
            if o.iter().any(|c| c.rem_euclid(*e) != 0) {
                return Err(format!("a tile at {o:?} is not aligned to its {e} voxels (corrupt file)"));
            }
            tiles.insert((*e, o.map(|c| c.div_euclid(*e))), q(*v));
        }
        let dims = self.dims.map(|d| u32::try_from(d).unwrap_or(u32::MAX));
        Ok(SparseGrid { dims, origin: self.lo, background, leaves, tiles })
    }
}
