//! Volume data on the host, the lowest layer of `volume`: the `Volume` type, loaders (raw + JSON
//! sidecar, MetaImage, NRRD, DICOM, NIfTI, OpenVDB), procedural volumes, sparse grids, the
//! host-side bricks and their builder (`bricks`), and the statistics the device layer uploads
//! (`stats`: gradients, histogram, block ranges). Imports nothing else from `volume`: a threshold
//! it shares with a higher layer (the auto layout's) lives here and is imported from here. Used by
//! every other layer, the demos and the Python module.
//!
//! Every loader decodes voxels to `f32` without normalizing them, then sanitizes:
//! - **NaN** voxels are replaced by the minimum finite value of the volume and a note (count and first
//!   coordinate) is pushed to [`Volume::warnings`]; a volume with no finite value at all is an error.
//! - **±Inf** voxels are an error ([`VolumeError::NonFinite`]): there is no sensible value range to map them to.
//! - **Negative** voxels are an error ([`VolumeError::Negative`]) unless [`LoadOptions::allow_negative`] is set,
//!   in which case they are simply mapped through the value range like any other value.
//! - Dims must be non-zero, at most [`LoadOptions::max_dimension`] per axis, and at most [`MAX_VOXELS`] in total
//!   unless the load streams into bricks (then only the stored bricks are bounded, by host and device memory);
//!   spacing must be finite and > 0.
//!
//! Sizes are checked exactly: fewer bytes than dims × type is [`VolumeError::Truncated`], more is
//! [`VolumeError::SizeMismatch`], so a wrong header never yields a silently wrong volume.

mod blosc;
mod bricked;
pub mod bricks;
mod budget;
mod dicom;
mod dicom_bricks;
mod dicom_guard;
mod error;
pub mod labels;
mod metaimage;
mod nifti;
mod nrrd;
mod orient;
pub mod procedural;
mod raw;
mod read;
mod sanitize;
pub mod sparse;
pub mod stats;
mod stream;
mod vdb;
pub(crate) use vdb::half_to_f32;
mod voxel;

use std::borrow::Cow;
use std::path::Path;

pub use bricked::IntoBricks;
pub(crate) use budget::check_fits;
pub use budget::{image_bytes, DeviceBudget};
pub use error::VolumeError;
use sanitize::{coord, sanitize};
pub(crate) use stream::dequantize;
pub use stream::Progress;
pub use voxel::{Endian, VoxelType};

/// Largest voxel count of a dense volume (2^31), which keeps byte sizes and GPU uploads within
/// reasonable limits; a load into bricks has none (its stored bricks are checked instead).
pub const MAX_VOXELS: u64 = 1 << 31;

/// A decoded scalar volume, x varying fastest in `data`.
#[derive(Debug, Clone, PartialEq)]
pub struct Volume {
    /// Size in voxels along x, y, z.
    pub dims: [u32; 3],
    /// Physical voxel size along x, y, z (finite and > 0).
    pub spacing: [f32; 3],
    /// Decoded (not normalized) values, `len == dims[0] * dims[1] * dims[2]`; empty when the
    /// volume was streamed into [`Volume::normalized`] instead.
    pub data: Vec<f32>,
    /// The values already normalized to u16 (see [`Volume::normalized_u16`]) when a loader
    /// streamed a volume larger than [`LoadOptions::stream_above`]: holding its `f32` values too
    /// would triple the host memory. `data` is then empty.
    pub normalized: Option<Vec<u16>>,
    /// Minimum and maximum of `data` (after sanitizing).
    pub value_range: [f32; 2],
    /// File path or procedural description, for messages and reports.
    pub source: String,
    /// Notes for the caller to print, e.g. how many NaN voxels were replaced.
    pub warnings: Vec<String>,
    /// What the values measure, as far as the file says (default: unknown).
    pub quantity: Quantity,
    /// The axes are a patient's (x → left, y → posterior, z → superior: DICOM and NIfTI after
    /// reordering), so a viewer can show superior up and the face towards the camera.
    pub patient_axes: bool,
    /// The voxels as leaves and tiles (OpenVDB), which the sparse layout bricks directly. When
    /// `data` and `normalized` are both empty the volume exists only in this form.
    pub sparse: Option<std::sync::Arc<sparse::SparseGrid>>,
    /// The sparse layout's bricks, built slab by slab as the file was read
    /// ([`LoadOptions::bricks`]); when `data` and `normalized` are empty the volume exists
    /// only in this form.
    pub bricks: Option<std::sync::Arc<crate::volume::data::bricks::builder::SparseBuild>>,
    /// The pyramid level `bricks` holds, when the volume's own bricks did not fit: `dims` and
    /// `spacing` are then that level's.
    pub lod: Option<Lod>,
    /// OpenVDB: the index coordinate of voxel (0, 0, 0) (the grid's active bounds' low corner),
    /// so grids of one file can be checked to share a box; `None` for other formats.
    pub index_origin: Option<[i64; 3]>,
}

/// Which level of the brick pyramid a volume holds when its bricks did not fit the device: the
/// volume halved `level` times (each voxel a block mean), over the same box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lod {
    /// Pyramid level (1: voxels twice as large along each axis).
    pub level: u32,
    /// The source's dims, at level 0.
    pub full_dims: [u32; 3],
    /// Bytes of GPU memory level 0 needs at least.
    pub needed: u64,
    /// Bytes of GPU memory the load was given.
    pub budget: u64,
}

/// What a volume's values measure, when the file format records it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Quantity {
    /// Acquisition modality as the file names it (DICOM codes such as `CT`, `MR`, `PT`), if any.
    pub modality: Option<String>,
    /// Unit of the decoded values (after any rescale the file prescribes).
    pub unit: ValueUnit,
}

/// Unit of voxel values.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum ValueUnit {
    /// Not recorded (most formats): values are in whatever the producer used.
    #[default]
    Unknown,
    /// Hounsfield units (CT): −1000 is air, 0 water, bone several hundred and up.
    Hounsfield,
    /// A medium's density (OpenVDB `density` grids, as smoke and cloud simulations write them):
    /// extinction proportional to the value.
    Density,
    /// A unit the file names that has no variant here (e.g. DICOM `RescaleType` `BQML`).
    Other(String),
}

impl Quantity {
    /// Whether negative values are meaningful in this unit, so loaders accept them without
    /// `allow_negative` (air is −1000 HU by definition).
    pub fn signed(&self) -> bool {
        self.unit == ValueUnit::Hounsfield
    }
}

impl Volume {
    /// Builds a volume from decoded values: checks dims, spacing and length, replaces NaN (with a warning),
    /// rejects ±Inf, and computes the value range. Negative values are allowed here.
    pub fn new(
        dims: [u32; 3],
        spacing: [f32; 3],
        data: Vec<f32>,
        source: impl Into<String>,
    ) -> Result<Self, VolumeError> {
        Self::build(dims, spacing, data, source.into(), true)
    }

    /// Shared constructor; loaders pass their `allow_negative` option.
    pub(crate) fn build(
        dims: [u32; 3],
        spacing: [f32; 3],
        mut data: Vec<f32>,
        source: String,
        allow_negative: bool,
    ) -> Result<Self, VolumeError> {
        let count = check_dims(&source, dims.map(u64::from), u32::MAX)?;
        check_spacing(&source, spacing.map(f64::from))?;
        if data.len() as u64 != count {
            return Err(VolumeError::DataLength { file: source, expected: count, got: data.len() as u64 });
        }
        let warnings = sanitize(&source, dims, &mut data, allow_negative)?;
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for &v in &data {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        Ok(Volume {
            dims,
            spacing,
            data,
            value_range: [lo, hi],
            source,
            warnings,
            quantity: Quantity::default(),
            patient_axes: false,
            normalized: None,
            sparse: None,
            bricks: None,
            lod: None,
            index_origin: None,
        })
    }

    /// Value at voxel (x, y, z), or `None` outside the volume.
    pub fn get(&self, x: u32, y: u32, z: u32) -> Option<f32> {
        let [nx, ny, nz] = self.dims;
        if x >= nx || y >= ny || z >= nz {
            return None;
        }
        let i = (z as usize * ny as usize + y as usize) * nx as usize + x as usize;
        if let Some(b) = self.bricks_only() {
            return Some(stream::dequantize(bricked::value(&b.bricks, [x, y, z]), self.value_range));
        }
        match (&self.normalized, self.sparse_only()) {
            (Some(q), _) => q.get(i).map(|&q| stream::dequantize(q, self.value_range)),
            (None, Some(g)) => Some(stream::dequantize(g.value([x, y, z].map(i64::from)), self.value_range)),
            (None, None) => self.data.get(i).copied(),
        }
    }

    /// Every voxel's value, x fastest: the decoded values, or what the normalized samples stand for.
    pub fn values(&self) -> Box<dyn Iterator<Item = f32> + '_> {
        if let Some(g) = self.sparse_only() {
            let [nx, ny, nz] = self.dims.map(i64::from);
            let range = self.value_range;
            let voxels = (0..nz).flat_map(move |z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])));
            return Box::new(voxels.map(move |p| stream::dequantize(g.value(p), range)));
        }
        if let Some(b) = self.bricks_only() {
            let range = self.value_range;
            return Box::new(
                bricked::voxels(self.dims).map(move |p| stream::dequantize(bricked::value(&b.bricks, p), range)),
            );
        }
        match &self.normalized {
            Some(q) => Box::new(q.iter().map(|&q| stream::dequantize(q, self.value_range))),
            None => Box::new(self.data.iter().copied()),
        }
    }

    /// Each value with the number of voxels holding it (one per voxel, or per distinct value of
    /// a volume kept sparse, whose box may hold more voxels than can be visited).
    pub fn value_counts(&self) -> Box<dyn Iterator<Item = (f32, u64)> + '_> {
        if let Some(g) = self.sparse_only() {
            let range = self.value_range;
            return Box::new(g.value_counts().into_iter().map(move |(q, n)| (stream::dequantize(q, range), n)));
        }
        Box::new(self.values().map(|v| (v, 1)))
    }

    /// First and last x in row (y, z) whose value passes `keep`, or `None` when none does.
    pub fn row_span(&self, y: u32, z: u32, keep: impl Fn(f32) -> bool) -> Option<(usize, usize)> {
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        let at = (z as usize * ny + y as usize) * nx;
        let span = |row: &mut dyn Iterator<Item = f32>| -> Option<(usize, usize)> {
            let mut first = None;
            let mut last = 0;
            for (x, v) in row.enumerate() {
                if keep(v) {
                    first.get_or_insert(x);
                    last = x;
                }
            }
            first.map(|f| (f, last))
        };
        if let Some(g) = self.sparse_only() {
            let range = self.value_range;
            let row = (0..nx as i64).map(|x| stream::dequantize(g.value([x, i64::from(y), i64::from(z)]), range));
            return span(&mut row.into_iter());
        }
        if self.bricks_only().is_some() {
            return span(&mut (0..nx as u32).filter_map(|x| self.get(x, y, z)));
        }
        match &self.normalized {
            Some(q) => span(&mut q.get(at..at + nx)?.iter().map(|&q| stream::dequantize(q, self.value_range))),
            None => span(&mut self.data.get(at..at + nx)?.iter().copied()),
        }
    }

    /// Value at voxel (x, y, z).
    ///
    /// # Panics
    /// If the coordinate is outside the volume (a caller bug, like slice indexing); use [`Volume::get`] otherwise.
    pub fn at(&self, x: u32, y: u32, z: u32) -> f32 {
        match self.get(x, y, z) {
            Some(v) => v,
            None => panic!("voxel ({x}, {y}, {z}) is outside volume dims {:?} ({})", self.dims, self.source),
        }
    }

    /// Number of voxels (`dims` product).
    pub fn voxel_count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Values normalized to [0, 1] by `value_range` and quantized to u16 (0..=65535, rounded), ready for an
    /// `R16_UNORM` 3D texture: the minimum maps to exactly 0 and the maximum to exactly 65535.
    ///
    /// A constant volume (max == min) has no range to normalize by; it maps to 65535 (1.0) if the value is > 0
    /// and to 0 otherwise, so a homogeneous box of positive density stays visible.
    /// A streamed volume lends its samples; the others are computed.
    pub fn normalized_u16(&self) -> Cow<'_, [u16]> {
        if let Some(q) = &self.normalized {
            return Cow::Borrowed(q);
        }
        if let Some(g) = self.sparse_only() {
            let [nx, ny, nz] = self.dims.map(i64::from);
            let voxels = (0..nz).flat_map(|z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])));
            return Cow::Owned(voxels.map(|p| g.value(p)).collect());
        }
        if let Some(b) = self.bricks_only() {
            return Cow::Owned(bricked::voxels(self.dims).map(|p| bricked::value(&b.bricks, p)).collect());
        }
        let [lo, hi] = self.value_range.map(f64::from);
        Cow::Owned(self.data.iter().map(|&v| stream::quantize(v, lo, hi)).collect())
    }

    /// The sparse grid when it is the only form of the voxels.
    pub fn sparse_only(&self) -> Option<&sparse::SparseGrid> {
        self.sparse.as_deref().filter(|_| self.data.is_empty() && self.normalized.is_none())
    }

    /// The bricks when they are the only form of the voxels.
    pub fn bricks_only(&self) -> Option<&crate::volume::data::bricks::builder::SparseBuild> {
        self.bricks.as_deref().filter(|_| self.data.is_empty() && self.normalized.is_none() && self.sparse.is_none())
    }

    /// Physical extent `dims * spacing` along x, y, z.
    pub fn extent(&self) -> [f32; 3] {
        [0, 1, 2].map(|i| self.dims[i] as f32 * self.spacing[i])
    }

    /// Largest component of [`Volume::extent`]: divide by it to fit the volume in a unit box.
    pub fn max_extent(&self) -> f32 {
        let [x, y, z] = self.extent();
        x.max(y).max(z)
    }
}

/// How to interpret a volume file; header formats take dims / type / byte order from the header.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadOptions {
    /// Dims for raw files (overrides the sidecar; ignored with a warning for header formats).
    pub dims: Option<[u32; 3]>,
    /// Voxel type for raw files (overrides the sidecar; ignored with a warning for header formats).
    pub voxel: Option<VoxelType>,
    /// Byte order for raw files (default little; overrides the sidecar; ignored with a warning for header formats).
    pub endian: Option<Endian>,
    /// Voxel spacing; overrides the sidecar or header in every format.
    pub spacing: Option<[f32; 3]>,
    /// Accept negative values (they are mapped through the value range) instead of failing.
    pub allow_negative: bool,
    /// Largest accepted size per axis; pass 64 × the device's `maxImageDimension3D` (the sparse
    /// layout's page directory, one word per 8³ bricks of 8³ voxels, is a 3D image).
    pub max_dimension: u32,
    /// DICOM: the `SeriesInstanceUID` to load when a folder holds several series.
    pub series: Option<String>,
    /// NIfTI: which volume (0-based) of a 4D file to load; default the first, with a warning.
    pub frame: Option<u32>,
    /// OpenVDB: the grid to load; default `density`, or the only float grid.
    pub grid: Option<String>,
    /// Voxel count above which raw, MetaImage, NRRD and NIfTI data is streamed straight into
    /// [`Volume::normalized`] (host memory: the u16 output and one slab) instead of kept as `f32`.
    pub stream_above: u64,
    /// What the device can hold: a volume that cannot fit is refused before anything is allocated.
    pub device: Option<DeviceBudget>,
    /// Whether raw, MetaImage, NRRD, NIfTI and DICOM loads build the sparse layout's bricks as
    /// they read (into [`Volume::bricks`]) instead of the dense volume; `None`: never.
    pub bricks: Option<IntoBricks>,
    /// Host bytes a load into bricks may take; `None`: what the system has available
    /// (`MemAvailable`) when the bricks' size is known, after the first pass.
    pub host_memory: Option<u64>,
    /// The pyramid level a load into bricks builds: `None` the finest that fits `device` (the
    /// volume itself when it fits), `Some(0)` the volume itself or a refusal, `Some(k)` level k.
    pub lod: Option<u32>,
    /// The `gpu_memory` setting that capped `device`'s heap: refusals name it instead of the
    /// heap when it is what limits the volume.
    pub gpu_memory: Option<u64>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            dims: None,
            voxel: None,
            endian: None,
            spacing: None,
            allow_negative: false,
            max_dimension: 2048,
            series: None,
            frame: None,
            grid: None,
            stream_above: 1 << 25,
            device: None,
            bricks: None,
            host_memory: None,
            lod: None,
            gpu_memory: None,
        }
    }
}

/// Loads a volume, choosing the format by extension (case-insensitive): `.mhd`/`.mha` → MetaImage,
/// `.nrrd`/`.nhdr` → NRRD, `.nii`/`.nii.gz` → NIfTI, `.vdb` → OpenVDB, `.dcm`/`.dicom` or a folder →
/// DICOM, anything else → DICOM if the file has the `DICM` preamble, raw otherwise (dims and type from
/// `opts` or a `<file>.json` sidecar).
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Volume, VolumeError> {
    load_with_progress(path, opts, &mut |_, _| {})
}

/// [`load`], reporting the progress of a streamed load (bytes done and total) as it goes.
pub fn load_with_progress(path: &Path, opts: &LoadOptions, progress: Progress<'_>) -> Result<Volume, VolumeError> {
    if path.is_dir() {
        return dicom::load(path, opts, progress);
    }
    let name = path.file_name().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    if name.ends_with(".nii") || name.ends_with(".nii.gz") {
        return nifti::load(path, opts, progress);
    }
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match ext.as_str() {
        "mhd" | "mha" => metaimage::load(path, opts, progress),
        "nrrd" | "nhdr" => nrrd::load(path, opts, progress),
        "vdb" => vdb::load(path, opts, progress),
        "dcm" | "dicom" => dicom::load(path, opts, progress),
        // Scanners often write DICOM files without an extension (or with a number for one).
        _ if dicom::has_preamble(path) => dicom::load(path, opts, progress),
        _ => raw::load(path, opts, progress),
    }
}

/// Builds the volume from decoded values, with `quantity` and the loader's warnings attached;
/// negative values pass when `opts.allow_negative` is set or the unit is signed.
pub(crate) fn finish_values(
    file: &str,
    dims: [u32; 3],
    spacing: [f32; 3],
    data: Vec<f32>,
    opts: &LoadOptions,
    quantity: Quantity,
    mut warnings: Vec<String>,
) -> Result<Volume, VolumeError> {
    let spacing = opts.spacing.unwrap_or(spacing);
    let allow_negative = opts.allow_negative || quantity.signed();
    let mut vol = Volume::build(dims, spacing, data, file.to_owned(), allow_negative)?;
    warnings.append(&mut vol.warnings);
    vol.warnings = warnings;
    vol.quantity = quantity;
    Ok(vol)
}

/// Allocates room for `len` decoded values without aborting when memory is short.
pub(crate) fn value_buffer(file: &str, len: u64) -> Result<Vec<f32>, VolumeError> {
    let mut v = Vec::new();
    let ok = usize::try_from(len).ok().is_some_and(|n| v.try_reserve_exact(n).is_ok());
    if !ok {
        return Err(VolumeError::Invalid { file: file.to_owned(), message: format!("cannot allocate {len} voxels") });
    }
    Ok(v)
}

/// Validated layout of the voxel data a header describes, before reading it.
pub(crate) struct Layout {
    pub dims: [u32; 3],
    pub voxel: VoxelType,
    pub endian: Endian,
    pub spacing: [f32; 3],
}

impl Layout {
    /// Validates header values (dims against the device's limits and, unless the load builds
    /// bricks, `MAX_VOXELS`; spacing finite and positive) and builds the layout every loader reads with.
    pub fn validated(
        file: &str,
        dims: [u64; 3],
        voxel: VoxelType,
        endian: Endian,
        spacing: [f64; 3],
        opts: &LoadOptions,
    ) -> Result<Self, VolumeError> {
        check_load_dims(file, dims, opts)?;
        check_fits(file, dims, opts)?;
        let spacing = check_spacing(file, spacing)?;
        // check_dims bounded every axis by max_dimension (a u32), so these conversions cannot fail.
        let dims = dims.map(|d| u32::try_from(d).unwrap_or(u32::MAX));
        Ok(Self { dims, voxel, endian, spacing })
    }

    /// Bytes of voxel data the layout requires (saturating: a count past `u64` was refused, its bytes
    /// at most 8× it can only exceed every file).
    pub fn byte_len(&self) -> u64 {
        self.dims.iter().map(|&d| u64::from(d)).product::<u64>().saturating_mul(self.voxel.bytes() as u64)
    }
}

/// Checks dims read from a file for a load with `opts` and returns the voxel count: at most
/// [`MAX_VOXELS`] for a dense volume; any count a `u64` holds when the load builds bricks, whose
/// stored bricks are checked against host and device memory after the first pass instead.
pub(crate) fn check_load_dims(file: &str, dims: [u64; 3], opts: &LoadOptions) -> Result<u64, VolumeError> {
    let into_bricks = match dims.map(u32::try_from) {
        [Ok(x), Ok(y), Ok(z)] => bricked::wanted([x, y, z], opts) != bricked::Want::No,
        _ => false,
    };
    check_voxels(file, dims, opts.max_dimension, if into_bricks { u64::MAX } else { MAX_VOXELS })
}

/// Checks dims read from a file (as u64, so huge header values are caught) and returns the voxel count.
pub(crate) fn check_dims(file: &str, dims: [u64; 3], limit: u32) -> Result<u64, VolumeError> {
    check_voxels(file, dims, limit, MAX_VOXELS)
}

/// [`check_dims`] with a voxel count limit of `max_voxels`.
fn check_voxels(file: &str, dims: [u64; 3], limit: u32, max_voxels: u64) -> Result<u64, VolumeError> {
    if dims.contains(&0) {
        return Err(VolumeError::ZeroDimension { file: file.to_owned(), dims });
    }
    if dims.iter().any(|&d| d > u64::from(limit)) {
        return Err(VolumeError::TooLarge { file: file.to_owned(), dims, limit });
    }
    let count = dims.iter().try_fold(1u64, |acc, &d| acc.checked_mul(d));
    match count {
        Some(n) if n <= max_voxels => Ok(n),
        _ => Err(VolumeError::TooManyVoxels { file: file.to_owned(), dims, limit: max_voxels }),
    }
}

/// Checks spacing (as f64 so values beyond the f32 range are caught before conversion).
pub(crate) fn check_spacing(file: &str, spacing: [f64; 3]) -> Result<[f32; 3], VolumeError> {
    let ok = spacing.iter().all(|&s| s.is_finite() && s > 0.0 && (s as f32).is_finite() && s as f32 > 0.0);
    if !ok {
        return Err(VolumeError::BadSpacing { file: file.to_owned(), spacing });
    }
    Ok(spacing.map(|s| s as f32))
}

/// Warnings about options that do not apply to self-describing formats.
pub(crate) fn ignored_option_warnings(opts: &LoadOptions, layout: &Layout) -> Vec<String> {
    let mut w = Vec::new();
    if let Some(d) = opts.dims.filter(|d| *d != layout.dims) {
        w.push(format!("dims option {d:?} ignored: the header says {:?}", layout.dims));
    }
    if let Some(t) = opts.voxel.filter(|t| *t != layout.voxel) {
        w.push(format!("voxel type option {t} ignored: the header says {}", layout.voxel));
    }
    if let Some(e) = opts.endian.filter(|e| *e != layout.endian && layout.voxel.bytes() > 1) {
        w.push(format!("endian option {e} ignored: the header says {}", layout.endian));
    }
    w
}

/// Reads the region `layout` describes and builds the volume with the loader options applied:
/// decoded to `f32` up to `opts.stream_above` voxels, streamed into normalized u16 past it.
pub(crate) fn finish_region(
    file: &str,
    layout: &Layout,
    region: &read::DataRegion<'_>,
    opts: &LoadOptions,
    mut warnings: Vec<String>,
    progress: Progress<'_>,
) -> Result<Volume, VolumeError> {
    let hint = |got| read::size_hint(layout.dims, layout.voxel.bytes(), got);
    let count = layout.dims.iter().map(|&d| u64::from(d)).product::<u64>();
    let bricks = bricked::wanted(layout.dims, opts);
    if count <= opts.stream_above && bricks == bricked::Want::No {
        let bytes = read::read_region(region, hint)?;
        let data = voxel::decode(&bytes, layout.voxel, layout.endian);
        drop(bytes);
        let mut vol = Volume::build(layout.dims, layout.spacing, data, file.to_owned(), opts.allow_negative)?;
        warnings.append(&mut vol.warnings);
        vol.warnings = warnings;
        return Ok(vol);
    }
    let decode = stream::Decode { voxel: layout.voxel, endian: layout.endian, rescale: None };
    let mut s = stream::normalize(
        file,
        layout.dims,
        layout.spacing,
        &decode,
        None,
        opts.allow_negative,
        (bricks, &bricked::Room::of(opts)),
        progress,
        &mut |each| read::stream_region(region, hint, each),
    )?;
    warnings.append(&mut s.warnings);
    Ok(streamed(file, s, warnings))
}

/// The volume a streamed load produced.
pub(crate) fn streamed(file: &str, s: stream::Streamed, mut warnings: Vec<String>) -> Volume {
    // A coarser level spans the same box with fewer, larger voxels.
    let (dims, spacing) = match s.lod {
        None => (s.dims, s.spacing),
        Some(l) => {
            let d = bricks::pyramid::level_dims(s.dims, l.level);
            let spacing = [0, 1, 2].map(|a| s.spacing[a] * s.dims[a] as f32 / d[a] as f32);
            warnings.push(format!(
                "{file}: its bricks need at least {} bytes of GPU memory but {} bytes are available: showing pyramid level {} ({}x{}x{} voxels of {} x {} x {}, not {}x{}x{} of {} x {} x {}); lod=0 refuses instead",
                l.needed, l.budget, l.level, d[0], d[1], d[2], spacing[0], spacing[1], spacing[2],
                s.dims[0], s.dims[1], s.dims[2], s.spacing[0], s.spacing[1], s.spacing[2]
            ));
            (d, spacing)
        }
    };
    Volume {
        dims,
        spacing,
        data: Vec::new(),
        normalized: s.normalized,
        value_range: s.value_range,
        source: file.to_owned(),
        warnings,
        quantity: Quantity::default(),
        patient_axes: false,
        sparse: None,
        bricks: s.bricks.map(std::sync::Arc::new),
        lod: s.lod,
        index_origin: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coord_matches_x_fastest_layout() {
        assert_eq!(coord([3, 4, 5], 0), [0, 0, 0]);
        assert_eq!(coord([3, 4, 5], 3 * 4 + 3 + 2), [2, 1, 1]);
    }

    #[test]
    fn dims_product_overflow_is_an_error() {
        let err = check_dims("f", [u64::from(u32::MAX); 3], u32::MAX);
        assert!(matches!(err, Err(VolumeError::TooManyVoxels { .. })));
    }
}
