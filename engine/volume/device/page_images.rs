//! The page table on the device (`volume/common.glsl`'s `page_word`), in one of two forms:
//! - **flat**: one word per brick (binding 15), a single lookup: what every volume whose table is
//!   small gets, so the default scenes pay nothing for the second form;
//! - **two levels**: a directory with one word per page of 8³ bricks (binding 22) naming a page
//!   of 8³ words in a pool (binding 15). Pages whose words are all one (the background around
//!   far-apart data) share a pool page, so the table grows with the pages that hold data: eight
//!   blobs 4,096 voxels apart need 1.1 MB of directory instead of 550 MB of flat table.
//!
//! A word carries the brick's occupancy bit ([`PAGE_OCCUPIED`]), rewritten for each transfer
//! function ([`DevicePages::mark`]); the words without it are kept here for that.

use crate::error::{Error, Result};
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::data::bricks::page_table::{Page, PageTable, PAGE, PAGE_BRICKS};
use crate::volume::data::bricks::{atlas_slots, MAX_SLOTS_PER_AXIS};
use std::collections::HashMap;

/// Bit of a page-table word set when its brick may be visible under the transfer function
/// (`volume/common.glsl`'s `PAGE_OCCUPIED`): EAM's empty-space skipping reads it with the slot.
pub const PAGE_OCCUPIED: u32 = 1 << 31;

/// Largest flat table kept flat whatever a directory would save (16 KiB: 4,096 bricks, a 128³
/// volume): small tables stay one lookup.
pub const FLAT_BYTES: u64 = 16 << 10;

/// The page table's images and the words they hold (module docs).
pub struct DevicePages {
    /// 1 (flat) or 2 (directory and pool): specialization constant 5 of `volume/common.glsl`.
    pub levels: u32,
    /// The flat table or the pool of pages (binding 15).
    pub table: Image,
    /// The directory (binding 22), a 1³ placeholder when flat.
    pub directory: Image,
    /// Words without occupancy bits; `None` for a dense volume's placeholders.
    entries: Option<PageTable>,
    /// Two levels: where each page's words are in the pool.
    pool: Option<PoolLayout>,
    /// A flat table rewritten word by word (view-dependent residency): the words last written,
    /// so [`Self::mark`] writes only those that changed.
    written: Option<std::sync::Mutex<Vec<u32>>>,
}

/// Where a two-level table's pages sit in its pool: pages of their own (stored ones, and uniform
/// ones whose bricks may differ in occupancy), then two shared pages per word some whole page
/// holds (without and with the occupancy bit).
#[derive(Clone, Debug)]
struct PoolLayout {
    /// Each page's own pool page (`u32::MAX`: it shares one).
    own: Vec<u32>,
    /// Pages of their own.
    own_pages: u32,
    /// The rank of each shared word (its pool pages: `own_pages + 2 · rank + bit`).
    shared: HashMap<u32, u32>,
    /// Pool pages along each axis.
    pool: [u32; 3],
}

impl PoolLayout {
    /// The layout for `entries`, where `mixed(first brick, extent)` says whether a uniform
    /// page's bricks may get different occupancy bits; at most `per_axis` pool pages along each
    /// axis (`None` when they do not fit).
    fn plan(entries: &PageTable, mixed: impl Fn([u32; 3], [u32; 3]) -> bool, per_axis: u32) -> Option<Self> {
        let mut own = Vec::new();
        let mut shared = HashMap::new();
        let mut next = 0u32;
        entries.for_each_page(|_, o, e, page, _| match page {
            // An unset page reads 0 throughout, as a uniform page of 0.
            Page::Uniform(_) | Page::Unset if !mixed(o, e) => {
                let w = if let Page::Uniform(w) = page { w } else { 0 };
                let n = shared.len() as u32;
                shared.entry(w).or_insert(n);
                own.push(u32::MAX);
            }
            _ => {
                own.push(next);
                next += 1;
            }
        });
        let n = shared.len() as u32;
        shared.entry(0).or_insert(n);
        let pages = u32::try_from(u64::from(next) + 2 * shared.len() as u64).ok()?;
        let pool = atlas_slots(pages, per_axis)?;
        Some(Self { own, own_pages: next, shared, pool })
    }

    /// Pool pages.
    fn pages(&self) -> u64 {
        u64::from(self.own_pages) + 2 * self.shared.len() as u64
    }

    /// Bytes of the pool.
    fn bytes(&self) -> u64 {
        self.pages() * PAGE_BRICKS as u64 * 4
    }

    /// The directory's and the pool's words, occupancy bits from `bit` (constant over each page
    /// that shares a pool page).
    fn words(&self, entries: &PageTable, bit: impl Fn([u32; 3]) -> u32) -> (Vec<u32>, Vec<u32>) {
        let [ax, ay, az] = self.pool.map(|p| p as usize);
        let p8 = PAGE as usize;
        let (w, h) = (ax * p8, ay * p8);
        let mut pool = vec![0u32; w * h * az * p8];
        let coords = |q: u32| {
            let q = q as usize;
            [q % ax, q / ax % ay, q / (ax * ay)]
        };
        let texel = |c: [usize; 3], l: [usize; 3]| ((c[2] * p8 + l[2]) * h + c[1] * p8 + l[1]) * w + c[0] * p8 + l[0];
        let encode = |c: [usize; 3]| (c[0] | c[1] << 10 | c[2] << 20) as u32;
        let mut dir = Vec::with_capacity(self.own.len());
        entries.for_each_page(|p, o, e, page, own| {
            let q = self.own[p];
            if q == u32::MAX {
                let word = match page {
                    Page::Uniform(v) => v,
                    _ => 0,
                };
                let rank = self.shared.get(&word).copied().unwrap_or(0);
                let occupied = u32::from(bit(o) != 0);
                dir.push(encode(coords(self.own_pages + 2 * rank + occupied)));
                return;
            }
            let c = coords(q);
            for z in 0..e[2] {
                for y in 0..e[1] {
                    for x in 0..e[0] {
                        let l = [x, y, z].map(|v| v as usize);
                        let v = match (page, own) {
                            (_, Some(own)) => own[(l[2] * p8 + l[1]) * p8 + l[0]],
                            (Page::Uniform(v), None) => v,
                            _ => 0,
                        };
                        pool[texel(c, l)] = v | bit([o[0] + x, o[1] + y, o[2] + z]);
                    }
                }
            }
            dir.push(encode(c));
        });
        for (&word, &rank) in &self.shared {
            for occupied in [0, 1] {
                let c = coords(self.own_pages + 2 * rank + occupied);
                for l in (0..PAGE_BRICKS).map(|i| [i % p8, i / p8 % p8, i / (p8 * p8)]) {
                    pool[texel(c, l)] = word | (occupied * PAGE_OCCUPIED);
                }
            }
        }
        (dir, pool)
    }
}

/// Pool pages along one axis on `ctx`'s device: its 3D-image limit in pages, and the
/// directory word's 10 bits.
fn pool_per_axis(ctx: &Context) -> u32 {
    (ctx.info.limits.max_image_dimension3_d / PAGE).min(MAX_SLOTS_PER_AXIS)
}

/// The form a table over `grid` bricks takes on `ctx`'s device given its pool layout (`None`:
/// its pages fit no pool), as [`DevicePages::new`] makes it: levels, and device bytes (two
/// levels: directory and pool). `ContextOptions::page_levels` forces the levels.
fn form(ctx: &Context, grid: [u32; 3], plan: Option<&PoolLayout>) -> (u32, u64) {
    let max3d = ctx.info.limits.max_image_dimension3_d;
    let max_allocation = super::layout::device_budget(ctx).max_allocation;
    let two = plan.is_some_and(|p| two_levels(grid, p.pages(), max3d, max_allocation));
    match ctx.info.page_levels.unwrap_or(if two { 2 } else { 1 }) {
        2 => (2, directory_bytes(grid) + plan.map_or(0, PoolLayout::bytes)),
        _ => (1, flat_bytes(grid)),
    }
}

/// Device bytes the page table of `entries` will take on `ctx`'s device (uniform pages counted
/// as shared: the few that keep their own page where occupancy cells differ add 2 KiB each).
pub fn planned_bytes(ctx: &Context, entries: &PageTable) -> u64 {
    let plan = PoolLayout::plan(entries, |_, _| false, pool_per_axis(ctx));
    form(ctx, entries.grid(), plan.as_ref()).1
}

/// Whether the occupancy cells (of `k`³ bricks over a `grid` of bricks; `ranges` theirs, x
/// fastest) that bricks `o .. o + e` touch differ in range, so their bricks may differ in
/// occupancy bit (equal ranges give equal bits).
fn cells_differ(ranges: &[[f32; 2]], k: u32, grid: [u32; 3], o: [u32; 3], e: [u32; 3]) -> bool {
    let cells = grid.map(|g| g.div_ceil(k));
    let cell = |c: [u32; 3]| ((c[2] * cells[1] + c[1]) * cells[0] + c[0]) as usize;
    let (lo, hi) = (o.map(|v| v / k), [0, 1, 2].map(|a| (o[a] + e[a] - 1) / k));
    let first = ranges[cell(lo)];
    (lo[2]..=hi[2]).any(|z| (lo[1]..=hi[1]).any(|y| (lo[0]..=hi[0]).any(|x| ranges[cell([x, y, z])] != first)))
}

/// Bytes of a flat table over `grid` bricks.
pub fn flat_bytes(grid: [u32; 3]) -> u64 {
    grid.iter().map(|&g| u64::from(g)).product::<u64>() * 4
}

/// Bytes of a two-level table's directory over `grid` bricks: a word per page.
fn directory_bytes(grid: [u32; 3]) -> u64 {
    flat_bytes(grid.map(|g| g.div_ceil(PAGE)))
}

/// Whether a table of these sizes takes two levels: where the flat one cannot be an image
/// (`max3d`) or one allocation (`max_allocation`), or is past [`FLAT_BYTES`] and the directory
/// and pool take at most a quarter of it.
pub fn two_levels(grid: [u32; 3], pool_pages: u64, max3d: u32, max_allocation: u64) -> bool {
    let two = directory_bytes(grid) + pool_pages * PAGE_BRICKS as u64 * 4;
    let flat = flat_bytes(grid);
    grid.iter().any(|&g| g > max3d) || flat > max_allocation || (flat > FLAT_BYTES && 4 * two <= flat)
}

fn storage_image(ctx: &Context, name: &str, dims: [u32; 3]) -> Result<Image> {
    let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST;
    Image::new(ctx, name, ImageInfo::d3(vk::Format::R32_UINT, dims, usage))
}

/// Writes `words` into `img`, left in `GENERAL` for the passes to read.
fn upload(ctx: &Context, img: &Image, words: &[u32]) -> Result<()> {
    ctx.upload_image(
        img,
        bytemuck::cast_slice(words),
        vk::ImageLayout::GENERAL,
        vk::PipelineStageFlags2::COMPUTE_SHADER,
        vk::AccessFlags2::SHADER_STORAGE_READ,
    )
}

impl DevicePages {
    /// 1³ placeholders for a dense volume (the shaders fold the lookups away).
    pub fn placeholder(ctx: &Context) -> Result<Self> {
        let table = storage_image(ctx, "page table (unused)", [1; 3])?;
        let directory = storage_image(ctx, "page directory (unused)", [1; 3])?;
        upload(ctx, &table, &[0])?;
        upload(ctx, &directory, &[0])?;
        Ok(Self { levels: 1, table, directory, entries: None, pool: None, written: None })
    }

    /// The table of `entries` (words without occupancy bits), its images unwritten until the
    /// first [`Self::mark`] (the renderer's, with its transfer function: one upload per load).
    /// `ranges` are the occupancy cells' value ranges, cells of `k`³ bricks: a uniform page over
    /// cells of different ranges may need different bits, so it keeps a pool page of its own.
    /// `ContextOptions::page_levels` forces the form. A form past one allocation is refused with
    /// the numbers.
    pub fn new(ctx: &Context, entries: PageTable, ranges: &[[f32; 2]], k: u32) -> Result<Self> {
        let grid = entries.grid();
        let mixed = |o: [u32; 3], e: [u32; 3]| cells_differ(ranges, k, grid, o, e);
        let max3d = ctx.info.limits.max_image_dimension3_d;
        let too_large = |what: &str| {
            Error::Input(format!(
                "a page table of {}x{}x{} bricks exceeds this device's 3D texture limit {max3d} {what}",
                grid[0], grid[1], grid[2]
            ))
        };
        let plan = PoolLayout::plan(&entries, mixed, pool_per_axis(ctx));
        let max_allocation = super::layout::device_budget(ctx).max_allocation;
        let past_allocation = |bytes: u64| {
            Error::Input(format!(
                "a page table of {}x{}x{} bricks needs {bytes} bytes, past this device's largest allocation ({max_allocation} bytes)",
                grid[0], grid[1], grid[2]
            ))
        };
        let (levels, bytes) = form(ctx, grid, plan.as_ref());
        Ok(if levels == 2 {
            let pool = plan.ok_or_else(|| too_large("even in pages"))?;
            if entries.pages().iter().any(|&p| p > max3d) {
                return Err(too_large("even in pages"));
            }
            // The pool is one image, the directory (a word per page) another.
            if pool.bytes() > max_allocation {
                return Err(past_allocation(pool.bytes()));
            }
            let table = storage_image(ctx, "page pool", pool.pool.map(|p| p * PAGE))?;
            let directory = storage_image(ctx, "page directory", entries.pages())?;
            Self { levels: 2, table, directory, entries: Some(entries), pool: Some(pool), written: None }
        } else {
            if grid.iter().any(|&g| g > max3d) {
                return Err(too_large("as one word per brick"));
            }
            if bytes > max_allocation {
                return Err(past_allocation(bytes));
            }
            let table = storage_image(ctx, "page table", grid)?;
            let directory = storage_image(ctx, "page directory (unused)", [1; 3])?;
            upload(ctx, &directory, &[0])?;
            Self { levels: 1, table, directory, entries: Some(entries), pool: None, written: None }
        })
    }

    /// A flat table of `entries` that [`Self::mark`] rewrites word by word, only the words that
    /// changed since its last write (view-dependent residency, whose words change as the camera
    /// moves). Refused past the device's 3D-image limit or one allocation.
    pub fn flat_partial(ctx: &Context, entries: PageTable) -> Result<Self> {
        let grid = entries.grid();
        let max3d = ctx.info.limits.max_image_dimension3_d;
        let max_allocation = super::layout::device_budget(ctx).max_allocation;
        if grid.iter().any(|&g| g > max3d) || flat_bytes(grid) > max_allocation {
            return Err(Error::Input(format!(
                "a page table of {}x{}x{} bricks exceeds this device's 3D texture limit {max3d} or its largest allocation ({max_allocation} bytes) as one word per brick",
                grid[0], grid[1], grid[2]
            )));
        }
        let table = storage_image(ctx, "page table", grid)?;
        let directory = storage_image(ctx, "page directory (unused)", [1; 3])?;
        upload(ctx, &directory, &[0])?;
        let written = Some(std::sync::Mutex::new(Vec::new()));
        Ok(Self { levels: 1, table, directory, entries: Some(entries), pool: None, written })
    }

    /// Replaces the words (without occupancy bits); the images change at the next
    /// [`Self::mark`].
    pub fn set_entries(&mut self, entries: PageTable) {
        self.entries = Some(entries);
    }

    /// Device bytes of the table's images.
    pub fn bytes(&self) -> u64 {
        self.table.memory_bytes() + self.directory.memory_bytes()
    }

    /// Every brick's word without its occupancy bit, x fastest (empty for a dense volume).
    pub fn flat_words(&self) -> std::result::Result<Vec<u32>, String> {
        match &self.entries {
            Some(entries) => entries.flat(|_, e| e),
            None => Ok(Vec::new()),
        }
    }

    /// Rewrites every word's occupancy bit: `occupied(brick)` (constant over each occupancy cell).
    /// Returns the bytes of words written (a table from [`Self::flat_partial`] writes the words
    /// that changed since its last write, in runs along x).
    pub fn mark(&self, ctx: &Context, occupied: impl Fn([u32; 3]) -> bool) -> Result<u64> {
        let Some(entries) = &self.entries else { return Ok(0) };
        let bit = |b: [u32; 3]| u32::from(occupied(b)) * PAGE_OCCUPIED;
        match (&self.pool, &self.written) {
            (None, Some(written)) => {
                let words = entries.flat(|b, e| e | bit(b)).map_err(Error::Input)?;
                let mut old = written.lock().map_err(|_| Error::Input("page table: a writer panicked".into()))?;
                let bytes = if old.len() == words.len() {
                    write_changed(ctx, &self.table, entries.grid(), &old, &words)?
                } else {
                    upload(ctx, &self.table, &words)?;
                    4 * words.len() as u64
                };
                *old = words;
                Ok(bytes)
            }
            (None, None) => {
                let words = entries.flat(|b, e| e | bit(b)).map_err(Error::Input)?;
                upload(ctx, &self.table, &words)?;
                Ok(4 * words.len() as u64)
            }
            (Some(layout), _) => {
                let (dir, pool) = layout.words(entries, bit);
                upload(ctx, &self.directory, &dir)?;
                upload(ctx, &self.table, &pool)?;
                Ok(4 * (dir.len() + pool.len()) as u64)
            }
        }
    }
}

/// Writes the words of `new` that differ from `old` (flat tables over `grid`, x fastest) into
/// `img`, each run of changed words along x as one box; returns the bytes written.
fn write_changed(ctx: &Context, img: &Image, grid: [u32; 3], old: &[u32], new: &[u32]) -> Result<u64> {
    let (mut boxes, mut data) = (Vec::new(), Vec::<u32>::new());
    let gx = grid[0] as usize;
    for (r, (o, n)) in old.chunks_exact(gx).zip(new.chunks_exact(gx)).enumerate() {
        let (y, z) = ((r % grid[1] as usize) as u32, (r / grid[1] as usize) as u32);
        let mut x = 0;
        while x < gx {
            if o[x] == n[x] {
                x += 1;
                continue;
            }
            let start = x;
            while x < gx && o[x] != n[x] {
                x += 1;
            }
            boxes.push(([start as u32, y, z], [(x - start) as u32, 1, 1]));
            data.extend_from_slice(&n[start..x]);
        }
    }
    ctx.update_image(
        img,
        &boxes,
        bytemuck::cast_slice(&data),
        vk::ImageLayout::GENERAL,
        vk::PipelineStageFlags2::COMPUTE_SHADER,
        vk::AccessFlags2::SHADER_STORAGE_READ,
    )?;
    Ok(4 * data.len() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Decodes brick `b`'s word as `volume/common.glsl`'s `page_word` does.
    fn lookup(layout: &PoolLayout, dir: &[u32], pool: &[u32], pages: [u32; 3], b: [u32; 3]) -> u32 {
        let p = b.map(|c| c / PAGE);
        let d = dir[((p[2] * pages[1] + p[1]) * pages[0] + p[0]) as usize];
        let o = [d & 1023, (d >> 10) & 1023, d >> 20];
        let t = [0, 1, 2].map(|a| (o[a] * PAGE + b[a] % PAGE) as usize);
        let [w, h] = [layout.pool[0] * PAGE, layout.pool[1] * PAGE].map(|v| v as usize);
        pool[(t[2] * h + t[1]) * w + t[0]]
    }

    #[test]
    fn every_brick_reads_its_word_and_bit_through_directory_and_pool() {
        // 3 × 2 × 2 pages: uniform ones of two words, one stored (mixed words), and one uniform
        // page whose bricks get different occupancy bits (it must keep a pool page of its own).
        let grid = [20, 9, 9];
        let mut t = PageTable::new(grid).expect("table");
        let word = |b: [u32; 3]| match b.map(|c| c / PAGE) {
            [1, 0, 0] => 100 + b[0] + 10 * b[1],
            [2, 1, 1] => 9,
            _ => 5,
        };
        for i in 0..t.len() {
            let b = t.brick(i);
            t.set(b, word(b)).expect("set");
        }
        let mixed_page = [0, 1, 0];
        let occupied = |b: [u32; 3]| b[0] >= 8 || (b.map(|c| c / PAGE) == mixed_page && b[1] % 2 == 1);
        let layout = PoolLayout::plan(&t, |o, _| o.map(|c| c / PAGE) == mixed_page, 1023).expect("plan");
        // Own pages: the stored one and the mixed one; shared: words 5 and 9, and 0.
        assert_eq!(layout.own_pages, 2);
        assert_eq!(layout.pages(), 2 + 2 * 3);
        let (dir, pool) = layout.words(&t, |b| u32::from(occupied(b)) * PAGE_OCCUPIED);
        for i in 0..t.len() {
            let b = t.brick(i);
            let want = word(b) | (u32::from(occupied(b)) * PAGE_OCCUPIED);
            assert_eq!(lookup(&layout, &dir, &pool, t.pages(), b), want, "brick {b:?}");
        }
        assert!(two_levels([516; 3], 40, 4096, 1 << 31), "mostly one word: two levels");
        assert!(!two_levels([16; 3], 2, 4096, 1 << 31), "a 128³ volume stays flat");
        assert!(!two_levels([64; 3], 400, 4096, 1 << 31), "two levels saving less than 3/4: flat");
        assert!(two_levels([4097, 1, 1], 4, 4096, 1 << 31), "past the 3D-image limit");
    }

    #[test]
    fn occupancy_bits_follow_cells_of_any_size_through_shared_and_own_pages() {
        // Uniform pages over cells of 1, 2, 4, 8 and 16 bricks, partial pages and cells at the
        // upper ends; each cell's range (and so its bit) set by a pattern that varies inside
        // pages for small cells: those pages keep their own pool page, the others share one.
        let grid = [21, 10, 9];
        let mut t = PageTable::new(grid).expect("table");
        for i in 0..t.len() {
            let b = t.brick(i);
            t.set(b, if b == [9, 9, 8] { 3 } else { 5 }).expect("set");
        }
        for k in [1u32, 2, 4, 8, 16] {
            let cells = grid.map(|g| g.div_ceil(k));
            let n = cells.iter().product::<u32>() as usize;
            let ranges: Vec<[f32; 2]> = (0..n).map(|c| [0.0, if (c * 7 / 3) % 2 == 0 { 0.2 } else { 0.9 }]).collect();
            let bit = |b: [u32; 3]| {
                let c = b.map(|v| v / k);
                let r = ranges[((c[2] * cells[1] + c[1]) * cells[0] + c[0]) as usize];
                u32::from(r[1] > 0.5) * PAGE_OCCUPIED
            };
            let layout = PoolLayout::plan(&t, |o, e| cells_differ(&ranges, k, grid, o, e), 1023).expect("plan");
            let (dir, pool) = layout.words(&t, bit);
            for i in 0..t.len() {
                let b = t.brick(i);
                let want = t.get(b) | bit(b);
                assert_eq!(lookup(&layout, &dir, &pool, t.pages(), b), want, "k = {k}, brick {b:?}");
            }
            eprintln!("k = {k}: {} pages of their own", layout.own_pages);
            if k >= PAGE {
                assert_eq!(layout.own_pages, 1, "k = {k}: a page within one cell is never mixed");
            }
        }
    }
}
