//! How a volume is stored on the device (`volume_layout`): one dense image per quantity (the
//! normalized values and their gradient magnitudes), or bricks in atlases behind a page table
//! ([`crate::volume::data::bricks`]); chosen per volume, and what the choice stores, for reports.

use super::page_images::{self, DevicePages};
use crate::error::{Error, Result};
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::volume::data::bricks::builder;
use crate::volume::data::bricks::cells;
use crate::volume::data::bricks::page_table::{PageTable, PAGE};
use crate::volume::data::bricks::{self, Bricks, AUTO_DENSE_BYTES, AUTO_OCCUPIED, MAX_ATLASES, SLOT};
use crate::volume::data::stats::BLOCK;
use crate::volume::data::stats::{block_ranges, gradient_magnitudes, histogram};
use crate::volume::data::{DeviceBudget, Volume};

/// Where a volume's voxels live on the device.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum VolumeLayout {
    /// Dense where the volume fits the device's 3D-image limit and one allocation and is small
    /// or mostly occupied; sparse otherwise.
    #[default]
    Auto,
    /// One image per quantity, as large as the volume.
    Dense,
    /// 8³ bricks with an apron in an atlas, uniform ones shared, behind a page table.
    Sparse,
}

impl VolumeLayout {
    /// Names `volume_layout` accepts.
    pub const NAMES: &'static [&'static str] = &["auto", "dense", "sparse"];

    /// The setting's name.
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// Parses a name of [`Self::NAMES`].
    pub fn parse(n: &str) -> std::result::Result<Self, String> {
        match n {
            "auto" => Ok(Self::Auto),
            "dense" => Ok(Self::Dense),
            "sparse" => Ok(Self::Sparse),
            _ => Err(format!("expected one of {}", Self::NAMES.join(", "))),
        }
    }
}

/// What a volume's layout stores on the device.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LayoutReport {
    /// The layout chosen.
    pub layout: VolumeLayout,
    /// The dense layout's bytes (volume and gradient images), whichever was chosen.
    pub dense_bytes: u64,
    /// 8³ bricks covering the volume.
    pub bricks: u64,
    /// Bricks stored in slots of their own (all of them in the dense layout).
    pub stored_bricks: u64,
    /// Slots shared by uniform bricks (one per distinct value and gradient).
    pub shared_slots: u64,
    /// Fraction of bricks without a slot of their own.
    pub skipped_fraction: f64,
    /// Bytes of device memory the volume's images were given (volume, gradients, page table).
    pub gpu_bytes: u64,
    /// Bytes of device memory the occupancy and majorant grids were given.
    pub grid_bytes: u64,
    /// Voxels per occupancy/majorant grid cell edge (8: one cell per brick; more for large
    /// boxes, `cells::bricks_per_cell`).
    pub grid_cell: u32,
    /// Texels of the value image along x, y, z: each atlas (sparse) or the volume (dense).
    pub image_texels: [u32; 3],
    /// Images per quantity: atlases (sparse; more than one past the largest allocation), or 1.
    pub atlases: u32,
    /// Page-table levels (sparse: 1 flat, 2 directory and pool, `page_images`); 0 when dense.
    pub page_levels: u32,
    /// Bytes of device memory the page table was given (in `gpu_bytes`).
    pub page_bytes: u64,
}

/// The device memory a volume may take on `ctx`'s device: its largest device-local heap, and
/// the most one allocation may hold.
pub fn device_budget(ctx: &Context) -> DeviceBudget {
    // SAFETY: the physical device belongs to this live instance; the call only reads properties.
    let mem = unsafe { ctx.instance.get_physical_device_memory_properties(ctx.physical_device) };
    let heaps = &mem.memory_heaps[..(mem.memory_heap_count as usize).min(mem.memory_heaps.len())];
    let heap_bytes =
        heaps.iter().filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL)).map(|h| h.size).max().unwrap_or(0);
    let mut m3 = vk::PhysicalDeviceMaintenance3Properties::default();
    let mut props = vk::PhysicalDeviceProperties2::default().push_next(&mut m3);
    // SAFETY: as above; `props` chains one properties struct that lives through the call.
    unsafe { ctx.instance.get_physical_device_properties2(ctx.physical_device, &mut props) };
    let max_allocation = m3.max_memory_allocation_size.min(ctx.info.max_allocation_cap.unwrap_or(u64::MAX));
    DeviceBudget { heap_bytes, max_allocation }
}

/// A volume's images on the device and what the renderer derives from its voxels.
pub(crate) struct VolumeImages {
    /// Values: the dense image or the value atlas.
    pub volume: Image,
    /// Gradient magnitudes: dense or the gradient atlas (same slots as the values').
    pub gradients: Image,
    /// Value and gradient atlases 1, 2, … past the first (sparse, past one allocation).
    pub more_atlases: Vec<(Image, Image)>,
    /// The page table (sparse), or 1³ placeholders the dense shaders never read.
    pub pages: DevicePages,
    /// Per grid cell (`cell_bricks`³ bricks), [min, max] over its bricks and their one-voxel aprons.
    pub block_ranges: Vec<[f32; 2]>,
    /// Bricks per grid cell edge.
    pub cell_bricks: u32,
    /// Value × gradient histogram (`VolumeRenderer::histogram`).
    pub histogram: Vec<u32>,
    /// Largest gradient magnitude.
    pub max_gradient: f32,
    /// What was stored.
    pub report: LayoutReport,
}

const USAGE: vk::ImageUsageFlags =
    vk::ImageUsageFlags::from_raw(vk::ImageUsageFlags::SAMPLED.as_raw() | vk::ImageUsageFlags::TRANSFER_DST.as_raw());

/// Uploads `bytes` into `img`, left for the compute passes to sample.
pub(crate) fn upload_ro(ctx: &Context, img: &Image, bytes: &[u8]) -> Result<()> {
    ctx.upload_image(
        img,
        bytes,
        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        vk::PipelineStageFlags2::COMPUTE_SHADER,
        vk::AccessFlags2::SHADER_SAMPLED_READ,
    )
}

fn image_u16(ctx: &Context, name: &str, dims: [u32; 3], data: &[u16]) -> Result<Image> {
    let img = Image::new(ctx, name, ImageInfo::d3(vk::Format::R16_UNORM, dims, USAGE))?;
    upload_ro(ctx, &img, bytemuck::cast_slice(data))?;
    Ok(img)
}

/// A sparse volume's images on the device.
pub struct SparseImages {
    /// The (first) value atlas.
    pub values: Image,
    /// The (first) gradient atlas (same slots).
    pub gradients: Image,
    /// Value and gradient atlases 1, 2, … of a volume whose slots exceed one allocation.
    pub more_atlases: Vec<(Image, Image)>,
    /// The page-table words of every brick (slots as atlas positions, no occupancy bit).
    pub entries: PageTable,
}

impl VolumeImages {
    /// Uploads `volume` in `layout` (`Auto` resolved here).
    pub fn new(ctx: &Context, volume: &Volume, layout: VolumeLayout) -> Result<Self> {
        let dims = volume.dims;
        let max3d = ctx.info.limits.max_image_dimension3_d;
        let budget = device_budget(ctx);
        let dense_image = crate::volume::data::image_bytes(dims);
        let fits = dims.iter().all(|&d| d <= max3d) && dense_image <= budget.max_allocation;
        if !sparse_possible(layout, fits) && dims.iter().any(|&d| d > max3d) {
            return Err(Error::Input(format!(
                "{}: {}x{}x{} exceeds this device's 3D texture limit {max3d} (volume_layout=sparse stores it in bricks)",
                volume.source, dims[0], dims[1], dims[2]
            )));
        }
        if !sparse_possible(layout, fits) && dense_image > budget.max_allocation {
            return Err(Error::Input(format!(
                "{}: {}x{}x{} needs {dense_image} bytes per dense image, past this device's largest allocation ({} bytes; volume_layout=sparse stores it in bricks)",
                volume.source, dims[0], dims[1], dims[2], budget.max_allocation
            )));
        }
        let grid = dims.map(|d| d.div_ceil(BLOCK));
        // A sparse grid is bricked leaf by leaf, a streamed load came in bricks; `auto` keeps
        // either dense where the dense volume would be kept dense.
        let built = match (volume.bricks.as_deref(), volume.sparse.as_deref()) {
            _ if layout == VolumeLayout::Dense => None,
            (Some(b), _) => Some(std::borrow::Cow::Borrowed(b)),
            (None, Some(g)) if layout == VolumeLayout::Sparse || !fits || dense_image > AUTO_DENSE_BYTES => {
                Some(std::borrow::Cow::Owned(
                    builder::build(g).map_err(|e| Error::Input(format!("{}: {e}", volume.source)))?,
                ))
            }
            _ => None,
        };
        if let Some(b) = built {
            let dense_enough = b.occupied_bricks as f64 >= AUTO_OCCUPIED * b.bricks.brick_count() as f64;
            if layout == VolumeLayout::Sparse || !fits || (dense_image > AUTO_DENSE_BYTES && !dense_enough) {
                return Self::sparse(ctx, &volume.source, &b, dense_image);
            }
        }
        let normalized = volume.normalized_u16();
        // Per brick: what `auto` weighs, and (merged into cells) the occupancy and majorants.
        let per_brick = block_ranges(&normalized, dims, grid);
        let occupied_bricks = per_brick.iter().filter(|[lo, hi]| lo < hi).count() as u64;
        let (k, bricks_total) = (cells::bricks_per_cell(grid), per_brick.len() as u64);
        let sparse = match layout {
            VolumeLayout::Dense => false,
            VolumeLayout::Sparse => true,
            VolumeLayout::Auto if !fits => true,
            VolumeLayout::Auto if dense_image <= AUTO_DENSE_BYTES => false,
            VolumeLayout::Auto => (occupied_bricks as f64) < AUTO_OCCUPIED * bricks_total as f64,
        };
        let block_ranges = cells::coarsen(&per_brick, grid, k);
        let grad = gradient_magnitudes(&normalized, dims);
        let max_gradient = grad.iter().copied().max().unwrap_or(0) as f32 / 65535.0;
        let histogram = histogram(&normalized, &grad, max_gradient);
        if sparse {
            let b =
                Bricks::build(&normalized, &grad, dims).map_err(|e| Error::Input(format!("{}: {e}", volume.source)))?;
            drop(grad);
            let b = builder::SparseBuild {
                bricks: b,
                block_ranges,
                cell_bricks: k,
                occupied_bricks,
                histogram,
                max_gradient,
            };
            return Self::sparse(ctx, &volume.source, &b, dense_image);
        }
        let volume_img = image_u16(ctx, "volume", dims, &normalized)?;
        let gradients = image_u16(ctx, "gradient magnitude", dims, &grad)?;
        let pages = DevicePages::placeholder(ctx)?;
        let more_atlases = Vec::new();
        let report = LayoutReport {
            layout: VolumeLayout::Dense,
            dense_bytes: 2 * dense_image,
            bricks: bricks_total,
            stored_bricks: bricks_total,
            shared_slots: 0,
            skipped_fraction: 0.0,
            gpu_bytes: volume_img.memory_bytes() + gradients.memory_bytes(),
            page_levels: 0,
            page_bytes: 0,
            grid_bytes: 0,
            grid_cell: BLOCK,
            image_texels: dims,
            atlases: 1,
        };
        Ok(Self {
            volume: volume_img,
            gradients,
            more_atlases,
            pages,
            block_ranges,
            cell_bricks: k,
            histogram,
            max_gradient,
            report,
        })
    }
}

/// Whether `layout` may store a volume sparse (`fits`: whether it fits densely).
fn sparse_possible(layout: VolumeLayout, fits: bool) -> bool {
    layout == VolumeLayout::Sparse || (layout == VolumeLayout::Auto && !fits)
}

impl VolumeImages {
    /// Uploads bricks with what the renderer derived from them (`dense_image`: bytes of one
    /// dense image, for the report).
    fn sparse(ctx: &Context, source: &str, built: &builder::SparseBuild, dense_image: u64) -> Result<Self> {
        let b = &built.bricks;
        let SparseImages { values: volume, gradients, more_atlases, entries } = upload_bricks(ctx, b, source)?;
        let pages = DevicePages::new(ctx, entries, &built.block_ranges, built.cell_bricks).map_err(|e| match e {
            Error::Input(m) => Error::Input(format!("{source}: {m}")),
            other => other,
        })?;
        let more_bytes: u64 = more_atlases.iter().map(|(v, g)| v.memory_bytes() + g.memory_bytes()).sum();
        let report = LayoutReport {
            layout: VolumeLayout::Sparse,
            dense_bytes: 2 * dense_image,
            bricks: b.brick_count(),
            stored_bricks: b.brick_count() - b.uniform_bricks,
            shared_slots: u64::from(b.shared_slots),
            skipped_fraction: b.uniform_bricks as f64 / b.brick_count().max(1) as f64,
            gpu_bytes: volume.memory_bytes() + gradients.memory_bytes() + pages.bytes() + more_bytes,
            page_levels: pages.levels,
            page_bytes: pages.bytes(),
            grid_bytes: 0,
            grid_cell: BLOCK * built.cell_bricks,
            image_texels: volume.info.extent,
            atlases: 1 + more_atlases.len() as u32,
        };
        Ok(Self {
            volume,
            gradients,
            more_atlases,
            pages,
            block_ranges: built.block_ranges.clone(),
            cell_bricks: built.cell_bricks,
            histogram: built.histogram.clone(),
            max_gradient: built.max_gradient,
            report,
        })
    }
}

/// Uploads bricks as atlases and a page table, after checking them ([`Bricks::validate`]) and
/// that they fit the device; errors name `source`.
pub fn upload_bricks(ctx: &Context, b: &Bricks, source: &str) -> Result<SparseImages> {
    b.validate().map_err(|e| Error::Input(format!("{source}: {e}")))?;
    let max3d = ctx.info.limits.max_image_dimension3_d;
    let pages = b.grid.map(|g| g.div_ceil(PAGE));
    if pages.iter().any(|&p| p > max3d) {
        return Err(Error::Input(format!(
            "{source}: {}x{}x{} voxels need a page directory of {}x{}x{} pages of {PAGE}³ bricks, past this device's 3D texture limit {max3d}",
            b.dims[0], b.dims[1], b.dims[2], pages[0], pages[1], pages[2]
        )));
    }
    let per_axis = max3d / SLOT;
    let DeviceBudget { heap_bytes: heap, max_allocation: max_alloc } = device_budget(ctx);
    let (plan, atlas_bytes) = atlas_plan(ctx, b.slots(), per_axis, max_alloc).ok_or_else(|| {
        Error::Input(format!(
            "{source}: its {} brick slots ({} bytes per quantity) exceed {MAX_ATLASES} atlases of at most {per_axis}³ slots (this device's 3D texture limit {max3d}) and {max_alloc} bytes (its largest allocation)",
            b.slots(),
            u64::from(b.slots()) * bricks::SLOT_TEXELS as u64 * 2
        ))
    })?;
    let atlas = plan.slots.map(|s| s * SLOT);
    let table = page_images::planned_bytes(ctx, &b.slot_of);
    let needed = 2 * u64::from(plan.count) * atlas_bytes + table;
    if needed > heap {
        return Err(Error::Input(format!(
            "{source}: its {} brick slots ({} of {} bricks stored) need {needed} bytes of GPU memory but the device-local heap holds {heap} bytes; crop or downsample the volume",
            b.slots(),
            b.brick_count() - b.uniform_bricks,
            b.brick_count()
        )));
    }
    // One atlas arranged at a time: the host holds the slots and one atlas image, not a second
    // copy of every slot.
    let images = |name: &str, data: &[u16]| -> Result<Vec<Image>> {
        let chunk = plan.per_atlas() as usize * bricks::SLOT_TEXELS;
        (0..)
            .zip(data.chunks(chunk))
            .map(|(k, d)| image_u16(ctx, &format!("{name} {k}"), atlas, &bricks::arrange(d, plan.slots)))
            .collect()
    };
    let mut values = images("volume atlas", &b.values)?.into_iter();
    let mut gradients = images("gradient atlas", &b.gradients)?.into_iter();
    let (Some(first_values), Some(first_gradients)) = (values.next(), gradients.next()) else {
        return Err(Error::Input(format!("{source}: no brick slots")));
    };
    let entries = b.slot_of.map(|s| bricks::page_entry(s, plan.slots));
    Ok(SparseImages {
        values: first_values,
        gradients: first_gradients,
        more_atlases: values.zip(gradients).collect(),
        entries,
    })
}

/// [`bricks::atlas_plan`] for atlases whose padded size on this device (row and slice
/// alignment included) stays within `max_alloc`, with that size.
fn atlas_plan(ctx: &Context, slots: u32, per_axis: u32, max_alloc: u64) -> Option<(bricks::AtlasPlan, u64)> {
    let slot_bytes = bricks::SLOT_TEXELS as u64 * 2;
    let mut max_slots = max_alloc / slot_bytes;
    while max_slots > 0 {
        let plan = bricks::atlas_plan(slots, per_axis, max_slots)?;
        let bytes = padded_atlas_bytes(ctx, plan.slots.map(|s| s * SLOT));
        if bytes <= max_alloc {
            return Some((plan, bytes));
        }
        // Padding took it past the allocation: fewer slots per atlas, in proportion.
        let per = u64::from(plan.per_atlas());
        max_slots = (per * max_alloc / bytes).min(per - 1);
    }
    None
}

/// Bytes the device asks for an R16 3D image of `extent` texels, its padding included.
fn padded_atlas_bytes(ctx: &Context, extent: [u32; 3]) -> u64 {
    let info = ImageInfo::d3(vk::Format::R16_UNORM, extent, USAGE).create_info();
    let query = vk::DeviceImageMemoryRequirements::default().create_info(&info);
    let mut req = vk::MemoryRequirements2::default();
    // SAFETY: the device is live and `query` points at a create info that lives through the call.
    unsafe { ctx.device.get_device_image_memory_requirements(&query, &mut req) };
    req.memory_requirements.size
}
