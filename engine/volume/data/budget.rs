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
    dims.iter().fold(2u64, |acc, &d| acc.saturating_mul(u64::from(d)))
}

impl DeviceBudget {
    /// Refuses a volume of `dims` (from `source`) whose images cannot fit this device's memory,
    /// with the numbers. One allocation's limit (`max_allocation`) is no reason: a volume past it
    /// is stored in bricks (`volume::layout`), whose atlas is checked against it when uploaded.
    pub fn check(&self, source: &str, dims: [u64; 3]) -> Result<(), VolumeError> {
        self.check_named(source, dims, "the device-local heap")
    }

    /// [`Self::check`], naming the budget `what` (the heap, or the setting that capped it).
    fn check_named(&self, source: &str, dims: [u64; 3], what: &'static str) -> Result<(), VolumeError> {
        // Saturating: a header's absurd dims must be refused, not wrap around to a small size.
        let image = dims.iter().fold(2u64, |acc, &d| acc.saturating_mul(d));
        let needed = image.saturating_mul(2);
        if needed > self.heap_bytes {
            return Err(VolumeError::DeviceMemory {
                file: source.to_owned(),
                dims,
                needed,
                available: self.heap_bytes,
                what,
            });
        }
        Ok(())
    }
}

/// Refuses `dims` when its images cannot fit the device in `opts`, with the numbers. A load
/// that builds bricks is checked by what its bricks take once they are built
/// (`volume::layout::upload_bricks`): a mostly empty volume fits where its dense images do not.
pub(crate) fn check_fits(file: &str, dims: [u64; 3], opts: &LoadOptions) -> Result<(), VolumeError> {
    let bricked = match dims.map(u32::try_from) {
        [Ok(x), Ok(y), Ok(z)] => super::bricked::wanted([x, y, z], opts) == super::bricked::Want::Yes,
        _ => false,
    };
    match opts.device {
        Some(budget) if !bricked => budget.check_named(file, dims, limit_name(opts).0),
        _ => Ok(()),
    }
}

/// What limits device memory in `opts`, as a refusal names it: the `gpu_memory` setting when it
/// capped the heap, else the device-local heap; and the verb for what it offers.
pub(crate) fn limit_name(opts: &LoadOptions) -> (&'static str, &'static str) {
    match (opts.gpu_memory, opts.device) {
        (Some(g), Some(d)) if g == d.heap_bytes => ("the gpu_memory setting", "allows"),
        _ => ("the device-local heap", "holds"),
    }
}

/// Host memory the system has available for a load (`MemAvailable` in `/proc/meminfo`: free
/// memory and caches it can drop, without swapping); `None` where it does not say.
pub(crate) fn host_available() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?;
    let kib = line.trim().strip_suffix("kB")?.trim().parse::<u64>().ok()?;
    Some(kib.saturating_mul(1024))
}
