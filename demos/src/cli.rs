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
    /// Headless: frames (iterations) to render before writing the output (default 1; with an
    /// error target, the most frames, default 65536).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Volume demo, Monte Carlo, headless: stop once the image's estimated relative error
    /// (foreground) is at most this, e.g. 0.02 (`--set until_error=E`).
    #[arg(long, value_name = "E")]
    pub until_error: Option<String>,
    /// Output or window size, e.g. 512x512.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    pub size: [u32; 2],
    /// Headless: final image (.png tone-mapped sRGB).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write a JSON report (device, driver, settings, per-pass GPU/CPU ms).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Headless: write a profile folder (per-pass table with efficiency against the device's
    /// measured limits, every frame's samples for `profile compare`, Chrome trace, budget chart).
    #[arg(long)]
    pub profile: Option<PathBuf>,
    /// Headless: frames rendered before measuring (not in the report's statistics).
    #[arg(long, default_value_t = 0)]
    pub warmup: u64,
    /// Device limits report for `--profile` efficiency (from `device_limits`).
    #[arg(long, default_value = "results/device_limits/limits.json")]
    pub limits: PathBuf,
    /// Compare the result against this linear HDR image.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Renderer/variant name.
    #[arg(long)]
    pub renderer: Option<String>,
    /// Override a scene setting, `key=value` (repeatable).
    #[arg(long = "set", value_parser = parse_kv)]
    pub set: Vec<(String, String)>,
    /// Vulkan device: `#N` (index), `uuid:…` (deviceUUID; `GPU-…` from `nvidia-smi -L` on
    /// NVIDIA) or part of its name (default `VKENGINE_DEVICE`, else a discrete GPU first).
    #[arg(long)]
    pub device: Option<String>,
    /// Seeds the procedural volumes and the Monte Carlo random streams.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seconds any wait for the GPU may take before the run fails naming the frame and pass
    /// (default `VKENGINE_GPU_TIMEOUT`, else 60).
    #[arg(long, value_name = "SECONDS", value_parser = vkengine::vk::parse_gpu_timeout)]
    pub gpu_timeout: Option<std::time::Duration>,
    /// Enable the Khronos validation layer (default in debug builds).
    #[arg(long)]
    pub validation: bool,
    /// Volume demos: load `.mhd`/`.mha`, `.nrrd`/`.nhdr`, `.nii`/`.nii.gz`, `.vdb`, a DICOM file or
    /// folder, or raw (with `--dims`, `--type`).
    #[arg(long)]
    pub volume: Option<PathBuf>,
    /// Volume demo: a label map on the volume's grid (`--set labels=FILE`).
    #[arg(long, value_name = "FILE")]
    pub labels: Option<String>,
    /// DICOM: the SeriesInstanceUID to load when the folder holds several series.
    #[arg(long)]
    pub series: Option<String>,
    /// NIfTI: the volume (0-based) of a 4D file to load (default 0, with a warning).
    #[arg(long)]
    pub frame: Option<u32>,
    /// OpenVDB: the float grid to load (default `density`, or the only float grid).
    #[arg(long)]
    pub grid: Option<String>,
    /// Mesh demos: a scene description (`.toml`), or a bare `.gltf`/`.glb`/`.obj` model framed with a default camera and sun.
    /// Volume demo: a session file (`.toml`, what the window's "Save scene" writes).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Raw volumes: dimensions `X,Y,Z`.
    #[arg(long, value_parser = parse_dims)]
    pub dims: Option<[u32; 3]>,
    /// Raw volumes: voxel type (u8, u16, i16, f32, ...).
    #[arg(long = "type")]
    pub voxel_type: Option<String>,
    /// Raw volumes: `little` (default) or `big` endian.
    #[arg(long)]
    pub endian: Option<String>,
    /// Voxel spacing `X,Y,Z` (overrides the file's).
    #[arg(long, value_parser = parse_spacing)]
    pub spacing: Option<[f32; 3]>,
    /// Map negative voxels through the value range instead of rejecting them.
    #[arg(long)]
    pub allow_negative: bool,
    /// Window: replay UI input, `FRAME:ACTION;…` with actions `click=WIDGET`, `screenshot`,
    /// `capture=PATH` (window with UI, PNG), `save-scene`, `quit`.
    #[arg(long)]
    pub ui_script: Option<String>,
}

/// The frame cap of a run with an error target (`--until-error`) when `--frames` is not given.
pub const UNTIL_ERROR_FRAMES: u64 = 65536;

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

fn parse_triple<T: std::str::FromStr>(s: &str) -> Result<[T; 3], String> {
    let parts: Vec<&str> = s.split([',', 'x']).collect();
    if parts.len() != 3 {
        return Err(format!("`{s}`: expected three values X,Y,Z"));
    }
    let p = |v: &str| v.trim().parse::<T>().map_err(|_| format!("`{s}`: `{v}` is not a number"));
    Ok([p(parts[0])?, p(parts[1])?, p(parts[2])?])
}

fn parse_dims(s: &str) -> Result<[u32; 3], String> {
    let d = parse_triple::<u32>(s)?;
    if d.contains(&0) {
        return Err(format!("`{s}`: dimensions must be > 0"));
    }
    Ok(d)
}

fn parse_spacing(s: &str) -> Result<[f32; 3], String> {
    let d = parse_triple::<f32>(s)?;
    if d.iter().any(|v| !v.is_finite() || *v <= 0.0) {
        return Err(format!("`{s}`: spacing must be finite and > 0"));
    }
    Ok(d)
}

/// Looks up `--set key=value`, parsing the value; a bad value is an input error naming the key.
pub fn setting<T: std::str::FromStr>(sets: &[(String, String)], key: &str) -> vkengine::Result<Option<T>> {
    match sets.iter().rev().find(|(k, _)| k == key) {
        None => Ok(None),
        Some((_, v)) => {
            v.parse::<T>().map(Some).map_err(|_| vkengine::Error::Input(format!("--set {key}={v}: cannot parse `{v}`")))
        }
    }
}

/// Parses a `key=value` pair (`--set`).
pub fn parse_kv(s: &str) -> Result<(String, String), String> {
    s.split_once('=')
        .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        .ok_or_else(|| format!("`{s}`: expected key=value"))
}

impl DemoArgs {
    /// Headless: the frames to render (`--frames`, default 1; the volume demo's error target
    /// raises the default to [`UNTIL_ERROR_FRAMES`]).
    pub fn frames(&self) -> u64 {
        self.frames.unwrap_or(1)
    }

    /// Whether to open a window: forced by flags, otherwise when a display is present.
    pub fn windowed(&self) -> bool {
        if self.headless {
            return false;
        }
        self.window || std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some()
    }

    /// Context options from flags and environment.
    pub fn context_options(&self) -> vkengine::vk::ContextOptions {
        let mut o = vkengine::vk::ContextOptions::from_env();
        if self.validation {
            o.validation = vkengine::vk::Validation::Required;
        }
        if self.device.is_some() {
            o.device = self.device.clone();
        }
        if let Some(t) = self.gpu_timeout {
            o.gpu_timeout = t;
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
