//! Writing what a demo produced: PNG images and JSON reports.

use std::path::Path;
use vkengine::{Error, Result};

/// Writes tightly packed RGBA8 pixels as a PNG, creating parent folders.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
    }
    image::save_buffer(path, rgba, width, height, image::ExtendedColorType::Rgba8)
        .map_err(|e| Error::Input(format!("{}: cannot write PNG: {e}", path.display())))
}

/// Writes linear RGBA f32 pixels as OpenEXR (references stay in linear HDR).
pub fn write_exr(path: &Path, width: u32, height: u32, rgba: &[[f32; 4]]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
    }
    let flat: Vec<f32> = rgba.iter().flatten().copied().collect();
    let img = image::Rgba32FImage::from_raw(width, height, flat)
        .ok_or_else(|| Error::Input(format!("{}: pixel count does not match {width}x{height}", path.display())))?;
    img.save(path).map_err(|e| Error::Input(format!("{}: cannot write EXR: {e}", path.display())))
}

/// Writes a serializable value as pretty JSON, creating parent folders.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
    }
    let text = serde_json::to_string_pretty(value).map_err(|e| Error::Input(format!("{}: {e}", path.display())))?;
    std::fs::write(path, text).map_err(|source| Error::Io { path: path.display().to_string(), source })
}

pub use vkengine::profile::report::DeviceReport;
