//! Physical-device choice: discrete GPU, then integrated, then virtual, then CPU (lavapipe),
//! unless the user names one.

use ash::vk;

/// What device selection needs to know about one candidate.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// `deviceName` from the driver.
    pub name: String,
    /// Device type reported by the driver.
    pub kind: vk::PhysicalDeviceType,
    /// Why this device cannot run the engine, if it cannot.
    pub unsupported: Option<String>,
}

fn rank(kind: vk::PhysicalDeviceType) -> u32 {
    match kind {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

/// Picks the best supported candidate, or the first whose name contains `wanted` (case-insensitive).
pub fn select_device(candidates: &[Candidate], wanted: Option<&str>) -> Result<usize, String> {
    let list = || {
        candidates
            .iter()
            .map(|c| match &c.unsupported {
                Some(why) => format!("{} ({:?}, unsupported: {why})", c.name, c.kind),
                None => format!("{} ({:?})", c.name, c.kind),
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    if candidates.is_empty() {
        return Err("no Vulkan devices found (is a driver such as mesa-vulkan-drivers installed?)".into());
    }
    if let Some(w) = wanted.filter(|w| !w.is_empty()) {
        let w_low = w.to_lowercase();
        let idx = candidates
            .iter()
            .position(|c| c.name.to_lowercase().contains(&w_low))
            .ok_or_else(|| format!("no Vulkan device matches `{w}`; available: {}", list()))?;
        return match &candidates[idx].unsupported {
            Some(why) => Err(format!("device `{}` cannot run the engine: {why}", candidates[idx].name)),
            None => Ok(idx),
        };
    }
    candidates
        .iter()
        .enumerate()
        .filter(|(_, c)| c.unsupported.is_none())
        .min_by_key(|(i, c)| (rank(c.kind), *i))
        .map(|(i, _)| i)
        .ok_or_else(|| format!("no Vulkan device supports the engine's requirements; found: {}", list()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(name: &str, kind: vk::PhysicalDeviceType, ok: bool) -> Candidate {
        Candidate { name: name.into(), kind, unsupported: (!ok).then(|| "no Vulkan 1.3".into()) }
    }

    #[test]
    fn prefers_discrete_then_integrated_then_cpu() {
        let cpu = c("llvmpipe", vk::PhysicalDeviceType::CPU, true);
        let igpu = c("Intel UHD", vk::PhysicalDeviceType::INTEGRATED_GPU, true);
        let dgpu = c("NVIDIA RTX", vk::PhysicalDeviceType::DISCRETE_GPU, true);
        assert_eq!(select_device(&[cpu.clone(), igpu.clone(), dgpu.clone()], None), Ok(2));
        assert_eq!(select_device(&[cpu.clone(), igpu.clone()], None), Ok(1));
        assert_eq!(select_device(std::slice::from_ref(&cpu), None), Ok(0));
    }

    #[test]
    fn skips_unsupported_and_honours_name() {
        let cpu = c("llvmpipe (LLVM 15)", vk::PhysicalDeviceType::CPU, true);
        let old = c("Old GPU", vk::PhysicalDeviceType::DISCRETE_GPU, false);
        assert_eq!(select_device(&[old.clone(), cpu.clone()], None), Ok(1));
        assert_eq!(select_device(&[old.clone(), cpu.clone()], Some("LLVMPIPE")), Ok(1));
        let err = select_device(&[old.clone(), cpu.clone()], Some("old")).unwrap_err();
        assert!(err.contains("no Vulkan 1.3"), "{err}");
        let err = select_device(&[cpu], Some("radeon")).unwrap_err();
        assert!(err.contains("radeon") && err.contains("llvmpipe"), "{err}");
        assert!(select_device(&[], None).is_err());
    }
}
