//! DICOM straight into the sparse layout's bricks: the slices, decoded one file (or one frame)
//! at a time in stack order, go through the streamed loads' two passes (value range, then
//! normalized slices into bricks, or into the dense normalized volume where `auto` keeps it
//! dense), so the host never holds the volume as `f32` values.

use super::bricked::Want;
use super::orient::plan;
use super::stream::{normalize, Decode};
use super::{check_spacing, streamed, LoadOptions, Progress, Quantity, Volume, VolumeError};
use super::{Endian, VoxelType};

/// Takes one decoded slice's values.
pub(crate) type SliceSink<'a> = &'a mut dyn FnMut(&[f32]) -> Result<(), VolumeError>;

/// Builds the volume of `dims` slices that `slices` hands over in stack order (once per pass),
/// with the voxel axes `axes` (row, column, normal in LPS) reordered to patient axes, what
/// the values measure and the warnings so far.
pub(crate) fn load(
    file: &str,
    (dims, spacing, axes): ([u32; 3], [f32; 3], Option<[[f64; 3]; 3]>),
    opts: &LoadOptions,
    (quantity, mut warnings): (Quantity, Vec<String>),
    want: Want,
    progress: Progress<'_>,
    slices: &mut dyn FnMut(SliceSink<'_>) -> Result<(), VolumeError>,
) -> Result<Volume, VolumeError> {
    let reorder = axes.and_then(|a| plan(file, dims, spacing, a, &mut warnings));
    let endian = if cfg!(target_endian = "little") { Endian::Little } else { Endian::Big };
    let decode = Decode { voxel: VoxelType::F32, endian, rescale: None };
    let allow_negative = opts.allow_negative || quantity.signed();
    let room = super::bricked::Room::of(opts);
    let mut s = normalize(
        file,
        dims,
        spacing,
        &decode,
        reorder.as_ref(),
        allow_negative,
        (want, &room),
        progress,
        &mut |each| slices(&mut |v: &[f32]| each(bytemuck::cast_slice(v))),
    )?;
    warnings.append(&mut s.warnings);
    s.spacing = check_spacing(file, opts.spacing.unwrap_or(s.spacing).map(f64::from))?;
    let mut vol = streamed(file, s, warnings);
    vol.quantity = quantity;
    vol.patient_axes = true;
    Ok(vol)
}
