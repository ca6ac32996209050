//! The command line every demo shares (`../shared/CONVENTIONS.md`).

use clap::Parser;
use std::path::PathBuf;

/// Common demo flags.
#[derive(Parser, Debug, Clone)]
#[command(version, about)]
pub struct DemoArgs {
    /// Force headless rendering (default when no display is available).
    #[arg(long, conflicts_with = "window")]
    pub headless: bool,
    /// Force a window.
    #[arg(long)]
    pub window: bool,
    /// Headless: frames (iterations) to render before writing the output.
    #[arg(long, default_value_t = 1)]
    pub frames: u64,
    /// Output or window size, e.g. 512x512.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    pub size: [u32; 2],
    /// Headless: final image (.png tone-mapped sRGB).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write a JSON report (device, driver, settings, per-pass GPU/CPU ms).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write a Chrome trace JSON of the frame graph's passes.
    #[arg(long)]
    pub profile: Option<PathBuf>,
    /// Compare the result against this linear HDR image.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Renderer/variant name.
    #[arg(long)]
    pub renderer: Option<String>,
    /// Override a scene setting, `key=value` (repeatable).
    #[arg(long = "set", value_parser = parse_kv)]
    pub set: Vec<(String, String)>,
    /// Pick a Vulkan device by (part of) its name; default prefers a discrete GPU.
    #[arg(long)]
    pub device: Option<String>,
    /// Deterministic random sequence.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Enable the Khronos validation layer (default in debug builds).
    #[arg(long)]
    pub validation: bool,
}

/// Parses `WxH` with both sides in 1..=16384.
pub fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}`: expected WxH, e.g. 512x512"))?;
    let p = |v: &str| v.trim().parse::<u32>().map_err(|_| format!("`{s}`: `{v}` is not a positive integer"));
    let (w, h) = (p(w)?, p(h)?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("`{s}`: each side must be in 1..=16384"));
    }
    Ok([w, h])
}

fn parse_kv(s: &str) -> Result<(String, String), String> {
    s.split_once('=')
        .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        .ok_or_else(|| format!("`{s}`: expected key=value"))
}

impl DemoArgs {
    /// Whether to open a window: forced by flags, otherwise when a display is present.
    pub fn windowed(&self) -> bool {
        if self.headless {
            return false;
        }
        self.window || std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some()
    }

    /// Context options from flags and environment.
    pub fn context_options(&self) -> crate::vk::ContextOptions {
        let mut o = crate::vk::ContextOptions::from_env();
        if self.validation {
            o.validation = crate::vk::Validation::Required;
        }
        if self.device.is_some() {
            o.device = self.device.clone();
        }
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_parsing_rejects_nonsense() {
        assert_eq!(parse_size("640x480"), Ok([640, 480]));
        for bad in ["640", "0x10", "10x", "axb", "99999x2", "-1x5"] {
            assert!(parse_size(bad).is_err(), "{bad} accepted");
        }
    }
}
