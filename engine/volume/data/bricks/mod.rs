//! The sparse layout's host side: a normalized volume cut into 8³ bricks, each with a one-voxel
//! apron on its upper sides (the next voxel, clamped: trilinear filtering of a point whose lower
//! texel is in the brick reads only its slot), and the page table from bricks to atlas slots. A brick whose slot would be uniform (one value and
//! one gradient magnitude over brick and apron) stores nothing: it shares one slot per distinct
//! (value, gradient), so the shader's lookup has no branch and filters it exactly. The builder
//! (`builder`), the page table (`page_table`) and the occupancy/majorant cells (`cells`) are
//! children; they use `data`'s grids and statistics, and `device` uploads what they build.

pub mod builder;
pub mod cells;
pub mod levels;
pub mod page_table;
pub mod pyramid;
pub mod residency;

use crate::volume::data::bricks::page_table::PageTable;
use crate::volume::data::stats::BLOCK;
use std::collections::HashMap;

/// Voxels per brick edge: the occupancy and majorant grids' block, so each grid cell is a brick.
pub const BRICK: u32 = BLOCK;
/// Texels per slot edge: the brick and its apron (9³ = 1.42 × the brick's texels).
pub const SLOT: u32 = BRICK + 1;
/// Texels per slot.
pub const SLOT_TEXELS: usize = (SLOT * SLOT * SLOT) as usize;
/// Most slots along one atlas axis: the page table's 10 bits per axis (`volume/common.glsl`).
pub const MAX_SLOTS_PER_AXIS: u32 = 1023;

/// A volume in bricks: slot contents and the brick → slot map, before the atlas is arranged.
#[derive(Clone, Debug, PartialEq)]
pub struct Bricks {
    /// Voxels along x, y, z.
    pub dims: [u32; 3],
    /// Bricks along x, y, z (the page table's size).
    pub grid: [u32; 3],
    /// Slot of each brick.
    pub slot_of: PageTable,
    /// Normalized values, slot after slot, each `SLOT_TEXELS` texels x fastest.
    pub values: Vec<u16>,
    /// Gradient magnitudes, laid out as `values`.
    pub gradients: Vec<u16>,
    /// Bricks that point to a shared uniform slot instead of their own.
    pub uniform_bricks: u64,
    /// Of the slots, those shared by uniform bricks.
    pub shared_slots: u32,
}

impl Bricks {
    /// Cuts `values` (normalized, x fastest) and their gradient magnitudes into bricks.
    pub fn build(values: &[u16], gradients: &[u16], dims: [u32; 3]) -> Result<Self, String> {
        let voxels = dims.iter().map(|&d| d as usize).product::<usize>();
        if dims.contains(&0) || values.len() != voxels || gradients.len() != voxels {
            return Err(format!(
                "bricking {}x{}x{}: {} values and {} gradients for {voxels} voxels",
                dims[0],
                dims[1],
                dims[2],
                values.len(),
                gradients.len()
            ));
        }
        let grid = dims.map(|d| d.div_ceil(BRICK));
        let mut me = Self {
            dims,
            grid,
            slot_of: PageTable::new(grid)?,
            values: Vec::new(),
            gradients: Vec::new(),
            uniform_bricks: 0,
            shared_slots: 0,
        };
        let mut shared: HashMap<(u16, u16), u32> = HashMap::new();
        let (mut v, mut g) = (vec![0u16; SLOT_TEXELS], vec![0u16; SLOT_TEXELS]);
        // Slot texel j along an axis holds voxel 8b + j, clamped to the volume (clamp-to-edge).
        let at = |b: u32, j: u32, d: u32| (b * BRICK + j).min(d - 1) as usize;
        for bz in 0..grid[2] {
            for by in 0..grid[1] {
                for bx in 0..grid[0] {
                    let xs: Vec<usize> = (0..SLOT).map(|i| at(bx, i, dims[0])).collect();
                    let mut t = 0;
                    for k in 0..SLOT {
                        for j in 0..SLOT {
                            let row = (at(bz, k, dims[2]) * dims[1] as usize + at(by, j, dims[1])) * dims[0] as usize;
                            for &x in &xs {
                                v[t] = values[row + x];
                                g[t] = gradients[row + x];
                                t += 1;
                            }
                        }
                    }
                    let uniform = v.iter().all(|&x| x == v[0]) && g.iter().all(|&x| x == g[0]);
                    let slot = if uniform {
                        me.uniform_bricks += 1;
                        match shared.get(&(v[0], g[0])) {
                            Some(&s) => s,
                            None => {
                                let s = me.push_slot(&v, &g);
                                shared.insert((v[0], g[0]), s);
                                me.shared_slots += 1;
                                s
                            }
                        }
                    } else {
                        me.push_slot(&v, &g)
                    };
                    me.slot_of.set([bx, by, bz], slot)?;
                }
            }
        }
        Ok(me)
    }

    pub(super) fn push_slot(&mut self, v: &[u16], g: &[u16]) -> u32 {
        let s = self.slots();
        self.values.extend_from_slice(v);
        self.gradients.extend_from_slice(g);
        s
    }

    /// Number of slots (stored bricks and shared uniform slots).
    pub fn slots(&self) -> u32 {
        (self.values.len() / SLOT_TEXELS) as u32
    }

    /// Bricks in the page table.
    pub fn brick_count(&self) -> u64 {
        self.slot_of.len()
    }

    /// Checks what the renderer trusts: sizes that agree with `dims` and every brick pointing
    /// at a slot that exists. The error names the first problem.
    pub fn validate(&self) -> Result<(), String> {
        let grid = self.dims.map(|d| d.div_ceil(BRICK));
        let n = grid.iter().map(|&g| g as u64).product::<u64>();
        if self.dims.contains(&0) || grid != self.grid {
            return Err(format!("brick grid {:?} does not match volume dims {:?}", self.grid, self.dims));
        }
        if self.slot_of.grid() != grid || self.slot_of.len() != n {
            return Err(format!("page table of {:?} bricks for {grid:?}", self.slot_of.grid()));
        }
        if !self.values.len().is_multiple_of(SLOT_TEXELS) || self.gradients.len() != self.values.len() {
            return Err(format!(
                "brick data truncated: {} values and {} gradients, not whole {SLOT}³ slots of both",
                self.values.len(),
                self.gradients.len()
            ));
        }
        let slots = self.slots();
        // Page by page (a uniform page once); only a bad table is walked brick by brick, to
        // name its first bad brick.
        let mut any_bad = false;
        self.slot_of.for_each_page(|_, _, _, page, own| {
            any_bad |= match (page, own) {
                (_, Some(own)) => own.iter().any(|&s| s >= slots),
                (crate::volume::data::bricks::page_table::Page::Uniform(s), None) => s >= slots,
                _ => slots == 0,
            };
        });
        if !any_bad {
            return Ok(());
        }
        let mut bad = None;
        self.slot_of.for_each_brick(|b, s| {
            if s >= slots && bad.is_none_or(|(c, _): ([u32; 3], u32)| [c[2], c[1], c[0]] > [b[2], b[1], b[0]]) {
                bad = Some((b, s));
            }
        });
        match bad {
            Some((b, s)) => Err(format!(
                "page table entry of brick ({}, {}, {}) points to slot {s}, past the {slots} stored",
                b[0], b[1], b[2]
            )),
            None => Ok(()),
        }
    }
}

/// Slots per atlas axis for `slots` slots, at most `per_axis` along each: the arrangement with
/// the fewest slots (the least memory), `None` when none holds them.
pub fn atlas_slots(slots: u32, per_axis: u32) -> Option<[u32; 3]> {
    let cap = per_axis.clamp(1, MAX_SLOTS_PER_AXIS);
    let n = u64::from(slots.max(1));
    let mut best: Option<[u32; 3]> = None;
    let size = |a: [u32; 3]| a.iter().map(|&c| u64::from(c)).product::<u64>();
    for z in 1..=cap {
        for y in 1..=cap {
            let x = n.div_ceil(u64::from(y) * u64::from(z));
            if x <= u64::from(cap) && best.is_none_or(|b| size([x as u32, y, z]) < size(b)) {
                best = Some([x as u32, y, z]);
            }
            if x == 1 {
                break;
            }
        }
    }
    best
}

/// `auto` keeps volumes whose dense image is at most this many bytes dense, occupied or not:
/// the memory a sparse layout could save there matters less than its page-table lookups.
pub const AUTO_DENSE_BYTES: u64 = 256 << 20;

/// `auto` stores larger volumes sparse when fewer than this fraction of their bricks vary.
pub const AUTO_OCCUPIED: f64 = 0.25;

/// Most atlases one volume's slots may fill (`volume/common.glsl`'s `ATLASES`: the first at the
/// volume's binding, the others at fixed ones).
pub const MAX_ATLASES: u32 = 4;

/// How a volume's slots fill its atlases: `count` atlases of `slots` slots per axis, numbered on
/// along z from one atlas into the next (atlas k holds slot layers [k·slots.z, (k+1)·slots.z)), so
/// a page-table word needs no atlas field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasPlan {
    /// Slots per axis of each atlas.
    pub slots: [u32; 3],
    /// Atlases.
    pub count: u32,
}

impl AtlasPlan {
    /// Slots each atlas holds.
    pub fn per_atlas(&self) -> u32 {
        self.slots.iter().product()
    }
}

/// The plan for `slots` slots with at most `per_axis` slots along each atlas axis and at most
/// `max_slots` slots in one atlas (its allocation): one atlas where they fit, else the fewest
/// atlases (up to [`MAX_ATLASES`]) of equal size; `None` when none holds them.
pub fn atlas_plan(slots: u32, per_axis: u32, max_slots: u64) -> Option<AtlasPlan> {
    (1..=MAX_ATLASES).find_map(|count| {
        let a = atlas_slots(slots.div_ceil(count), per_axis)?;
        let plan = AtlasPlan { slots: a, count: slots.max(1).div_ceil(a.iter().product()) };
        let layers_fit = u64::from(plan.count) * u64::from(a[2]) <= u64::from(MAX_SLOTS_PER_AXIS);
        (u64::from(plan.per_atlas()) <= max_slots && layers_fit).then_some(plan)
    })
}

/// The page-table word of slot `s` in an atlas of `a` slots per axis (`volume/common.glsl`).
pub fn page_entry(s: u32, a: [u32; 3]) -> u32 {
    (s % a[0]) | ((s / a[0]) % a[1]) << 10 | (s / (a[0] * a[1])) << 20
}

/// Slot contents (`SLOT_TEXELS` per slot) arranged as an atlas image of `a` slots per axis.
pub fn arrange(data: &[u16], a: [u32; 3]) -> Vec<u16> {
    let [w, h] = [a[0] * SLOT, a[1] * SLOT].map(|d| d as usize);
    let mut out = vec![0u16; w * h * (a[2] * SLOT) as usize];
    let s = SLOT as usize;
    for (i, slot) in data.chunks_exact(SLOT_TEXELS).enumerate() {
        let i = i as u32;
        let o = [i % a[0], (i / a[0]) % a[1], i / (a[0] * a[1])].map(|c| (c * SLOT) as usize);
        for (r, row) in slot.chunks_exact(s).enumerate() {
            let (y, z) = (o[1] + r % s, o[2] + r / s);
            let at = (z * h + y) * w + o[0];
            out[at..at + s].copy_from_slice(row);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_past_one_allocation_fill_atlases_numbered_on_along_z() {
        // One atlas when it fits; else the fewest equal atlases under the allocation.
        assert_eq!(atlas_plan(100, 50, 1000), Some(AtlasPlan { slots: [50, 2, 1], count: 1 }));
        let p = atlas_plan(1000, 50, 300).expect("plan");
        assert!(p.count >= 4 && u64::from(p.per_atlas()) <= 300 && p.count * p.per_atlas() >= 1000, "{p:?}");
        assert_eq!(atlas_plan(1000, 50, 200), None, "five atlases are past MAX_ATLASES");
        // Slot s of atlas k: its word's z is k·slots.z plus its layer within the atlas.
        let p = AtlasPlan { slots: [3, 2, 2], count: 3 };
        let s = 2 * 12 + 7; // atlas 2, slot 7: x 1, y 0, layer 1
        assert_eq!(page_entry(s, p.slots), 1 | (2 * 2 + 1) << 20);
        let data: Vec<u16> = (0..32 * SLOT_TEXELS).map(|t| (t / SLOT_TEXELS) as u16).collect();
        let atlases: Vec<Vec<u16>> =
            data.chunks(p.per_atlas() as usize * SLOT_TEXELS).map(|c| arrange(c, p.slots)).collect();
        assert_eq!(atlases.len(), 3);
        let w = (3 * SLOT) as usize;
        let h = (2 * SLOT) as usize;
        // Slot 7 of atlas 2 starts at texel (9, 0, 9) of that atlas.
        assert_eq!(atlases[2][(9 * h) * w + 9], s as u16);
    }

    #[test]
    fn slots_hold_the_clamped_voxels_and_uniform_bricks_share_a_slot() {
        let dims = [20, 9, 17];
        let n = 20 * 9 * 17;
        // Zero except a ramp in one corner: most bricks uniform.
        let v: Vec<u16> = (0..n).map(|i| if i % 20 < 5 && i / 180 < 6 { (i * 37 % 65536) as u16 } else { 0 }).collect();
        let g = crate::volume::data::stats::gradient_magnitudes(&v, dims);
        let b = Bricks::build(&v, &g, dims).expect("bricks");
        assert!(b.uniform_bricks > 0 && b.shared_slots >= 1);
        assert!(b.validate().is_ok());
        // Each brick's slot holds exactly the clamped voxels around it.
        b.slot_of.for_each_brick(|bb, s| {
            let slot = &b.values[s as usize * SLOT_TEXELS..][..SLOT_TEXELS];
            for (t, &val) in slot.iter().enumerate() {
                let j = [t % 9, t / 9 % 9, t / 81].map(|c| c as u32);
                let p: Vec<usize> = (0..3).map(|a| (bb[a] * 8 + j[a]).min(dims[a] - 1) as usize).collect();
                assert_eq!(val, v[(p[2] * 9 + p[1]) * 20 + p[0]], "brick {bb:?} texel {j:?}");
            }
        });
    }

    #[test]
    fn atlas_arrangement_places_each_slot_at_its_page_entry() {
        let slots = 7u32;
        let data: Vec<u16> = (0..slots as usize * SLOT_TEXELS).map(|i| (i / SLOT_TEXELS) as u16).collect();
        // 7 slots, at most 2 per axis: 2 × 2 × 2 is the only arrangement.
        let a = atlas_slots(slots, 2).expect("fits");
        assert_eq!(a, [2, 2, 2]);
        assert_eq!(atlas_slots(5, 7), Some([5, 1, 1]));
        assert_eq!(atlas_slots(9, 3).map(|a| a.iter().product::<u32>()), Some(9));
        let atlas = arrange(&data, a);
        for s in 0..slots {
            let e = page_entry(s, a);
            let o = [e & 1023, (e >> 10) & 1023, e >> 20].map(|c| (c * SLOT) as usize);
            let (w, h) = (18, 18);
            assert_eq!(atlas[((o[2] + 8) * h + o[1] + 8) * w + o[0] + 8], s as u16);
            assert_eq!(atlas[(o[2] * h + o[1]) * w + o[0]], s as u16);
        }
        assert_eq!(atlas_slots(9, 2), None);
    }

    #[test]
    fn validate_names_a_page_entry_past_the_atlas_and_truncated_data() {
        let dims = [16, 8, 8];
        let v: Vec<u16> = (0..16 * 64).map(|i| i as u16 * 50).collect();
        let g = crate::volume::data::stats::gradient_magnitudes(&v, dims);
        let mut b = Bricks::build(&v, &g, dims).expect("bricks");
        let mut bad = b.clone();
        bad.slot_of.set([1, 0, 0], 99).expect("set");
        let e = bad.validate().expect_err("corrupt page table");
        assert!(e.contains("brick (1, 0, 0) points to slot 99"), "{e}");
        b.values.truncate(b.values.len() - 3);
        let e = b.validate().expect_err("truncated");
        assert!(e.contains("truncated"), "{e}");
    }
}
