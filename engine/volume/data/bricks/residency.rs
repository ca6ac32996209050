//! View-dependent residency over the brick pyramid: which level's brick stands for each region
//! of a volume that cannot be on the device whole at level 0. [`choose`] refines a cut through
//! the pyramid (one node per region, each a brick of some level) from the coarsest brick down,
//! largest projected voxel first, within a byte budget; regions outside the frustum stay
//! coarse. [`Streamer`] moves the device from one cut to the next a bounded number of bytes per
//! frame, so an orbit never waits on a whole cut: until a finer brick arrives its region shows
//! the finest resident brick above it (the coarsest level is always resident).
//!
//! Costs are the bricks' own slots (values and gradient magnitudes); a brick that cannot vary
//! shares a uniform slot and costs none. Page-table words rewritten count as uploaded bytes.

use super::pyramid::{coarsest, level_dims, varies};
use super::{BRICK, SLOT_TEXELS};
use std::collections::{BinaryHeap, HashSet};

/// Device bytes of one brick's own slot: values and gradient magnitudes, 16 bits each.
pub const BRICK_BYTES: u64 = 2 * 2 * SLOT_TEXELS as u64;
/// Bytes of one page-table word.
pub const WORD_BYTES: u64 = 4;

/// A brick of the pyramid: `brick` of level `level`'s brick grid. It covers level-0 bricks
/// `brick · 2^level ..< (brick + 1) · 2^level`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Node {
    /// Pyramid level (0: the volume itself).
    pub level: u32,
    /// Brick coordinates at that level.
    pub brick: [u32; 3],
}

/// The pyramid's levels as far as residency needs them: their brick grids and which of their
/// bricks may vary (store a slot of their own).
#[derive(Clone, Debug)]
pub struct Pyramid {
    dims: [u32; 3],
    top: u32,
    grids: Vec<[u32; 3]>,
    varies: Vec<Vec<bool>>,
}

impl Pyramid {
    /// The pyramid of a `dims` volume from its level-0 bricks' dilated ranges (quantized, x
    /// fastest, as the first pass gathers them), up to the level of one brick.
    pub fn from_ranges(ranges: &[[u16; 2]], dims: [u32; 3]) -> Result<Self, String> {
        let grid = dims.map(|d| d.div_ceil(BRICK));
        let n = grid.iter().map(|&g| g as usize).product::<usize>();
        if dims.contains(&0) || ranges.len() != n {
            return Err(format!("{} brick ranges for a {dims:?} volume of {n} bricks", ranges.len()));
        }
        let top = coarsest(dims);
        let grids = (0..=top).map(|k| level_dims(dims, k).map(|d| d.div_ceil(BRICK))).collect();
        let varies = (0..=top).map(|k| varies(ranges, grid, k)).collect();
        Ok(Self { dims, top, grids, varies })
    }

    /// The coarsest level (one brick along every axis).
    pub fn top(&self) -> u32 {
        self.top
    }

    /// Bricks along each axis of level `k`.
    pub fn grid(&self, k: u32) -> [u32; 3] {
        self.grids[k as usize]
    }

    fn index(&self, n: Node) -> usize {
        let g = self.grid(n.level).map(|c| c as usize);
        let b = n.brick.map(|c| c as usize);
        (b[2] * g[1] + b[1]) * g[0] + b[0]
    }

    /// Device bytes of node `n`'s own slot (0 for a brick that shares a uniform slot).
    pub fn bytes(&self, n: Node) -> u64 {
        if self.varies[n.level as usize][self.index(n)] {
            BRICK_BYTES
        } else {
            0
        }
    }

    /// Bytes of every level-`k` brick's own slots: what showing the whole volume at `k` takes.
    pub fn level_bytes(&self, k: u32) -> u64 {
        self.varies[k as usize].iter().filter(|&&v| v).count() as u64 * BRICK_BYTES
    }

    /// The level-0 bricks `n` covers, per axis.
    fn covered(&self, n: Node) -> [std::ops::Range<u32>; 3] {
        let g = self.grid(0);
        [0, 1, 2].map(|a| (n.brick[a] << n.level).min(g[a])..((n.brick[a] + 1) << n.level).min(g[a]))
    }

    /// `n`'s box in level-0 voxels.
    fn bounds(&self, n: Node) -> ([f32; 3], [f32; 3]) {
        let edge = BRICK << n.level;
        let lo = [0, 1, 2].map(|a| (n.brick[a] * edge).min(self.dims[a]) as f32);
        let hi = [0, 1, 2].map(|a| ((n.brick[a] + 1) * edge).min(self.dims[a]) as f32);
        (lo, hi)
    }

    /// The bricks one level finer that `n` splits into (none at level 0).
    fn children(&self, n: Node) -> Vec<Node> {
        if n.level == 0 {
            return Vec::new();
        }
        let g = self.grid(n.level - 1);
        let mut out = Vec::with_capacity(8);
        for i in 0..8u32 {
            let b = [0, 1, 2].map(|a| 2 * n.brick[a] + (i >> a & 1));
            if (0..3).all(|a| b[a] < g[a]) {
                out.push(Node { level: n.level - 1, brick: b });
            }
        }
        out
    }
}

/// Where the camera is and what it sees, in level-0 voxel coordinates (the volume's box is
/// `[0, dims]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// The eye.
    pub eye: [f32; 3],
    /// Frustum planes `(n, d)`: a point p is inside when `n · p + d ≥ 0` for all six.
    pub planes: [[f32; 4]; 6],
}

impl View {
    /// The view of a view-projection matrix `m` (column-major, voxel coordinates to clip space
    /// with depth in [0, 1]) from `eye`.
    pub fn from_view_projection(m: [[f32; 4]; 4], eye: [f32; 3]) -> Self {
        let row = |r: usize| [m[0][r], m[1][r], m[2][r], m[3][r]];
        let (r0, r1, r2, r3) = (row(0), row(1), row(2), row(3));
        let add = |a: [f32; 4], b: [f32; 4], s: f32| [0, 1, 2, 3].map(|i| a[i] + s * b[i]);
        // Gribb and Hartmann: -w ≤ x, y ≤ w and 0 ≤ z ≤ w.
        let planes = [add(r3, r0, 1.0), add(r3, r0, -1.0), add(r3, r1, 1.0), add(r3, r1, -1.0), r2, add(r3, r2, -1.0)];
        Self { eye, planes }
    }

    /// How much node `n` would gain from refining: its voxel edge over its distance from the
    /// eye (the angle one of its voxels subtends), 0 outside the frustum.
    fn priority(&self, p: &Pyramid, n: Node) -> f32 {
        let (lo, hi) = p.bounds(n);
        let outside = self.planes.iter().any(|pl| {
            // The box's corner furthest along the plane's normal.
            let c = [0, 1, 2].map(|a| if pl[a] >= 0.0 { hi[a] } else { lo[a] });
            pl[0] * c[0] + pl[1] * c[1] + pl[2] * c[2] + pl[3] < 0.0
        });
        if outside {
            return 0.0;
        }
        let d2: f32 = (0..3).map(|a| (self.eye[a] - self.eye[a].clamp(lo[a], hi[a])).powi(2)).sum();
        (1u32 << n.level) as f32 / d2.sqrt().max(1.0)
    }
}

/// An entry of the refinement queue: higher priority first, then by node for a deterministic
/// order.
#[derive(PartialEq, Eq, PartialOrd, Ord)]
struct Queued(u32, std::cmp::Reverse<Node>);

fn queued(view: &View, p: &Pyramid, n: Node) -> Queued {
    // Non-negative finite floats order as their bits.
    Queued(view.priority(p, n).to_bits(), std::cmp::Reverse(n))
}

/// The cut for `view` within `budget` bytes of own slots: starting from the coarsest brick,
/// the node of highest [`View::priority`] is split into its children while what they add fits,
/// until no node in the frustum can be split. The coarsest brick counts even once split: it
/// stays resident as every region's fallback. Sorted; every level-0 brick under exactly one
/// node. Everything at level 0 when level 0 fits the budget and the whole volume is in view.
pub fn choose(p: &Pyramid, view: &View, budget: u64) -> Vec<Node> {
    let root = Node { level: p.top, brick: [0; 3] };
    let mut cost = p.bytes(root);
    let mut cut = Vec::new();
    let mut heap = BinaryHeap::from([queued(view, p, root)]);
    while let Some(Queued(pri, std::cmp::Reverse(n))) = heap.pop() {
        if pri == 0 || n.level == 0 {
            cut.push(n);
            continue;
        }
        let children = p.children(n);
        let added: u64 = children.iter().map(|&c| p.bytes(c)).sum();
        // The coarsest brick stays resident under its children ([`Streamer`]).
        let after = cost - if n == root { 0 } else { p.bytes(n) } + added;
        if after > budget {
            cut.push(n);
            continue;
        }
        cost = after;
        heap.extend(children.into_iter().map(|c| queued(view, p, c)));
    }
    cut.sort();
    cut
}

/// What one frame of [`Streamer::frame`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct FrameUpload {
    /// Bytes uploaded: bricks' slots and page-table words.
    pub bytes: u64,
    /// Of them, the bricks' slots.
    pub brick_bytes: u64,
    /// Bricks uploaded.
    pub uploaded: u32,
    /// Bricks evicted.
    pub evicted: u32,
    /// Whether any region now shows another brick (Monte Carlo's progressive mean restarts).
    pub changed: bool,
    /// Bricks of the cut still to upload.
    pub pending: u32,
}

/// The bricks on the device and the level each level-0 brick shows, moved toward a chosen cut
/// at most `upload_budget` bytes per frame and never past `budget` bytes of slots.
#[derive(Clone, Debug)]
pub struct Streamer {
    budget: u64,
    upload_budget: u64,
    resident: HashSet<Node>,
    root: Node,
    /// Level shown by each level-0 brick, x fastest: its finest resident node's.
    shown: Vec<u8>,
    used: u64,
}

impl Streamer {
    /// The coarsest brick resident, every region showing it. Refused, naming the setting, when
    /// the coarsest brick alone is past `budget`.
    pub fn new(p: &Pyramid, budget: u64, upload_budget: u64) -> Result<Self, String> {
        let root = Node { level: p.top, brick: [0; 3] };
        if p.bytes(root) > budget {
            return Err(format!("gpu_memory: {budget} bytes hold not even the coarsest brick ({BRICK_BYTES} bytes)"));
        }
        let n = p.grid(0).iter().map(|&g| g as usize).product::<usize>();
        Ok(Self {
            budget,
            upload_budget,
            resident: HashSet::from([root]),
            root,
            shown: vec![p.top as u8; n],
            used: p.bytes(root),
        })
    }

    /// Level-0 brick `b`'s shown level.
    pub fn level_of(&self, p: &Pyramid, b: [u32; 3]) -> u32 {
        let g = p.grid(0).map(|c| c as usize);
        u32::from(self.shown[(b[2] as usize * g[1] + b[1] as usize) * g[0] + b[0] as usize])
    }

    /// Level-0 bricks showing each level, finest first.
    pub fn shown_counts(&self, p: &Pyramid) -> Vec<u64> {
        let mut out = vec![0; p.top as usize + 1];
        for &l in &self.shown {
            out[l as usize] += 1;
        }
        out
    }

    /// Resident bricks of each level, finest first.
    pub fn resident_counts(&self, p: &Pyramid) -> Vec<u64> {
        let mut out = vec![0; p.top as usize + 1];
        for n in &self.resident {
            out[n.level as usize] += 1;
        }
        out
    }

    /// The resident bricks (the coarsest among them), in no order.
    pub fn resident(&self) -> impl Iterator<Item = &Node> {
        self.resident.iter()
    }

    /// Bytes of the resident bricks' own slots.
    pub fn resident_bytes(&self) -> u64 {
        self.used
    }

    /// The level-0 bricks under `n` whose shown level changes when `n` arrives (`adding`) or
    /// leaves, with their new levels.
    fn changes(&self, p: &Pyramid, n: Node, adding: bool) -> Vec<(usize, u8)> {
        let g = p.grid(0).map(|c| c as usize);
        let [xs, ys, zs] = p.covered(n);
        let mut out = Vec::new();
        for z in zs {
            for y in ys.clone() {
                for x in xs.clone() {
                    let i = (z as usize * g[1] + y as usize) * g[0] + x as usize;
                    let shown = u32::from(self.shown[i]);
                    if adding && shown > n.level {
                        out.push((i, n.level as u8));
                    } else if !adding && shown == n.level {
                        // The finest resident node above it (the root at the latest).
                        let up = (n.level + 1..=p.top)
                            .find(|&l| self.resident.contains(&Node { level: l, brick: [x, y, z].map(|c| c >> l) }))
                            .unwrap_or(p.top);
                        out.push((i, up as u8));
                    }
                }
            }
        }
        out
    }

    /// One frame toward `target` (a cut from [`choose`] for `view`): bricks not in it are
    /// evicted, then its missing bricks are uploaded, highest priority first, while the frame's
    /// bytes stay within the upload budget and the slots within the device budget. A brick
    /// whose upload alone is past the frame's budget is left pending.
    pub fn frame(&mut self, p: &Pyramid, view: &View, target: &[Node]) -> FrameUpload {
        let want: HashSet<Node> = target.iter().copied().chain([self.root]).collect();
        let mut f = FrameUpload::default();
        let mut gone: Vec<Node> = self.resident.iter().filter(|n| !want.contains(n)).copied().collect();
        // Finest first: a coarser brick leaving then sees no finer one still resident under it.
        gone.sort();
        for n in gone {
            let ch = self.changes(p, n, false);
            let cost = ch.len() as u64 * WORD_BYTES;
            if f.bytes + cost > self.upload_budget {
                continue;
            }
            self.resident.remove(&n);
            self.used -= p.bytes(n);
            f.bytes += cost;
            f.evicted += 1;
            f.changed |= !ch.is_empty();
            for (i, l) in ch {
                self.shown[i] = l;
            }
        }
        let mut missing: Vec<Queued> =
            target.iter().filter(|n| !self.resident.contains(n)).map(|&n| queued(view, p, n)).collect();
        missing.sort_by(|a, b| b.cmp(a));
        for Queued(_, std::cmp::Reverse(n)) in missing {
            let ch = self.changes(p, n, true);
            let cost = p.bytes(n) + ch.len() as u64 * WORD_BYTES;
            if f.bytes + cost > self.upload_budget || self.used + p.bytes(n) > self.budget {
                f.pending += 1;
                continue;
            }
            self.resident.insert(n);
            self.used += p.bytes(n);
            f.bytes += cost;
            f.brick_bytes += p.bytes(n);
            f.uploaded += 1;
            f.changed |= !ch.is_empty();
            for (i, l) in ch {
                self.shown[i] = l;
            }
        }
        f
    }
}
