//! Loads straight into the sparse layout's bricks: the normalized voxels arrive slice by slice
//! (x fastest, z ascending) and each layer of bricks is built as soon as the slices its slots
//! and gradient stencil reach (8b − 1 ..= 8b + 9) are in, so the host holds the bricks and a
//! window of at most 11 slices (plus the slab being read), never the dense volume.

use super::bricks::builder::{Builder, SparseBuild, REACH};
use super::bricks::pyramid::{level_dims, Halver};
use super::bricks::{self, Bricks, AUTO_DENSE_BYTES, AUTO_OCCUPIED, BRICK, MAX_ATLASES, SLOT, SLOT_TEXELS};
use super::{image_bytes, DeviceBudget, LoadOptions, VolumeError};

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

/// Whether a load builds bricks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Want {
    /// The dense volume.
    No,
    /// Bricks.
    Yes,
    /// Bricks if `auto` stores the volume sparse: fewer than [`AUTO_OCCUPIED`] of its bricks
    /// vary (counted in the first pass, from each block's range of values).
    IfSparse,
}

/// What a `dims` volume loaded with `opts` is built into: `auto`'s rule (`layout.rs`) as far as
/// the dims and the device decide it.
pub(crate) fn wanted(dims: [u32; 3], opts: &LoadOptions) -> Want {
    let Some(rule) = opts.bricks else { return Want::No };
    let image = image_bytes(dims);
    let max_allocation = opts.device.map_or(u64::MAX, |d| d.max_allocation);
    // Dense images past the heap leave bricks as the only way the volume may fit.
    let heap = opts.device.map_or(u64::MAX, |d| d.heap_bytes);
    let past_heap = image.saturating_mul(2) > heap;
    // Past `MAX_VOXELS` the dense volume is refused: bricks are the only way it loads.
    let past_dense = dims.iter().fold(1u64, |n, &d| n.saturating_mul(u64::from(d))) > super::MAX_VOXELS;
    if rule.always || dims.iter().any(|&d| d > rule.max_image_3d) || image > max_allocation || past_heap || past_dense {
        Want::Yes
    } else if image > AUTO_DENSE_BYTES {
        Want::IfSparse
    } else {
        Want::No
    }
}

/// Per 8³ block, the range of source values over the block and a one-voxel apron (as
/// `gpu_data::block_ranges`), gathered in the first pass: quantizing is monotonic, so a block
/// varies after normalizing exactly when its quantized ends differ.
pub(crate) struct BlockRanges {
    dims: [u32; 3],
    grid: [u32; 3],
    /// [min, max] per block; a NaN voxel (normalized as the minimum) makes min −∞.
    range: Vec<[f32; 2]>,
    /// [min, max] per brick over its slot's voxels (8b ..= 8b + 8 within the volume): a brick
    /// whose slot values differ is stored in a slot of its own, whatever its gradients.
    slot: Vec<[f32; 2]>,
}

impl BlockRanges {
    /// Empty ranges for a `dims` volume; the error names what could not be allocated.
    pub fn new(dims: [u32; 3]) -> Result<Self, String> {
        let grid = dims.map(|d| d.div_ceil(BRICK));
        let n = grid.iter().map(|&g| g as usize).product::<usize>();
        let empty = || {
            let mut range = Vec::new();
            range.try_reserve_exact(n).map_err(|_| format!("cannot allocate the block ranges of {n} bricks"))?;
            range.resize(n, [f32::INFINITY, f32::NEG_INFINITY]);
            Ok::<_, String>(range)
        };
        Ok(Self { dims, grid, range: empty()?, slot: empty()? })
    }

    /// [`Self::new`], refused first when its ranges (16 bytes per brick) are past the host
    /// memory `room` allows, so a header's absurd dims never allocate past memory.
    pub fn within(dims: [u32; 3], room: &Room) -> Result<Self, String> {
        let bricks = dims.iter().fold(1u64, |n, &d| n.saturating_mul(u64::from(d.div_ceil(BRICK))));
        let bytes = bricks.saturating_mul(2 * std::mem::size_of::<[f32; 2]>() as u64);
        match room.host {
            Some(host) if bytes > host => Err(format!(
                "the value ranges of its {bricks} bricks need {bytes} bytes of host memory but {host} bytes are available"
            )),
            _ => Self::new(dims),
        }
    }

    /// Adds voxel `index` (output order, x fastest) of value `v` (finite or NaN).
    pub fn add(&mut self, index: u64, v: f32) {
        let (nx, ny) = (u64::from(self.dims[0]), u64::from(self.dims[1]));
        let c = [index % nx, index / nx % ny, index / (nx * ny)].map(|c| c as u32);
        // The blocks whose dilated extent 8b − 1 ..= 8b + 8 holds the voxel.
        let span = |a: usize| {
            let b = c[a] / BRICK;
            let lo = if c[a] % BRICK == 0 { b.saturating_sub(1) } else { b };
            let hi = if c[a] % BRICK == BRICK - 1 { (b + 1).min(self.grid[a] - 1) } else { b };
            lo..=hi
        };
        let v = if v.is_nan() { [f32::NEG_INFINITY, f32::NEG_INFINITY] } else { [v, v] };
        // Slots reach 8b ..= 8b + 8: the same blocks but the one above.
        let own = c.map(|c| c / BRICK);
        for z in span(2) {
            for y in span(1) {
                for x in span(0) {
                    let i = ((z * self.grid[1] + y) * self.grid[0] + x) as usize;
                    let r = &mut self.range[i];
                    r[0] = r[0].min(v[0]);
                    r[1] = r[1].max(v[1]);
                    if x <= own[0] && y <= own[1] && z <= own[2] {
                        let r = &mut self.slot[i];
                        r[0] = r[0].min(v[0]);
                        r[1] = r[1].max(v[1]);
                    }
                }
            }
        }
    }

    /// Adds the voxels `index ..` (output order, x fastest) of values `run`, as [`Self::add`]
    /// on each: a row's voxels are merged per block first, so a block's ranges are updated once
    /// per row instead of once per voxel.
    pub fn add_run(&mut self, index: u64, run: &[f32]) {
        let nx = u64::from(self.dims[0]);
        let (mut index, mut run) = (index, run);
        while !run.is_empty() {
            let x0 = (index % nx) as u32;
            let (row, rest) = run.split_at(((nx - u64::from(x0)) as usize).min(run.len()));
            self.add_row(index, x0, row);
            index += row.len() as u64;
            run = rest;
        }
    }

    /// [`Self::add_run`] within one row, from voxel `index` at x = `x0`.
    fn add_row(&mut self, index: u64, x0: u32, row: &[f32]) {
        let (nx, ny) = (u64::from(self.dims[0]), u64::from(self.dims[1]));
        let c = [x0, (index / nx % ny) as u32, (index / (nx * ny)) as u32];
        let span = |a: usize| {
            let b = c[a] / BRICK;
            let lo = if c[a].is_multiple_of(BRICK) { b.saturating_sub(1) } else { b };
            let hi = if c[a] % BRICK == BRICK - 1 { (b + 1).min(self.grid[a] - 1) } else { b };
            lo..=hi
        };
        let own = c.map(|c| c / BRICK);
        // A NaN voxel lowers the minimum only (to −∞), as in `add`.
        let merge =
            |r: [f32; 2], v: f32| if v.is_nan() { [f32::NEG_INFINITY, r[1]] } else { [r[0].min(v), r[1].max(v)] };
        let x1 = x0 + row.len() as u32;
        let empty = [f32::INFINITY, f32::NEG_INFINITY];
        // Blocks whose dilated x extent 8b − 1 ..= 8b + 8 meets x0 .. x1.
        for bx in x0.saturating_sub(BRICK).div_ceil(BRICK)..=(x1 / BRICK).min(self.grid[0] - 1) {
            let (lo, hi) = ((bx * BRICK).max(x0), (bx * BRICK + BRICK).min(x1 - 1));
            let slot = if lo <= hi {
                row[(lo - x0) as usize..=(hi - x0) as usize].iter().fold(empty, |r, &v| merge(r, v))
            } else {
                empty
            };
            let below = bx * BRICK;
            let dilated = if below > x0 && below <= x1 { merge(slot, row[(below - 1 - x0) as usize]) } else { slot };
            for z in span(2) {
                for y in span(1) {
                    let i = ((z * self.grid[1] + y) * self.grid[0] + bx) as usize;
                    let r = &mut self.range[i];
                    *r = [r[0].min(dilated[0]), r[1].max(dilated[1])];
                    if y <= own[1] && z <= own[2] {
                        let r = &mut self.slot[i];
                        *r = [r[0].min(slot[0]), r[1].max(slot[1])];
                    }
                }
            }
        }
    }

    /// Each block's range normalized as the volume will be, once its range is `[lo, hi]`.
    fn quantized(&self, lo: f32, hi: f32) -> impl Iterator<Item = [u16; 2]> + '_ {
        quantized(&self.range, lo, hi)
    }

    /// Whether `auto` stores the volume sparse, once its range is `[lo, hi]`.
    pub fn sparse(&self, lo: f32, hi: f32) -> bool {
        let occupied = self.quantized(lo, hi).filter(|[a, b]| a < b).count();
        (occupied as f64) < AUTO_OCCUPIED * self.range.len() as f64
    }

    /// Bricks whose slot values differ once the range is `[lo, hi]`: each is stored in a slot of
    /// its own, so the bricks store at least this many (more where only gradients vary).
    pub fn stored_at_least(&self, lo: f32, hi: f32) -> u64 {
        quantized(&self.slot, lo, hi).filter(|[a, b]| a < b).count() as u64
    }

    /// Bricks in the page table.
    pub fn bricks(&self) -> u64 {
        self.range.len() as u64
    }
}

/// `ranges` normalized as the volume will be, once its range is `[lo, hi]`.
fn quantized(ranges: &[[f32; 2]], lo: f32, hi: f32) -> impl Iterator<Item = [u16; 2]> + '_ {
    let (flo, fhi) = (f64::from(lo), f64::from(hi));
    let q = move |v: f32| super::stream::quantize(v.max(lo), flo, fhi);
    ranges.iter().map(move |&[a, b]| [q(a), q(b)])
}

/// What a load's bricks must fit: the device (its heap, largest allocation and 3D-image limit)
/// and the host memory free for them, checked from the first pass's block ranges so bricks
/// that cannot fit are refused before the second pass builds any.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Room {
    device: Option<DeviceBudget>,
    max_image_3d: u32,
    host: Option<u64>,
    lod: Option<u32>,
    /// How refusals name the device budget ([`super::budget::limit_name`]).
    limit: (&'static str, &'static str),
}

impl Room {
    /// The room `opts` gives: its device, and its host memory or what the system has available.
    pub fn of(opts: &LoadOptions) -> Self {
        Self {
            device: opts.device,
            max_image_3d: opts.bricks.map_or(u32::MAX, |b| b.max_image_3d),
            host: opts.host_memory.or_else(super::budget::host_available),
            lod: opts.lod,
            limit: super::budget::limit_name(opts),
        }
    }

    /// Refuses `stored` bricks of own slots (a lower bound) out of `ranges`' bricks when their
    /// slots cannot fit, with the numbers `layout::upload_bricks` gives once they are built.
    pub fn check(&self, file: &str, ranges: &BlockRanges, stored: u64) -> Result<(), VolumeError> {
        let n = ranges.bricks();
        match self.device_refusal(n, stored).or_else(|| self.host_refusal(n, stored)) {
            Some(what) => Err(refusal(file, n, stored, &what, "")),
            None => Ok(()),
        }
    }

    /// The pyramid level a load bricks (0: the volume itself), chosen from the first pass's
    /// `ranges` once the range is `[lo, hi]`: the `lod` option when given (0 keeps [`Self::check`]'s
    /// refusal), else the finest level whose bricks may fit the device, counting every brick
    /// that may vary ([`bricks::pyramid::stored_at_most`]); level 0 when it fits, as without a
    /// pyramid. Refused with the numbers when not even the coarsest level fits.
    pub fn level(
        &self,
        file: &str,
        ranges: &BlockRanges,
        (lo, hi): (f32, f32),
    ) -> Result<Option<super::Lod>, VolumeError> {
        let lod = self.lod;
        let stored0 = ranges.stored_at_least(lo, hi);
        let fits = || self.device_refusal(ranges.bricks(), stored0).is_none();
        if lod == Some(0) || (lod.is_none() && fits()) {
            self.check(file, ranges, stored0)?;
            return Ok(None);
        }
        let q: Vec<[u16; 2]> = quantized(&ranges.range, lo, hi).collect();
        let coarsest = bricks::pyramid::coarsest(ranges.dims);
        let note = |level| super::Lod {
            level,
            full_dims: ranges.dims,
            needed: needed(ranges.bricks(), stored0).1,
            budget: self.device.map_or(u64::MAX, |d| d.heap_bytes),
        };
        let levels = match lod {
            Some(k) => k.min(coarsest)..=k.min(coarsest),
            None => 1..=coarsest,
        };
        let mut last = None;
        for k in levels {
            let grid = bricks::pyramid::level_dims(ranges.dims, k).map(|d| d.div_ceil(BRICK));
            let n = grid.iter().map(|&g| u64::from(g)).product::<u64>();
            let stored = bricks::pyramid::stored_at_most(&q, ranges.grid, k);
            match self.device_refusal(n, stored) {
                Some(what) => last = Some((k, n, stored, what)),
                None => {
                    if let Some(what) = self.host_refusal(n, stored) {
                        return Err(refusal(file, n, stored, &what, &format!(" at pyramid level {k}")));
                    }
                    return Ok((k > 0).then(|| note(k)));
                }
            }
        }
        let n0 = ranges.bricks();
        let (k, n, stored, what) =
            last.unwrap_or_else(|| (0, n0, stored0, self.device_refusal(n0, stored0).unwrap_or_default()));
        let dims = bricks::pyramid::level_dims(ranges.dims, k);
        let at = match lod {
            Some(_) => format!(" at pyramid level {k} ({}x{}x{} voxels; lod={k})", dims[0], dims[1], dims[2]),
            None => format!(" even at pyramid level {k}, the coarsest ({}x{}x{} voxels)", dims[0], dims[1], dims[2]),
        };
        Err(refusal(file, n, stored, &what, &at))
    }

    /// Why `stored` own slots of `n` bricks cannot fit the device, or `None` when they may.
    fn device_refusal(&self, n: u64, stored: u64) -> Option<String> {
        let d = self.device?;
        let (slots, needed) = needed(n, stored);
        let slot_bytes = SLOT_TEXELS as u64 * 2;
        if needed > d.heap_bytes {
            return Some(format!(
                "need at least {needed} bytes of GPU memory but {} {} {} bytes",
                self.limit.0, self.limit.1, d.heap_bytes
            ));
        }
        let per_axis = self.max_image_3d / SLOT;
        let most = d.max_allocation / slot_bytes;
        if u32::try_from(slots).ok().and_then(|s| bricks::atlas_plan(s, per_axis, most)).is_none() {
            return Some(format!(
                "take {} bytes per quantity, past {MAX_ATLASES} atlases of at most {per_axis}³ slots (this device's 3D texture limit {}) and {} bytes (its largest allocation)",
                slots * slot_bytes,
                self.max_image_3d,
                d.max_allocation
            ));
        }
        None
    }

    /// Why the slots cannot fit the host memory, or `None` when they may.
    fn host_refusal(&self, n: u64, stored: u64) -> Option<String> {
        let needed = needed(n, stored).1;
        match self.host {
            Some(host) if needed > host => {
                Some(format!("need at least {needed} bytes of host memory but {host} bytes are available"))
            }
            _ => None,
        }
    }
}

/// Slots and their least bytes for `stored` own slots of `n` bricks: a brick that is not stored
/// still needs a slot (its own or a shared one); values and gradients, before the device's
/// padding, and the page table's least, a directory word per page of 8³ bricks (`page_images`;
/// more where pages hold data).
fn needed(n: u64, stored: u64) -> (u64, u64) {
    let slots = stored + u64::from(n > stored);
    (slots, 2 * slots * SLOT_TEXELS as u64 * 2 + n / 512 * 4)
}

/// The refusal of `stored` own slots of `n` bricks for `what`, `at` naming a pyramid level.
fn refusal(file: &str, n: u64, stored: u64, what: &str, at: &str) -> VolumeError {
    let slots = needed(n, stored).0;
    let message = format!(
        "its {slots} brick slots ({stored} of {n} bricks stored){at} {what}; crop or downsample the volume (refused after reading its value ranges, before bricking)"
    );
    VolumeError::Invalid { file: file.to_owned(), message }
}

/// The normalized value of voxel `p` in `b` (inside its dims).
pub(crate) fn value(b: &Bricks, p: [u32; 3]) -> u16 {
    let (g, c) = (p.map(|c| c / BRICK), p.map(|c| c % BRICK));
    let slot = b.slot_of.get(g) as usize;
    b.values[slot * SLOT_TEXELS + ((c[2] * SLOT + c[1]) * SLOT + c[0]) as usize]
}

/// Every voxel coordinate of a `dims` volume, x fastest.
pub(crate) fn voxels(dims: [u32; 3]) -> impl Iterator<Item = [u32; 3]> {
    let [nx, ny, nz] = dims;
    (0..nz).flat_map(move |z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])))
}

/// Builds bricks from normalized voxels pushed in order: slices by ascending z, or (`reversed`)
/// descending z, x fastest within each.
pub(crate) struct SliceBricker {
    builder: Builder,
    dims: [u32; 3],
    /// Slices received so far from slice `first` on (the last one possibly partial), x fastest:
    /// z = `first` + k, or `first` − k when reversed.
    window: Vec<u16>,
    first: u32,
    reversed: bool,
    /// Layers of bricks built so far (from z = 0 up, or from the top down when reversed).
    built: u32,
    reach: Vec<u16>,
    pushed: u64,
}

impl SliceBricker {
    /// A builder for a `dims` volume whose slices arrive by ascending z, or descending when
    /// `reversed`; the error names what could not be allocated.
    pub fn new(dims: [u32; 3], reversed: bool) -> Result<Self, String> {
        Ok(Self {
            builder: Builder::new(
                dims,
                super::bricks::cells::bricks_per_cell(dims.map(|d| d.div_ceil(super::bricks::BRICK))),
            )?,
            dims,
            window: Vec::new(),
            first: if reversed { dims[2].saturating_sub(1) } else { 0 },
            reversed,
            built: 0,
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
        let (grid_z, top) = (self.dims[2].div_ceil(BRICK), self.dims[2] - 1);
        let plane = self.plane();
        while self.built < grid_z {
            let layer = if self.reversed { grid_z - 1 - self.built } else { self.built };
            // The layer reaches slices 8b − 1 ..= 8b + 9 (within the volume).
            let (low, high) = ((layer * BRICK).saturating_sub(1), (layer * BRICK + BRICK + 1).min(top));
            let complete = (self.window.len() / plane) as u32;
            let ready = if self.reversed { self.first < low + complete } else { self.first + complete > high };
            if !end && !ready {
                return Ok(());
            }
            self.build_layer(layer)?;
            self.built += 1;
            // The next layer reaches down to slice 8b − 1 (up to 8b + 1 when reversed).
            let drop = if self.reversed {
                let keep = (layer * BRICK + 1).min(top);
                let n = self.first.saturating_sub(keep);
                self.first -= n;
                n
            } else {
                let keep = ((layer + 1) * BRICK).saturating_sub(1).min(top);
                let n = keep - self.first;
                self.first = keep;
                n
            };
            let drop = (drop as usize * plane).min(self.window.len());
            self.window.drain(..drop);
        }
        Ok(())
    }

    fn build_layer(&mut self, layer: u32) -> Result<(), String> {
        let [nx, ny, nz] = self.dims.map(i64::from);
        let b8 = i64::from(BRICK);
        let bz = i64::from(layer);
        let plane = self.plane();
        let first = i64::from(self.first);
        let r = REACH as i64;
        let grid = self.dims.map(|d| i64::from(d.div_ceil(BRICK)));
        let z = |k: i64| {
            let z = k.clamp(0, nz - 1);
            (if self.reversed { first - z } else { z - first }) as usize
        };
        // The reach's slices within the volume (the clamped ones repeat them).
        let zs = z(b8 * bz - 1).min(z(b8 * bz + b8 + 1))..=z(b8 * bz - 1).max(z(b8 * bz + b8 + 1));
        for by in 0..grid[1] {
            let ys = (b8 * by - 1).max(0) as usize..=(b8 * by + b8 + 1).min(ny - 1) as usize;
            for bx in 0..grid[0] {
                // A reach of one value (most bricks of a mostly empty volume) is a uniform brick:
                // rows compared as slices, no texel gathered and no gradient computed.
                let xs = (b8 * bx - 1).max(0) as usize..=(b8 * bx + b8 + 1).min(nx - 1) as usize;
                let v0 = self.window[*zs.start() * plane + *ys.start() * nx as usize + *xs.start()];
                let uniform = zs.clone().all(|z| {
                    ys.clone().all(|y| {
                        let row = z * plane + y * nx as usize;
                        self.window[row + xs.start()..=row + xs.end()].iter().all(|&v| v == v0)
                    })
                });
                if uniform {
                    self.builder.brick([bx, by, bz], None, v0)?;
                    continue;
                }
                let mut t = 0;
                for kz in 0..r {
                    let z = (b8 * bz - 1 + kz).clamp(0, nz - 1);
                    let z = if self.reversed { first - z } else { z - first };
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

/// Bricks level `level` of the pyramid from the volume's normalized voxels pushed as
/// [`SliceBricker`] takes them: each level's slices halved from the one below as they arrive
/// (`bricks::pyramid::Halver`), only the level's own bricks built and kept.
pub(crate) struct LevelBricker {
    halvers: Vec<Halver>,
    bricker: SliceBricker,
    want: u64,
    pushed: u64,
}

impl LevelBricker {
    /// A builder of level `level` of a `dims` volume whose slices arrive by ascending z, or
    /// descending when `reversed`; the error names what could not be allocated.
    pub fn new(dims: [u32; 3], reversed: bool, level: u32) -> Result<Self, String> {
        let halvers = (0..level).map(|k| Halver::new(level_dims(dims, k), reversed)).collect::<Result<_, _>>()?;
        Ok(Self {
            halvers,
            bricker: SliceBricker::new(level_dims(dims, level), reversed)?,
            want: dims.iter().map(|&d| u64::from(d)).product(),
            pushed: 0,
        })
    }

    /// Takes the next normalized voxels of the volume (any count).
    pub fn push(&mut self, values: &[u16]) -> Result<(), String> {
        fn feed(halvers: &mut [Halver], bricker: &mut SliceBricker, values: &[u16]) -> Result<(), String> {
            match halvers.split_first_mut() {
                None => bricker.push(values),
                Some((h, rest)) => h.push(values, &mut |slice| feed(rest, bricker, slice)),
            }
        }
        self.pushed += values.len() as u64;
        feed(&mut self.halvers, &mut self.bricker, values)
    }

    /// The level's bricks, once every voxel of the volume was pushed (otherwise the error says
    /// how many were).
    pub fn finish(self) -> Result<SparseBuild, String> {
        if self.pushed != self.want {
            return Err(format!("{} voxels for a {}-voxel volume", self.pushed, self.want));
        }
        self.bricker.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::data::stats::{block_ranges, gradient_magnitudes, histogram};

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
        // And slices top down (a reversed slice axis), bricked from the top layer.
        let plane = (dims[0] * dims[1]) as usize;
        let top_down: Vec<u16> = dense.chunks(plane).rev().flatten().copied().collect();
        let orders = [(false, &dense), (true, &top_down)];
        for (size, (reversed, pushed)) in
            [1usize, 7, 21 * 18 - 1, 1000, dense.len()].into_iter().flat_map(|c| orders.map(|o| (c, o)))
        {
            // Names the case in the messages below.
            let chunk = format!("{size}{}", if reversed { " top down" } else { "" });
            let mut b = SliceBricker::new(dims, reversed).expect("builder");
            for c in pushed.chunks(size) {
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
        let mut short = SliceBricker::new(dims, false).expect("builder");
        short.push(&dense[1..]).expect("push");
        assert!(short.finish().expect_err("short").contains(&format!("{} voxels", dense.len() - 1)));
        let mut long = SliceBricker::new(dims, false).expect("builder");
        long.push(&dense).expect("push");
        long.push(&[0]).expect("push");
        assert!(long.finish().is_err());
    }

    #[test]
    fn first_pass_counts_the_bricks_whose_slot_values_differ() {
        // One bright voxel in a zero 24³ volume. At (8, 8, 8) it lies in the slots of bricks
        // 0 and 1 along each axis (slot b holds 8b ..= 8b + 8): 8 stored, exactly. At (9, 9, 9)
        // only brick (1, 1, 1)'s slot holds it, but its neighbours at (8, 9, 9), (9, 8, 9) and
        // (9, 9, 8), the last texels of bricks (0, 1, 1), (1, 0, 1) and (1, 1, 0), take a
        // gradient from it: 4 stored, of which the first pass counts 1. At (7, 7, 7) likewise
        // (its neighbours at 8 are the first texels of bricks 1), though the blocks' dilated
        // ranges (8b − 1 ..= 8b + 8) of 8 bricks hold it: counting those would refuse bricks
        // that fit.
        let dims = [24u32; 3];
        for (at, counted, stored) in [(8u32, 8u64, 8u64), (9, 1, 4), (7, 1, 4)] {
            let dense: Vec<u16> = voxels(dims).map(|p| if p == [at; 3] { 50000 } else { 0 }).collect();
            let mut r = BlockRanges::new(dims).expect("ranges");
            for (i, &v) in dense.iter().enumerate() {
                r.add(i as u64, f32::from(v));
            }
            assert_eq!(r.stored_at_least(0.0, 50000.0), counted, "voxel at {at}");
            let b = Bricks::build(&dense, &gradient_magnitudes(&dense, dims), dims).expect("bricks");
            assert_eq!(b.brick_count() - b.uniform_bricks, stored, "voxel at {at}: built");
        }
    }

    #[test]
    fn first_pass_block_ranges_are_the_normalized_volumes() {
        // Partial blocks, values on both sides of block borders, NaN voxels (normalized as the
        // minimum) inside a block and on its apron.
        let dims = [19u32, 17, 10];
        let mut data: Vec<f32> = voxels(dims)
            .map(|[x, y, z]| if x > 8 && y < 9 { (x * 31 + y * 7 + z) as f32 * 0.37 - 4.0 } else { 2.5 })
            .collect();
        for i in [0usize, 8 + 19 * 3, 19 * 17 * 7 + 19 * 16 + 15] {
            data[i] = f32::NAN;
        }
        let mut b = BlockRanges::new(dims).expect("ranges");
        for (i, &v) in data.iter().enumerate() {
            b.add(i as u64, v);
        }
        // Runs of any length, across rows and slices, as voxel by voxel.
        for chunk in [1usize, 5, 8, 19, 40, 19 * 17 + 3, data.len()] {
            let mut r = BlockRanges::new(dims).expect("ranges");
            for (k, c) in data.chunks(chunk).enumerate() {
                r.add_run((k * chunk) as u64, c);
            }
            let same = |a: &[[f32; 2]], b: &[[f32; 2]]| {
                a.iter().zip(b).all(|(x, y)| x.map(f32::to_bits) == y.map(f32::to_bits))
            };
            assert!(same(&r.range, &b.range) && same(&r.slot, &b.slot), "runs of {chunk}");
        }
        let vol = crate::volume::data::Volume::new(dims, [1.0; 3], data, "t").expect("volume");
        let [lo, hi] = vol.value_range;
        let q = vol.normalized_u16();
        let want = block_ranges(&q, dims, dims.map(|d| d.div_ceil(BRICK)));
        let got: Vec<[f32; 2]> = b.quantized(lo, hi).map(|r| r.map(|v| v as f32 / 65535.0)).collect();
        assert_eq!(got, want);
    }
}
