//! Whether a volume fits the device it will be rendered on, decided from its dims alone so a
//! volume that cannot fit is refused before its data is read or anything is allocated.

use super::{LoadOptions, VolumeError};

/// The device memory a volume must fit in (from the Vulkan device the caller renders on).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceBudget {
    /// Size of the largest device-local memory heap.
    pub heap_bytes: u64,
    /// `maxMemoryAllocationSize`: the most one image may take.
    pub max_allocation: u64,
}

/// Bytes one R16 image of `dims` takes (the volume, and its gradient magnitudes, are one each).
pub fn image_bytes(dims: [u32; 3]) -> u64 {
    dims.iter().map(|&d| u64::from(d)).product::<u64>() * 2
}

/// Bytes the renderer uploads for a dense volume of `dims`: the normalized volume and its
/// gradient-magnitude image (the occupancy and majorant grids are 1/512 of that and left out).
pub fn gpu_bytes(dims: [u32; 3]) -> u64 {
    2 * image_bytes(dims)
}

/// Refuses `dims` when its images cannot fit the device in `opts`, with the numbers.
pub(crate) fn check_fits(file: &str, dims: [u64; 3], opts: &LoadOptions) -> Result<(), VolumeError> {
    let Some(budget) = opts.device else { return Ok(()) };
    let Ok(d) = dims.map(u32::try_from).into_iter().collect::<Result<Vec<u32>, _>>() else { return Ok(()) };
    let d = [d[0], d[1], d[2]];
    let (image, needed) = (image_bytes(d), gpu_bytes(d));
    if needed > budget.heap_bytes {
        return Err(VolumeError::DeviceMemory {
            file: file.to_owned(),
            dims,
            needed,
            available: budget.heap_bytes,
            what: "the device-local heap",
        });
    }
    if image > budget.max_allocation {
        return Err(VolumeError::DeviceMemory {
            file: file.to_owned(),
            dims,
            needed: image,
            available: budget.max_allocation,
            what: "one allocation (maxMemoryAllocationSize)",
        });
    }
    Ok(())
}
