//! Image error metrics on linear HDR values (RGB; alpha ignored): RMSE, relative MSE, PSNR.

use crate::error::{Error, Result};
use std::path::Path;

/// Error of an image against a reference.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ImageError {
    /// Root-mean-square error over all RGB values.
    pub rmse: f64,
    /// Mean of (x - r)² / (r² + ε) with ε = 1e-2: scale-independent in bright and dark regions.
    pub rel_mse: f64,
    /// 10·log10(peak² / MSE) with the reference's peak value.
    pub psnr_db: f64,
}

/// Compares two equally sized RGBA images.
pub fn compare(image: &[[f32; 4]], reference: &[[f32; 4]]) -> Result<ImageError> {
    if image.len() != reference.len() || image.is_empty() {
        return Err(Error::Input(format!(
            "reference has {} pixels, image has {}: sizes must match",
            reference.len(),
            image.len()
        )));
    }
    let (mut se, mut rel, mut peak) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in image.iter().zip(reference) {
        for c in 0..3 {
            let (x, r) = (a[c] as f64, b[c] as f64);
            let d = x - r;
            se += d * d;
            rel += d * d / (r * r + 1e-2);
            peak = peak.max(r.abs());
        }
    }
    let n = (image.len() * 3) as f64;
    let mse = se / n;
    let psnr_db = if mse > 0.0 { 10.0 * (peak.max(1e-12).powi(2) / mse).log10() } else { f64::INFINITY };
    Ok(ImageError { rmse: mse.sqrt(), rel_mse: rel / n, psnr_db })
}

/// Loads a linear HDR reference (EXR) and checks its size.
pub fn load_reference(path: &Path, size: [u32; 2]) -> Result<Vec<[f32; 4]>> {
    let img = image::open(path).map_err(|e| Error::Input(format!("{}: cannot read reference: {e}", path.display())))?;
    let img = img.to_rgba32f();
    if img.dimensions() != (size[0], size[1]) {
        return Err(Error::Input(format!(
            "{}: reference is {}x{}, the render is {}x{}",
            path.display(),
            img.width(),
            img.height(),
            size[0],
            size[1]
        )));
    }
    Ok(img.pixels().map(|p| p.0).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_of_known_differences() {
        let r = vec![[1.0, 1.0, 1.0, 1.0]; 4];
        let same = compare(&r, &r).expect("same size");
        assert_eq!(same.rmse, 0.0);
        assert!(same.psnr_db.is_infinite());
        let off = vec![[1.1, 1.1, 1.1, 0.0]; 4];
        let e = compare(&off, &r).expect("same size");
        assert!((e.rmse - 0.1).abs() < 1e-6);
        assert!((e.psnr_db - 20.0).abs() < 1e-4);
        assert!(compare(&off[..3], &r).is_err());
    }
}
