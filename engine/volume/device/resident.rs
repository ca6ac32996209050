//! View-dependent residency on the device: one atlas of fixed size holding the bricks of a cut
//! through the pyramid (`data::bricks::residency`), of any level, and a flat page table whose
//! word for each level-0 brick names the slot of the brick it shows and that brick's level
//! (`volume/common.glsl`'s LOD_WORDS). Each frame only the bricks that arrived and the page words
//! that changed are written ([`ResidentAtlas::apply`], [`DevicePages::mark`]); evicted bricks'
//! slots are reused. Uniform bricks of every level share slots uploaded once.

use super::layout::{device_budget, upload_ro, LayoutReport, VolumeImages, VolumeLayout};
use super::page_images::DevicePages;
use crate::error::{Error, Result};
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::data::bricks::levels::{cut_ranges, Levels};
use crate::volume::data::bricks::page_table::PageTable;
use crate::volume::data::bricks::residency::{FrameUpload, Node, Streamer, BRICK_BYTES};
use crate::volume::data::bricks::{self, atlas_slots, SLOT, SLOT_TEXELS};
use crate::volume::data::stats::{gradient_magnitudes, histogram};
use crate::volume::data::Volume;
use std::collections::{HashMap, HashSet};

/// Most slots along one atlas axis a residency word can name (9 bits, `volume/common.glsl`).
pub const LOD_SLOTS_PER_AXIS: u32 = 511;

/// The residency page word of slot `s` in an atlas of `a` slots per axis showing a level-`level`
/// brick (`volume/common.glsl`'s `word_slot_index` and `word_level` with LOD_WORDS).
pub fn lod_entry(s: u32, a: [u32; 3], level: u32) -> u32 {
    (s % a[0]) | ((s / a[0]) % a[1]) << 9 | (s / (a[0] * a[1])) << 18 | level << 27
}

/// The device atlas of a residency cut and the slots its bricks occupy.
pub struct ResidentAtlas {
    /// Slots per axis.
    slots: [u32; 3],
    /// Slots not in use, taken from the end.
    free: Vec<u32>,
    /// Own slots of the resident bricks that vary.
    own: HashMap<Node, u32>,
    /// Per level, per slot of its bricks: the shared device slot when the slot is uniform.
    shared: Vec<Vec<Option<u32>>>,
}

/// Whether slot `s` of `b` holds one value and one gradient throughout.
fn uniform_slot(b: &bricks::Bricks, s: usize) -> Option<(u16, u16)> {
    let v = &b.values[s * SLOT_TEXELS..][..SLOT_TEXELS];
    let g = &b.gradients[s * SLOT_TEXELS..][..SLOT_TEXELS];
    (v.iter().all(|&x| x == v[0]) && g.iter().all(|&x| x == g[0])).then_some((v[0], g[0]))
}

const USAGE: vk::ImageUsageFlags =
    vk::ImageUsageFlags::from_raw(vk::ImageUsageFlags::SAMPLED.as_raw() | vk::ImageUsageFlags::TRANSFER_DST.as_raw());

impl ResidentAtlas {
    /// An atlas for the shared uniform slots of every level and `budget` bytes of own slots (as
    /// [`Streamer`] counts them) besides the coarsest brick; the shared slots uploaded, the rest
    /// empty until [`Self::apply`]; with the value and gradient atlases it fills (the renderer
    /// binds them). Refused with the numbers past one allocation.
    pub fn new(ctx: &Context, levels: &Levels, budget: u64) -> Result<(Self, Image, Image)> {
        let (mut sv, mut sg) = (Vec::new(), Vec::new());
        let mut by_value: HashMap<(u16, u16), u32> = HashMap::new();
        let mut shared = Vec::with_capacity(levels.bricks.len());
        for b in &levels.bricks {
            let mut per = Vec::with_capacity(b.slots() as usize);
            for s in 0..b.slots() as usize {
                per.push(uniform_slot(b, s).map(|(v, g)| {
                    *by_value.entry((v, g)).or_insert_with(|| {
                        sv.extend(std::iter::repeat_n(v, SLOT_TEXELS));
                        sg.extend(std::iter::repeat_n(g, SLOT_TEXELS));
                        (sv.len() / SLOT_TEXELS - 1) as u32
                    })
                }));
            }
            shared.push(per);
        }
        let n_shared = by_value.len() as u32;
        let own = u32::try_from(budget / BRICK_BYTES + 1)
            .map_err(|_| Error::Input(format!("gpu_memory: {budget} bytes are past what residency addresses")))?;
        let total = n_shared.saturating_add(own);
        let per_axis = (ctx.info.limits.max_image_dimension3_d / SLOT).min(LOD_SLOTS_PER_AXIS);
        let max_alloc = device_budget(ctx).max_allocation;
        let too_many = || {
            Error::Input(format!(
                "gpu_memory: {budget} bytes of bricks need {total} slots, past one atlas of at most {per_axis}³ slots and {max_alloc} bytes on this device"
            ))
        };
        let slots = atlas_slots(total, per_axis).ok_or_else(too_many)?;
        let extent = slots.map(|s| s * SLOT);
        if extent.iter().map(|&e| u64::from(e)).product::<u64>() * 2 > max_alloc {
            return Err(too_many());
        }
        let capacity: u32 = slots.iter().product();
        sv.resize(capacity as usize * SLOT_TEXELS, 0);
        sg.resize(capacity as usize * SLOT_TEXELS, 0);
        let values = Image::new(ctx, "volume atlas (resident)", ImageInfo::d3(vk::Format::R16_UNORM, extent, USAGE))?;
        let gradients =
            Image::new(ctx, "gradient atlas (resident)", ImageInfo::d3(vk::Format::R16_UNORM, extent, USAGE))?;
        upload_ro(ctx, &values, bytemuck::cast_slice(&bricks::arrange(&sv, slots)))?;
        upload_ro(ctx, &gradients, bytemuck::cast_slice(&bricks::arrange(&sg, slots)))?;
        let me = Self { slots, free: (n_shared..capacity).rev().collect(), own: HashMap::new(), shared };
        Ok((me, values, gradients))
    }

    /// Makes the atlas hold `streamer`'s resident bricks: evicted ones free their slots, arrived
    /// ones are written into free slots (only those) of `atlases` (values, gradients: the images
    /// [`Self::new`] made). Returns every level-0 brick's page word (without occupancy bits) for
    /// the level it shows, and the bytes of bricks written.
    pub fn apply(
        &mut self,
        ctx: &Context,
        levels: &Levels,
        streamer: &Streamer,
        atlases: (&Image, &Image),
    ) -> Result<(PageTable, u64)> {
        let resident: HashSet<Node> = streamer.resident().copied().collect();
        let free = &mut self.free;
        self.own.retain(|n, s| {
            let keep = resident.contains(n);
            if !keep {
                free.push(*s);
            }
            keep
        });
        let host_slot = |n: Node| levels.bricks[n.level as usize].slot_of.get(n.brick) as usize;
        let (mut boxes, mut v, mut g) = (Vec::new(), Vec::new(), Vec::new());
        let mut arrived: Vec<Node> = resident.iter().filter(|n| !self.own.contains_key(n)).copied().collect();
        arrived.sort();
        for n in arrived {
            let hs = host_slot(n);
            if self.shared[n.level as usize][hs].is_some() {
                continue;
            }
            let s = self.free.pop().ok_or_else(|| {
                Error::Input(format!(
                    "residency: the atlas's {} slots are all in use",
                    self.slots.iter().product::<u32>()
                ))
            })?;
            self.own.insert(n, s);
            let a = self.slots;
            let o = [s % a[0], s / a[0] % a[1], s / (a[0] * a[1])].map(|c| c * SLOT);
            boxes.push((o, [SLOT; 3]));
            let b = &levels.bricks[n.level as usize];
            v.extend_from_slice(&b.values[hs * SLOT_TEXELS..][..SLOT_TEXELS]);
            g.extend_from_slice(&b.gradients[hs * SLOT_TEXELS..][..SLOT_TEXELS]);
        }
        let (layout, stage, access) = (
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_SAMPLED_READ,
        );
        ctx.update_image(atlases.0, &boxes, bytemuck::cast_slice(&v), layout, stage, access)?;
        ctx.update_image(atlases.1, &boxes, bytemuck::cast_slice(&g), layout, stage, access)?;
        let p = &levels.pyramid;
        let mut words = PageTable::new(p.grid(0)).map_err(Error::Input)?;
        let g0 = p.grid(0);
        for z in 0..g0[2] {
            for y in 0..g0[1] {
                for x in 0..g0[0] {
                    let b = [x, y, z];
                    let level = streamer.level_of(p, b);
                    let n = Node { level, brick: b.map(|c| c >> level) };
                    let slot = match self.shared[level as usize][host_slot(n)] {
                        Some(s) => s,
                        None => *self
                            .own
                            .get(&n)
                            .ok_or_else(|| Error::Input(format!("residency: brick {n:?} shown but not resident")))?,
                    };
                    words.set(b, lod_entry(slot, self.slots, level)).map_err(Error::Input)?;
                }
            }
        }
        Ok((words, 2 * 2 * v.len() as u64))
    }
}

/// A volume kept resident by the view: its levels, the streamer moving the device between cuts,
/// the atlas, and what the last frame did.
pub struct Residency {
    /// Every level's bricks on the host.
    pub levels: Levels,
    /// Which bricks are on the device and which level each region shows.
    pub streamer: Streamer,
    /// The device atlas.
    pub atlas: ResidentAtlas,
    /// Bytes of own slots the cut may take.
    pub budget: u64,
    /// The last frame's uploads.
    pub last: FrameUpload,
}

/// What residency reports per frame.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ResidencyReport {
    /// The streamer's frame: bytes (bricks and page words as budgeted), bricks uploaded and
    /// evicted, pending, whether anything shown changed.
    pub upload: FrameUpload,
    /// Bytes actually written to the device this frame: brick slots (values and gradients) and
    /// page-table words.
    pub written_bytes: u64,
    /// Level-0 bricks showing each level, finest first.
    pub shown_levels: Vec<u64>,
    /// Resident bricks of each level, finest first.
    pub resident_levels: Vec<u64>,
}

impl Residency {
    /// `volume` resident within `budget` bytes of own slots, `upload_budget` bytes per frame:
    /// the coarsest brick on the device, the images the renderer binds. The occupancy/majorant
    /// grid must have a cell per brick (its cells bound what each brick shows).
    pub(crate) fn new(ctx: &Context, volume: &Volume, budget: u64, upload_budget: u64) -> Result<(Self, VolumeImages)> {
        let input = |e: String| Error::Input(format!("{}: {e}", volume.source));
        let dims = volume.dims;
        let grid = dims.map(|d| d.div_ceil(bricks::BRICK));
        if crate::volume::data::bricks::cells::bricks_per_cell(grid) != 1 {
            return Err(input(format!(
                "residency keeps one occupancy cell per brick; {}x{}x{} bricks are too many",
                grid[0], grid[1], grid[2]
            )));
        }
        if volume.bricks.is_some() || volume.sparse.is_some() {
            return Err(input(
                "view-dependent residency needs the volume whole on the host, not loaded into bricks".into(),
            ));
        }
        let normalized = volume.normalized_u16();
        let levels = Levels::build(&normalized, dims).map_err(input)?;
        // No more room than every level's bricks take.
        let all: u64 = (0..=levels.top()).map(|k| levels.pyramid.level_bytes(k)).sum();
        let budget = budget.min(all);
        let streamer = Streamer::new(&levels.pyramid, budget, upload_budget).map_err(input)?;
        let (mut atlas, values, gradients) = ResidentAtlas::new(ctx, &levels, budget)?;
        let (words, _) = atlas.apply(ctx, &levels, &streamer, (&values, &gradients))?;
        let pages = DevicePages::flat_partial(ctx, words).map_err(|e| match e {
            Error::Input(m) => input(m),
            other => other,
        })?;
        let grad = gradient_magnitudes(&normalized, dims);
        let max_gradient = grad.iter().copied().max().unwrap_or(0) as f32 / 65535.0;
        let histogram = histogram(&normalized, &grad, max_gradient);
        let block_ranges = cut_ranges(&levels, &streamer);
        let b0 = &levels.bricks[0];
        let report = LayoutReport {
            layout: VolumeLayout::Sparse,
            dense_bytes: 2 * crate::volume::data::image_bytes(dims),
            bricks: b0.brick_count(),
            stored_bricks: b0.brick_count() - b0.uniform_bricks,
            shared_slots: u64::from(b0.shared_slots),
            skipped_fraction: b0.uniform_bricks as f64 / b0.brick_count().max(1) as f64,
            gpu_bytes: values.memory_bytes() + gradients.memory_bytes() + pages.bytes(),
            page_levels: 1,
            page_bytes: pages.bytes(),
            grid_bytes: 0,
            grid_cell: bricks::BRICK,
            image_texels: values.info.extent,
            atlases: 1,
        };
        let images = VolumeImages {
            volume: values,
            gradients,
            more_atlases: Vec::new(),
            pages,
            block_ranges,
            cell_bricks: 1,
            histogram,
            max_gradient,
            report,
        };
        let me = Self { levels, streamer, atlas, budget, last: FrameUpload::default() };
        Ok((me, images))
    }
}
