//! The page table on the host: one number per brick (a slot, or a page-table word), kept in
//! pages of 8³ bricks where a page whose bricks all hold one number (the background, a tile's
//! inside) is that number alone. Its memory grows with the pages that hold data, not with the
//! box: eight blobs 4,096 voxels apart (516³ bricks) would take 550 MB as one number per brick.

/// Bricks per page edge (the device directory's unit, `volume/common.glsl`'s `PAGE`).
pub const PAGE: u32 = 8;
/// Bricks per page.
pub const PAGE_BRICKS: usize = (PAGE * PAGE * PAGE) as usize;

/// A page: every brick's number, or where its own numbers are kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Page {
    /// No brick set yet (reads as 0).
    Unset,
    /// Every brick holds this number.
    Uniform(u32),
    /// The bricks' numbers are `PAGE_BRICKS` entries at this index of the stored pages.
    Stored(u32),
}

/// Brick → number for a grid of bricks, paged (module docs).
#[derive(Clone, Debug)]
pub struct PageTable {
    grid: [u32; 3],
    pages: [u32; 3],
    dir: Vec<Page>,
    stored: Vec<u32>,
}

fn alloc<T: Clone>(n: usize, v: T, what: &str) -> Result<Vec<T>, String> {
    let mut out = Vec::new();
    out.try_reserve_exact(n).map_err(|_| format!("cannot allocate {what} of {n} entries"))?;
    out.resize(n, v);
    Ok(out)
}

impl PageTable {
    /// A table over `grid` bricks with nothing set.
    pub fn new(grid: [u32; 3]) -> Result<Self, String> {
        let pages = grid.map(|g| g.div_ceil(PAGE));
        let n = pages.iter().try_fold(1usize, |a, &p| a.checked_mul(p as usize)).ok_or("too many pages")?;
        Ok(Self { grid, pages, dir: alloc(n, Page::Unset, "the page directory")?, stored: Vec::new() })
    }

    /// Bricks along x, y, z.
    pub fn grid(&self) -> [u32; 3] {
        self.grid
    }

    /// Pages along x, y, z.
    pub fn pages(&self) -> [u32; 3] {
        self.pages
    }

    /// Bricks in the table.
    pub fn len(&self) -> u64 {
        self.grid.iter().map(|&g| u64::from(g)).product()
    }

    /// Whether the grid holds no brick.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Brick coordinates of index `i` (x fastest).
    pub fn brick(&self, i: u64) -> [u32; 3] {
        let [gx, gy, _] = self.grid.map(u64::from);
        [i % gx, i / gx % gy, i / (gx * gy)].map(|c| c as u32)
    }

    fn page_of(&self, b: [u32; 3]) -> (usize, usize) {
        let p = b.map(|c| (c / PAGE) as usize);
        let l = b.map(|c| (c % PAGE) as usize);
        let [px, py, _] = self.pages.map(|c| c as usize);
        ((p[2] * py + p[1]) * px + p[0], (l[2] * PAGE as usize + l[1]) * PAGE as usize + l[0])
    }

    /// The number of brick `b`.
    pub fn get(&self, b: [u32; 3]) -> u32 {
        let (p, l) = self.page_of(b);
        match self.dir[p] {
            Page::Unset => 0,
            Page::Uniform(v) => v,
            Page::Stored(s) => self.stored[s as usize * PAGE_BRICKS + l],
        }
    }

    /// The number of brick index `i` (x fastest).
    pub fn get_index(&self, i: u64) -> u32 {
        self.get(self.brick(i))
    }

    /// Sets brick `b`'s number; a page gets its own numbers when a second one arrives (until
    /// then, its bricks not yet set read as the first number set).
    pub fn set(&mut self, b: [u32; 3], v: u32) -> Result<(), String> {
        let (p, l) = self.page_of(b);
        match self.dir[p] {
            Page::Unset => self.dir[p] = Page::Uniform(v),
            Page::Uniform(u) if u == v => {}
            Page::Uniform(u) => {
                let s = self.stored.len() / PAGE_BRICKS;
                if self.stored.capacity() - self.stored.len() < PAGE_BRICKS {
                    // A quarter more at a time: the spare room stays small next to the pages.
                    let more = (self.stored.len() / 4).max(16 * PAGE_BRICKS);
                    self.stored
                        .try_reserve_exact(more)
                        .map_err(|_| format!("cannot allocate {} more bytes for page-table pages", 4 * more))?;
                }
                self.stored.resize(self.stored.len() + PAGE_BRICKS, u);
                self.stored[s * PAGE_BRICKS + l] = v;
                self.dir[p] = Page::Stored(s as u32);
            }
            Page::Stored(s) => self.stored[s as usize * PAGE_BRICKS + l] = v,
        }
        Ok(())
    }

    /// Page `p` (x fastest over [`Self::pages`]) and, when stored, its bricks' numbers.
    pub fn page(&self, p: usize) -> (Page, Option<&[u32]>) {
        let page = self.dir[p];
        let own = match page {
            Page::Stored(s) => Some(&self.stored[s as usize * PAGE_BRICKS..][..PAGE_BRICKS]),
            _ => None,
        };
        (page, own)
    }

    /// Pages holding numbers of their own.
    pub fn stored_pages(&self) -> usize {
        self.stored.len() / PAGE_BRICKS
    }

    /// Host bytes the table takes.
    pub fn bytes(&self) -> u64 {
        (self.dir.len() * std::mem::size_of::<Page>() + self.stored.len() * 4) as u64
    }

    /// Calls `f(page, first brick, extent in bricks, numbers)` for every page, where `numbers` is
    /// `None` for a page whose bricks all hold the number of its `Page`.
    pub fn for_each_page(&self, mut f: impl FnMut(usize, [u32; 3], [u32; 3], Page, Option<&[u32]>)) {
        let [px, py, pz] = self.pages;
        let mut p = 0;
        for z in 0..pz {
            for y in 0..py {
                for x in 0..px {
                    let o = [x, y, z].map(|c| c * PAGE);
                    let e = [0, 1, 2].map(|a| (self.grid[a] - o[a]).min(PAGE));
                    let (page, own) = self.page(p);
                    f(p, o, e, page, own);
                    p += 1;
                }
            }
        }
    }

    /// Calls `f(brick, number)` for every brick, page by page (a uniform page's bricks in a row).
    pub fn for_each_brick(&self, mut f: impl FnMut([u32; 3], u32)) {
        self.for_each_page(|_, o, e, page, own| {
            for z in 0..e[2] {
                for y in 0..e[1] {
                    for x in 0..e[0] {
                        let v = match (page, own) {
                            (_, Some(own)) => own[((z * PAGE + y) * PAGE + x) as usize],
                            (Page::Uniform(v), None) => v,
                            _ => 0,
                        };
                        f([o[0] + x, o[1] + y, o[2] + z], v);
                    }
                }
            }
        });
    }

    /// The numbers of every brick, x fastest (the flat page table; one entry per brick).
    pub fn flat(&self, mut word: impl FnMut([u32; 3], u32) -> u32) -> Result<Vec<u32>, String> {
        let n = usize::try_from(self.len()).map_err(|_| "too many bricks".to_string())?;
        let mut out = alloc(n, 0u32, "the flat page table")?;
        let [gx, gy, _] = self.grid.map(|g| g as usize);
        self.for_each_brick(|b, v| {
            let b = b.map(|c| c as usize);
            out[(b[2] * gy + b[1]) * gx + b[0]] = word(b.map(|c| c as u32), v);
        });
        Ok(out)
    }

    /// The table with every number replaced by `f(number)`.
    pub fn map(&self, f: impl Fn(u32) -> u32) -> Self {
        let dir = self
            .dir
            .iter()
            .map(|p| match *p {
                Page::Uniform(v) => Page::Uniform(f(v)),
                // Reads 0.
                Page::Unset => Page::Uniform(f(0)),
                other => other,
            })
            .collect();
        Self { grid: self.grid, pages: self.pages, dir, stored: self.stored.iter().map(|&v| f(v)).collect() }
    }
}

/// Equal when every brick holds the same number (however the pages are kept).
impl PartialEq for PageTable {
    fn eq(&self, other: &Self) -> bool {
        if self.grid != other.grid {
            return false;
        }
        let mut same = true;
        self.for_each_brick(|b, v| same &= other.get(b) == v);
        same
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_pages_keep_one_number_and_mixed_pages_their_own() {
        let grid = [20, 9, 17];
        let mut t = PageTable::new(grid).expect("table");
        assert_eq!(t.pages(), [3, 2, 3]);
        let n = t.len();
        let value = |b: [u32; 3]| if b[0] == 17 && b[1] == 3 && b[2] == 16 { 7 } else { 1 + b[2] / 8 };
        for i in 0..n {
            let b = t.brick(i);
            t.set(b, value(b)).expect("set");
        }
        // Only the page holding brick (17, 3, 16) mixes numbers.
        assert_eq!(t.stored_pages(), 1);
        for i in 0..n {
            let b = t.brick(i);
            assert_eq!(t.get(b), value(b), "brick {b:?}");
        }
        let flat = t.flat(|b, v| v * 1000 + b[0]).expect("flat");
        assert_eq!(flat.len() as u64, n);
        for (i, &w) in flat.iter().enumerate() {
            let b = t.brick(i as u64);
            assert_eq!(w, value(b) * 1000 + b[0], "flat word of {b:?}");
        }
        let mut seen = 0;
        t.for_each_brick(|b, v| {
            assert_eq!(v, value(b));
            seen += 1;
        });
        assert_eq!(seen, n, "every brick once");
        let mut other = PageTable::new(grid).expect("table");
        assert_ne!(t, other);
        t.for_each_brick(|b, v| other.set(b, v).expect("set"));
        assert_eq!(t, other);
        assert_eq!(t.map(|v| v + 1).get([17, 3, 16]), 8);
    }
}
