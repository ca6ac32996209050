//! Physical-device choice: discrete GPU, then integrated, then virtual, then CPU (lavapipe),
//! unless the user names one: by index (`#N`, the order Vulkan enumerates devices), by identity
//! (`uuid:…`, Vulkan's `deviceUUID`, which NVIDIA's driver makes the `GPU-…` of `nvidia-smi -L`)
//! or by (part of) its name. Identical GPUs share a name, so only the first two tell them apart.

use ash::vk;

/// What device selection needs to know about one candidate.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// `deviceName` from the driver.
    pub name: String,
    /// Device type reported by the driver.
    pub kind: vk::PhysicalDeviceType,
    /// `deviceUUID`: stable across processes and APIs (CUDA and NVML report the same on NVIDIA).
    pub uuid: [u8; 16],
    /// Why this device cannot run the engine, if it cannot.
    pub unsupported: Option<String>,
}

/// A UUID as text, `8-4-4-4-12` lowercase hex digits (the form `vulkaninfo` and `nvidia-smi` print).
pub fn format_uuid(u: &[u8; 16]) -> String {
    let hex: String = u.iter().map(|b| format!("{b:02x}")).collect();
    format!("{}-{}-{}-{}-{}", &hex[..8], &hex[8..12], &hex[12..16], &hex[16..20], &hex[20..])
}

/// The 32 hex digits of `uuid:…` text: dashes, case and an `nvidia-smi` `GPU-` prefix ignored.
fn parse_uuid(text: &str) -> Option<String> {
    let t = text.trim();
    let t = t.strip_prefix("GPU-").or_else(|| t.strip_prefix("gpu-")).unwrap_or(t);
    let hex: String = t.chars().filter(|c| *c != '-').collect::<String>().to_lowercase();
    (hex.len() == 32 && hex.chars().all(|c| c.is_ascii_hexdigit())).then_some(hex)
}

/// Every candidate on one line each way a user can name it: `#N name (kind, uuid:…)`.
pub fn describe(candidates: &[Candidate]) -> String {
    candidates
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let uuid = format_uuid(&c.uuid);
            match &c.unsupported {
                Some(why) => format!("#{i} {} ({:?}, uuid:{uuid}, unsupported: {why})", c.name, c.kind),
                None => format!("#{i} {} ({:?}, uuid:{uuid})", c.name, c.kind),
            }
        })
        .collect::<Vec<_>>()
        .join("; ")
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

/// Why no device was chosen.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    /// One line, listing the devices.
    pub message: String,
    /// The user's choice named no device (a bad argument), as opposed to no usable device.
    pub bad_choice: bool,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// Picks the best supported candidate, or the one `wanted` names: `#N` (index), `uuid:HEX`
/// (`deviceUUID`), else the first whose name contains it (case-insensitive).
pub fn select_device(candidates: &[Candidate], wanted: Option<&str>) -> Result<usize, Refusal> {
    let refuse = |message: String| Refusal { message, bad_choice: false };
    if candidates.is_empty() {
        return Err(refuse("no Vulkan devices found (is a driver such as mesa-vulkan-drivers installed?)".into()));
    }
    if let Some(w) = wanted.map(str::trim).filter(|w| !w.is_empty()) {
        return choose(candidates, w).map_err(|message| Refusal { message, bad_choice: true }).and_then(|idx| {
            match &candidates[idx].unsupported {
                Some(why) => {
                    Err(refuse(format!("device #{idx} `{}` cannot run the engine: {why}", candidates[idx].name)))
                }
                None => Ok(idx),
            }
        });
    }
    candidates
        .iter()
        .enumerate()
        .filter(|(_, c)| c.unsupported.is_none())
        .min_by_key(|(i, c)| (rank(c.kind), *i))
        .map(|(i, _)| i)
        .ok_or_else(|| {
            refuse(format!("no Vulkan device supports the engine's requirements; found: {}", describe(candidates)))
        })
}

/// The index of the candidate `w` names, or why it names none.
fn choose(candidates: &[Candidate], w: &str) -> Result<usize, String> {
    Ok(if let Some(n) = w.strip_prefix('#') {
        let n: usize = n.trim().parse().map_err(|_| {
            format!("device `{w}`: `#` takes a device index (#0, #1, …); devices: {}", describe(candidates))
        })?;
        if n >= candidates.len() {
            return Err(format!(
                "no Vulkan device #{n}: there {} {} ({})",
                if candidates.len() == 1 { "is" } else { "are" },
                candidates.len(),
                describe(candidates)
            ));
        }
        n
    } else if w.get(..5).is_some_and(|p| p.eq_ignore_ascii_case("uuid:")) {
        let hex = parse_uuid(&w[5..]).ok_or_else(|| {
            format!(
                "device `{w}`: a UUID is 32 hex digits (dashes and a GPU- prefix allowed); devices: {}",
                describe(candidates)
            )
        })?;
        candidates
            .iter()
            .position(|c| format_uuid(&c.uuid).replace('-', "") == hex)
            .ok_or_else(|| format!("no Vulkan device has uuid {}; devices: {}", w[5..].trim(), describe(candidates)))?
    } else {
        let w_low = w.to_lowercase();
        candidates
            .iter()
            .position(|c| c.name.to_lowercase().contains(&w_low))
            .ok_or_else(|| format!("no Vulkan device matches `{w}`; devices: {}", describe(candidates)))?
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(name: &str, kind: vk::PhysicalDeviceType, ok: bool) -> Candidate {
        let mut uuid = [0u8; 16];
        for (i, b) in name.bytes().take(16).enumerate() {
            uuid[i] = b;
        }
        Candidate { name: name.into(), kind, uuid, unsupported: (!ok).then(|| "no Vulkan 1.3".into()) }
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
        assert!(!err.bad_choice, "an unusable device is no bad argument");
        let err = err.message;
        assert!(err.contains("no Vulkan 1.3"), "{err}");
        let err = select_device(&[cpu], Some("radeon")).unwrap_err();
        assert!(err.bad_choice);
        let err = err.message;
        assert!(err.contains("radeon") && err.contains("llvmpipe"), "{err}");
        assert!(select_device(&[], None).is_err());
    }

    #[test]
    fn identical_gpus_are_told_apart_by_index_and_uuid() {
        let mut a = c("NVIDIA H100", vk::PhysicalDeviceType::DISCRETE_GPU, true);
        let mut b = a.clone();
        a.uuid = [0x11; 16];
        b.uuid = [0xab; 16];
        b.uuid[15] = 0x01;
        let both = [a, b];
        assert_eq!(select_device(&both, Some("nvidia")), Ok(0));
        assert_eq!(select_device(&both, Some("#1")), Ok(1));
        assert_eq!(select_device(&both, Some(" #0 ")), Ok(0));
        assert_eq!(format_uuid(&both[1].uuid), "abababab-abab-abab-abab-ababababab01");
        // nvidia-smi's form, upper case, without dashes: all the same device.
        for text in [
            "uuid:abababab-abab-abab-abab-ababababab01",
            "UUID:GPU-ABABABAB-ABAB-ABAB-ABAB-ABABABABAB01",
            "uuid:ababababababababababababababab01",
        ] {
            assert_eq!(select_device(&both, Some(text)), Ok(1), "{text}");
        }
        let err = select_device(&both, Some("#2")).unwrap_err().message;
        assert!(
            err.contains("no Vulkan device #2") && err.contains("#0 NVIDIA H100") && err.contains("#1 NVIDIA H100"),
            "{err}"
        );
        assert!(err.contains("uuid:abababab-abab-abab-abab-ababababab01"), "{err}");
        let err = select_device(&both, Some("uuid:abababab-abab-abab-abab-ababababab02")).unwrap_err();
        assert!(err.bad_choice);
        let err = err.message;
        assert!(err.contains("no Vulkan device has uuid") && err.contains("#1"), "{err}");
        for bad in ["#x", "#-1", "uuid:1234", "uuid:zzababababababababababababab01", "ñvidiä"] {
            let err = select_device(&both, Some(bad)).unwrap_err().message;
            assert!(err.contains(bad) && err.contains("#0 NVIDIA"), "{bad}: {err}");
        }
    }
}
