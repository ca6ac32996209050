//! How a context is made: validation, device choice, GPU timeout; from the environment or set
//! by the caller.

use std::time::Duration;

/// Whether to load the Khronos validation layer (with synchronization validation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validation {
    /// Never load it.
    Off,
    /// Load it if installed, otherwise warn and continue.
    IfAvailable,
    /// Fail context creation if it is not installed.
    Required,
}

/// How to create a [`Context`].
#[derive(Clone, Debug)]
pub struct ContextOptions {
    /// Validation layer policy.
    pub validation: Validation,
    /// The device to use: `#N` (index), `uuid:…` (`deviceUUID`) or part of its name
    /// (case-insensitive); `None` prefers a discrete GPU.
    pub device: Option<String>,
    /// Display to present to; `None` for headless (no surface extensions).
    pub display: Option<raw_window_handle::RawDisplayHandle>,
    /// How long any wait for the GPU may take before it is an error ([`Error::GpuTimeout`]):
    /// a runaway dispatch or a hung device must end the run, not hang it.
    pub gpu_timeout: Duration,
    /// Caps the largest allocation the engine plans for below the device's
    /// `maxMemoryAllocationSize` (`VKENGINE_MAX_ALLOCATION`, bytes): leaves room for other
    /// users of the device, and lets a test exercise what large volumes do on a small one.
    pub max_allocation: Option<u64>,
    /// Forces sparse volumes' page tables to 1 (flat) or 2 (directory and pool) levels
    /// (`VKENGINE_PAGE_LEVELS`); `None` chooses by size (`volume::page_images`). For tests and
    /// measurements: both forms give the same images.
    pub page_levels: Option<u32>,
}

/// The GPU timeout when neither `VKENGINE_GPU_TIMEOUT` nor `--gpu-timeout` says otherwise:
/// generous, because a legitimately heavy frame on a CPU rasterizer takes seconds.
pub const DEFAULT_GPU_TIMEOUT: Duration = Duration::from_secs(60);

/// Parses a GPU timeout in seconds (`VKENGINE_GPU_TIMEOUT`, `--gpu-timeout`): finite and > 0.
pub fn parse_gpu_timeout(s: &str) -> std::result::Result<Duration, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e9 => Ok(Duration::from_secs_f64(v)),
        _ => Err(format!("`{s}`: the GPU timeout is a number of seconds, > 0 (e.g. 60 or 0.5)")),
    }
}

impl Default for ContextOptions {
    fn default() -> Self {
        Self::from_env()
    }
}

impl ContextOptions {
    /// Defaults from the build profile and environment: validation on in debug builds or with
    /// `VKENGINE_VALIDATION=1` (`required` makes it mandatory, `0` disables); device from `VKENGINE_DEVICE`.
    pub fn from_env() -> Self {
        let validation = match std::env::var("VKENGINE_VALIDATION").as_deref() {
            Ok("0") | Ok("off") => Validation::Off,
            Ok("required") => Validation::Required,
            Ok(_) => Validation::IfAvailable,
            Err(_) if cfg!(debug_assertions) => Validation::IfAvailable,
            Err(_) => Validation::Off,
        };
        let device = std::env::var("VKENGINE_DEVICE").ok().filter(|s| !s.is_empty());
        let gpu_timeout = match std::env::var("VKENGINE_GPU_TIMEOUT") {
            Ok(v) if !v.is_empty() => parse_gpu_timeout(&v).unwrap_or_else(|e| {
                // from_env cannot fail; a typo must not silently become an infinite wait either.
                eprintln!("warning: VKENGINE_GPU_TIMEOUT {e}; using {} s", DEFAULT_GPU_TIMEOUT.as_secs());
                DEFAULT_GPU_TIMEOUT
            }),
            _ => DEFAULT_GPU_TIMEOUT,
        };
        let max_allocation =
            std::env::var("VKENGINE_MAX_ALLOCATION").ok().and_then(|v| match v.trim().parse::<u64>() {
                Ok(n) if n > 0 => Some(n),
                _ => {
                    eprintln!("warning: VKENGINE_MAX_ALLOCATION `{v}` is not a number of bytes > 0; ignored");
                    None
                }
            });
        let page_levels = std::env::var("VKENGINE_PAGE_LEVELS").ok().and_then(|v| match v.trim() {
            "1" => Some(1),
            "2" => Some(2),
            _ => {
                eprintln!("warning: VKENGINE_PAGE_LEVELS `{v}` is not 1 or 2; ignored");
                None
            }
        });
        Self { validation, device, display: None, gpu_timeout, max_allocation, page_levels }
    }
}
