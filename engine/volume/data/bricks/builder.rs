//! Bricks straight from a sparse grid ([`SparseGrid`], OpenVDB's leaves and tiles), never
//! densified: only bricks whose slot or apron reaches a leaf or a tile's border are gathered
//! voxel by voxel; every other brick is one value (a tile's or the background) and shares a
//! slot. The result equals [`Bricks::build`] on the densified grid, slot for slot, and so do
//! the block ranges and the histogram derived here.

use super::cells;
use super::page_table::Page;
use crate::volume::data::bricks::{Bricks, BRICK, SLOT, SLOT_TEXELS};
use crate::volume::data::sparse::SparseGrid;
use crate::volume::data::stats::{gradient_u16, histogram_bin};
use crate::volume::data::stats::{TF_GRADIENTS, TF_VALUES};
use std::collections::HashMap;

/// What the renderer derives from a sparse grid: its bricks and what the dense path computes
/// from the dense volume.
#[derive(Clone, Debug, PartialEq)]
pub struct SparseBuild {
    /// The bricks and page table.
    pub bricks: Bricks,
    /// Per grid cell of `cell_bricks`³ bricks, [min, max] over its bricks, each dilated by a
    /// one-voxel apron (as `gpu_data::block_ranges` merged by `cells::coarsen`).
    pub block_ranges: Vec<[f32; 2]>,
    /// Bricks per grid cell edge (`cells::bricks_per_cell`).
    pub cell_bricks: u32,
    /// Bricks whose dilated range is not one value (what `auto` weighs).
    pub occupied_bricks: u64,
    /// Value × gradient histogram (as `gpu_data::histogram`; counts saturate).
    pub histogram: Vec<u32>,
    /// Largest gradient magnitude.
    pub max_gradient: f32,
}

/// Voxels a brick's slot and gradients read along an axis: 8b − 1 ..= 8b + 9.
pub(crate) const REACH: usize = BRICK as usize + 3;

fn alloc<T: Clone>(n: usize, v: T, what: &str) -> Result<Vec<T>, String> {
    let mut out = Vec::new();
    out.try_reserve_exact(n).map_err(|_| format!("cannot allocate {what} for {n} bricks"))?;
    out.resize(n, v);
    Ok(out)
}

/// Bricks, block ranges and histogram of `g`, the ranges in cells of
/// [`cells::bricks_per_cell`] bricks.
pub fn build(g: &SparseGrid) -> Result<SparseBuild, String> {
    build_in_cells(g, cells::bricks_per_cell(g.dims.map(|d| d.div_ceil(BRICK))))
}

/// [`build`] with block ranges in cells of `k`³ bricks.
fn build_in_cells(g: &SparseGrid, k: u32) -> Result<SparseBuild, String> {
    let dims = g.dims;
    if dims.contains(&0) {
        return Err(format!("bricking an empty {dims:?} grid"));
    }
    let grid = dims.map(|d| d.div_ceil(BRICK));
    let n = grid.iter().try_fold(1usize, |acc, &c| acc.checked_mul(c as usize)).ok_or("too many bricks")?;
    let mut near = alloc(n.div_ceil(64), 0u64, "the brick marks")?;
    let b8 = i64::from(BRICK);
    let d = dims.map(i64::from);
    for (o, e) in g.regions() {
        // Bricks whose reach [8b − 1, 8b + 10) meets [o, o + e).
        let span = |a: usize| {
            let lo = ((o[a] - 10).div_euclid(b8) + 1).max(0);
            let hi = (o[a] + e).div_euclid(b8).min(i64::from(grid[a]) - 1);
            lo..=hi
        };
        let inside = |a: usize, b: i64| o[a] <= (b8 * b - 1).max(0) && (b8 * b + 10).min(d[a]) <= o[a] + e;
        for bz in span(2) {
            for by in span(1) {
                for bx in span(0) {
                    // A leaf always varies near its border; a tile only where its border is near.
                    if e > b8 && inside(0, bx) && inside(1, by) && inside(2, bz) {
                        continue;
                    }
                    let i = ((bz * i64::from(grid[1]) + by) * i64::from(grid[0]) + bx) as usize;
                    near[i / 64] |= 1 << (i % 64);
                }
            }
        }
    }
    let mut me = Builder::new(dims, k)?;
    let mut reach = vec![0u16; REACH * REACH * REACH];
    let mut i = 0;
    for bz in 0..i64::from(grid[2]) {
        for by in 0..i64::from(grid[1]) {
            for bx in 0..i64::from(grid[0]) {
                let b = [bx, by, bz];
                if near[i / 64] >> (i % 64) & 1 == 1 {
                    // reach[k] holds voxel clamp(8b − 1 + k), k along each axis.
                    let base = b.map(|c| b8 * c - 1);
                    let cl = |a: usize, p: i64| p.clamp(0, d[a] - 1);
                    let mut t = 0;
                    for kz in 0..REACH as i64 {
                        for ky in 0..REACH as i64 {
                            for kx in 0..REACH as i64 {
                                let p = [cl(0, base[0] + kx), cl(1, base[1] + ky), cl(2, base[2] + kz)];
                                reach[t] = g.value(p);
                                t += 1;
                            }
                        }
                    }
                    me.brick(b, Some(&reach), 0)?;
                } else {
                    me.brick(b, None, g.value(b.map(|c| b8 * c)))?;
                }
                i += 1;
            }
        }
    }
    Ok(me.finish())
}

/// Builds bricks one at a time, in page-table order (x fastest), from each brick's reach: the
/// part shared by [`build`] and the slab-by-slab loaders (`super::stream_bricks`).
pub(crate) struct Builder {
    me: Bricks,
    /// Per grid cell of `k`³ bricks (`cells`): the union of its bricks' ranges.
    ranges: Vec<[f32; 2]>,
    k: u32,
    cells: [u32; 3],
    occupied_bricks: u64,
    shared: HashMap<(u16, u16), u32>,
    uniform_slot: Vec<bool>,
    v: Vec<u16>,
    gr: Vec<u16>,
    /// Page-table index after the last brick recorded, and whether any came out of that order.
    next: u64,
    out_of_order: bool,
}

impl Builder {
    /// An empty build of a `dims` volume whose ranges are kept in cells of `k`³ bricks (page
    /// table and cell ranges allocated, no slot yet).
    pub(crate) fn new(dims: [u32; 3], k: u32) -> Result<Self, String> {
        if dims.contains(&0) {
            return Err(format!("bricking an empty {dims:?} grid"));
        }
        let grid = dims.map(|d| d.div_ceil(BRICK));
        let me = Bricks {
            dims,
            grid,
            slot_of: super::page_table::PageTable::new(grid)?,
            values: Vec::new(),
            gradients: Vec::new(),
            uniform_bricks: 0,
            shared_slots: 0,
        };
        let cells = grid.map(|g| g.div_ceil(k.max(1)));
        let cell_count = cells.iter().map(|&c| c as usize).product();
        Ok(Self {
            me,
            ranges: alloc(cell_count, [f32::MAX, f32::MIN], "the block ranges")?,
            k: k.max(1),
            cells,
            occupied_bricks: 0,
            shared: HashMap::new(),
            uniform_slot: Vec::new(),
            v: vec![0u16; SLOT_TEXELS],
            gr: vec![0u16; SLOT_TEXELS],
            next: 0,
            out_of_order: false,
        })
    }

    /// Adds brick `b` (each once, in any order; slots are numbered in page-table order when
    /// finished): from `reach` (`REACH`³ voxels,
    /// `reach[k]` = voxel clamp(8b − 1 + k) along each axis, x fastest) or, without one, a brick
    /// whose reach is all `uniform`. The error says which slot could not be allocated.
    pub(crate) fn brick(&mut self, b: [i64; 3], reach: Option<&[u16]>, uniform: u16) -> Result<(), String> {
        if reach.is_none() {
            if let Some(&s) = self.shared.get(&(uniform, 0)) {
                // One value by construction, its slot made already: no texel to visit.
                self.me.uniform_bricks += 1;
                return self.record(b, [uniform; 2], s);
            }
        }
        let (v, gr) = (&mut self.v, &mut self.gr);
        let d = self.me.dims.map(i64::from);
        let b8 = i64::from(BRICK);
        let base = b.map(|c| b8 * c - 1);
        let (lo, hi) = if let Some(reach) = reach {
            let cl = |a: usize, p: i64| p.clamp(0, d[a] - 1);
            let k = |a: usize, p: i64| (cl(a, p) - base[a]) as usize;
            let at = |x: usize, y: usize, z: usize| reach[(z * REACH + y) * REACH + x];
            let mut t = 0;
            for j in 0..i64::from(SLOT) {
                for jy in 0..i64::from(SLOT) {
                    for jx in 0..i64::from(SLOT) {
                        let q = [cl(0, b8 * b[0] + jx), cl(1, b8 * b[1] + jy), cl(2, b8 * b[2] + j)];
                        let (x, y, z) = (k(0, q[0]), k(1, q[1]), k(2, q[2]));
                        v[t] = at(x, y, z);
                        gr[t] = gradient_u16(
                            [at(k(0, q[0] + 1), y, z), at(k(0, q[0] - 1), y, z)],
                            [at(x, k(1, q[1] + 1), z), at(x, k(1, q[1] - 1), z)],
                            [at(x, y, k(2, q[2] + 1)), at(x, y, k(2, q[2] - 1))],
                        );
                        t += 1;
                    }
                }
            }
            // As `block_ranges`: the block dilated by one voxel, within the volume.
            let r = |a: usize| k(a, base[a])..=k(a, b8 * b[a] + 8);
            let (mut lo, mut hi) = (u16::MAX, 0u16);
            for z in r(2) {
                for y in r(1) {
                    for x in r(0) {
                        lo = lo.min(at(x, y, z));
                        hi = hi.max(at(x, y, z));
                    }
                }
            }
            (lo, hi)
        } else {
            v.fill(uniform);
            gr.fill(0);
            (uniform, uniform)
        };
        let me = &mut self.me;
        // Slots grow by a quarter at a time (not doubling), so their spare room stays small
        // next to the bricks a load holds.
        if me.values.capacity() - me.values.len() < SLOT_TEXELS {
            let more = (me.values.len() / 4).max(64 * SLOT_TEXELS);
            let oom = |_| format!("cannot allocate {} more bytes for brick slots", 4 * more);
            me.values.try_reserve_exact(more).map_err(oom)?;
            me.gradients.try_reserve_exact(more).map_err(oom)?;
        }
        let uniform = v.iter().all(|&x| x == v[0]) && gr.iter().all(|&x| x == gr[0]);
        let slot = if uniform {
            me.uniform_bricks += 1;
            match self.shared.get(&(v[0], gr[0])) {
                Some(&s) => s,
                None => {
                    let s = me.push_slot(v, gr);
                    self.shared.insert((v[0], gr[0]), s);
                    me.shared_slots += 1;
                    self.uniform_slot.push(true);
                    s
                }
            }
        } else {
            self.uniform_slot.push(false);
            me.push_slot(v, gr)
        };
        self.record(b, [lo, hi], slot)
    }

    /// Brick `b` takes slot `slot`; its dilated range `r` joins its cell's.
    fn record(&mut self, b: [i64; 3], r: [u16; 2], slot: u32) -> Result<(), String> {
        let bu = b.map(|c| c as u32);
        let g = self.me.grid.map(u64::from);
        let i = (u64::from(bu[2]) * g[1] + u64::from(bu[1])) * g[0] + u64::from(bu[0]);
        self.out_of_order |= i != self.next;
        self.next = i + 1;
        self.me.slot_of.set(bu, slot)?;
        self.occupied_bricks += u64::from(r[0] < r[1]);
        let c = &mut self.ranges[cells::cell_of(b.map(|v| v as u32), self.k, self.cells)];
        c[0] = c[0].min(f32::from(r[0]) / 65535.0);
        c[1] = c[1].max(f32::from(r[1]) / 65535.0);
        Ok(())
    }

    /// Renumbers the slots by their first brick in page-table order, moving them in place (one
    /// slot of scratch), so bricks added out of order (top layer first) equal those added in
    /// order and [`Bricks::build`]'s; in order, every slot stays where it is.
    fn number_slots_in_page_order(&mut self) {
        if !self.out_of_order {
            return;
        }
        let n = self.uniform_slot.len();
        let mut to = vec![u32::MAX; n];
        let mut next = 0;
        for i in 0..self.me.slot_of.len() {
            let t = &mut to[self.me.slot_of.get_index(i) as usize];
            if *t == u32::MAX {
                *t = next;
                next += 1;
            }
        }
        // A slot no brick points to (none, if every brick was added once) keeps a place after.
        for t in to.iter_mut().filter(|t| **t == u32::MAX) {
            *t = next;
            next += 1;
        }
        self.me.slot_of = self.me.slot_of.map(|s| to[s as usize]);
        let mut moved = vec![false; n];
        let mut scratch = (vec![0u16; SLOT_TEXELS], vec![0u16; SLOT_TEXELS]);
        for start in 0..n {
            if moved[start] || to[start] as usize == start {
                continue;
            }
            // Carry slot `start` to its place, taking up the slot found there, round the cycle.
            scratch.0.copy_from_slice(&self.me.values[start * SLOT_TEXELS..][..SLOT_TEXELS]);
            scratch.1.copy_from_slice(&self.me.gradients[start * SLOT_TEXELS..][..SLOT_TEXELS]);
            let mut uniform = self.uniform_slot[start];
            let mut at = start;
            loop {
                moved[at] = true;
                let dst = to[at] as usize;
                self.me.values[dst * SLOT_TEXELS..][..SLOT_TEXELS].swap_with_slice(&mut scratch.0);
                self.me.gradients[dst * SLOT_TEXELS..][..SLOT_TEXELS].swap_with_slice(&mut scratch.1);
                std::mem::swap(&mut self.uniform_slot[dst], &mut uniform);
                at = dst;
                if at == start {
                    break;
                }
            }
        }
    }

    /// The bricks with their block ranges, histogram and largest gradient.
    pub(crate) fn finish(mut self) -> SparseBuild {
        self.number_slots_in_page_order();
        let Self { me, ranges, uniform_slot, k, occupied_bricks, .. } = self;
        let dims = me.dims;
        // Every texel of a slot is a voxel of the volume (the apron clamped), so the slots hold
        // every voxel's gradient and none other.
        let max_gradient = me.gradients.iter().copied().max().unwrap_or(0) as f32 / 65535.0;
        let bin = histogram_bin(max_gradient);
        let mut histogram = vec![0u32; TF_VALUES * TF_GRADIENTS];
        let voxels = |o: [u32; 3], e: [u32; 3]| -> u64 {
            (0..3).map(|a| u64::from((dims[a] - BRICK * o[a]).min(BRICK * e[a]))).product()
        };
        me.slot_of.for_each_page(|_, o, e, page, own| {
            let add = |histogram: &mut Vec<u32>, s: u32, b: [u32; 3], n: u64| {
                let slot = &me.values[s as usize * SLOT_TEXELS..][..SLOT_TEXELS];
                let grads = &me.gradients[s as usize * SLOT_TEXELS..][..SLOT_TEXELS];
                if uniform_slot[s as usize] {
                    let h = &mut histogram[bin(slot[0], grads[0])];
                    *h = h.saturating_add(n.min(u64::from(u32::MAX)) as u32);
                    return;
                }
                let count = [0, 1, 2].map(|a| (dims[a] - BRICK * b[a]).min(BRICK) as usize);
                let s9 = SLOT as usize;
                for z in 0..count[2] {
                    for y in 0..count[1] {
                        for x in 0..count[0] {
                            let t = (z * s9 + y) * s9 + x;
                            let h = &mut histogram[bin(slot[t], grads[t])];
                            *h = h.saturating_add(1);
                        }
                    }
                }
            };
            match (page, own) {
                // A page of one uniform slot: its voxels in one count, however many bricks.
                (Page::Uniform(s), None) if uniform_slot[s as usize] => add(&mut histogram, s, o, voxels(o, e)),
                _ => {
                    for z in 0..e[2] {
                        for y in 0..e[1] {
                            for x in 0..e[0] {
                                let b = [o[0] + x, o[1] + y, o[2] + z];
                                add(&mut histogram, me.slot_of.get(b), b, voxels(b, [1; 3]));
                            }
                        }
                    }
                }
            }
        });
        SparseBuild { bricks: me, block_ranges: ranges, cell_bricks: k, occupied_bricks, histogram, max_gradient }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::data::stats::{block_ranges, gradient_magnitudes, histogram};
    use crate::volume::data::{self, LoadOptions};

    /// The dense builder's output on every voxel of `g`, against this module's.
    fn assert_same_as_dense(g: &SparseGrid, what: &str) {
        let [nx, ny, nz] = g.dims.map(i64::from);
        let mut dense = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    dense.push(g.value([x, y, z]));
                }
            }
        }
        let grad = gradient_magnitudes(&dense, g.dims);
        let want = Bricks::build(&dense, &grad, g.dims).expect("dense bricks");
        let got = build(g).expect("sparse bricks");
        assert_eq!(got.bricks, want, "{what}: bricks");
        let grid = g.dims.map(|d| d.div_ceil(BRICK));
        let ranges = block_ranges(&dense, g.dims, grid);
        assert_eq!(got.block_ranges, cells::coarsen(&ranges, grid, cells::bricks_per_cell(grid)), "{what}: ranges");
        // Cells of 2³ and 4³ bricks (what boxes past `cells::MAX_CELLS` bricks get), partial
        // at the grid's upper ends: the union of their bricks' ranges.
        for k in [2, 4] {
            let got = build_in_cells(g, k).expect("sparse bricks in cells");
            assert_eq!(got.block_ranges, cells::coarsen(&ranges, grid, k), "{what}: ranges in cells of {k}");
        }
        let max = grad.iter().copied().max().unwrap_or(0) as f32 / 65535.0;
        assert_eq!(got.max_gradient, max, "{what}: max gradient");
        assert_eq!(got.histogram, histogram(&dense, &grad, max), "{what}: histogram");
    }

    #[test]
    fn leaves_and_tiles_brick_as_their_dense_box_does() {
        // Boxes aligned to the leaves and not (a leaf then starts 1, 3 or 7 voxels into a
        // brick: 1 is where a brick's reach, 8b − 1 ..= 8b + 9, just meets it), leaves on both
        // sides of leaf and brick borders, an 8³ tile, a 128³ tile cut by the box and the
        // background elsewhere.
        for origin in [[-3i64, 5, 1], [-1, 5, 7], [0, 0, 0]] {
            synthetic(origin);
        }
    }

    fn synthetic(origin: [i64; 3]) {
        let dims = [150u32, 27, 140];
        let mut leaves = std::collections::HashMap::new();
        for (n, k) in [[0i64, 0, 0], [1, 0, 0], [1, 1, 0], [5, 2, 3], [17, 3, 16], [-1, 1, 1]].iter().enumerate() {
            let leaf: Box<[u16; 512]> =
                Box::new(std::array::from_fn(|i| if (i + n) % 3 == 0 { (i * 97 + n * 1000) as u16 } else { 7 }));
            leaves.insert(*k, leaf);
        }
        let mut tiles = std::collections::HashMap::new();
        tiles.insert((8, [3, 3, 3]), 40000u16);
        tiles.insert((128, [0, 0, 1]), 20000u16);
        let g = SparseGrid { dims, origin, background: 7, leaves, tiles };
        assert_same_as_dense(&g, &format!("synthetic, origin {origin:?}"));
        // A background no voxel shows differs from the leaves' inactive voxels' 7.
        let g = SparseGrid { background: 3, ..g };
        assert_same_as_dense(&g, &format!("synthetic, origin {origin:?}, background 3"));
    }

    #[test]
    fn openvdb_fixtures_brick_as_their_dense_load_does() {
        for name in ["sparse.vdb", "smoke.vdb"] {
            let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats").join(name);
            let dense = data::load(&p, &LoadOptions::default()).expect("dense load");
            let g = dense.sparse.as_deref().expect("a VDB load keeps its sparse grid");
            // The grid's voxels are the dense load's, normalized the same way.
            let values: Vec<u16> = (0..dense.voxel_count() as u32)
                .map(|i| {
                    let [nx, ny] = [dense.dims[0], dense.dims[1]];
                    g.value([i % nx, i / nx % ny, i / (nx * ny)].map(i64::from))
                })
                .collect();
            assert_eq!(values, dense.normalized_u16().into_owned(), "{name}: sparse grid vs dense load");
            assert_same_as_dense(g, name);
            // Loaded sparse only (every box above `stream_above`), the volume is the same.
            let sparse = data::load(&p, &LoadOptions { stream_above: 0, ..LoadOptions::default() }).expect("sparse");
            assert!(sparse.data.is_empty() && sparse.sparse_only().is_some(), "{name}: not densified");
            assert_eq!(sparse.value_range, dense.value_range, "{name}: value range");
            assert_eq!(sparse.dims, dense.dims, "{name}: dims");
            assert_eq!(sparse.normalized_u16(), dense.normalized_u16(), "{name}: normalized values");
        }
    }
}
