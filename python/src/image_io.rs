//! Images in and out: EXR (linear HDR, what the CLI's `--out x.exr` writes) and PNG, through the
//! demos' own writers so a file from Python is the CLI's byte for byte.

use crate::{arrays, errors};
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::path::PathBuf;

/// Reads an image file (EXR, HDR, PNG, ...) as float32 RGBA, shape `(height, width, 4)`.
#[pyfunction]
pub fn read_image<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    if !path.exists() {
        return Err(pyo3::exceptions::PyFileNotFoundError::new_err(format!("{}: no such file", path.display())));
    }
    let img = errors::guarded("read_image", || {
        image::open(&path).map_err(|e| errors::value(format!("{}: cannot read image: {e}", path.display())))
    })?;
    let rgba = img.into_rgba32f();
    let (w, h) = (rgba.width() as usize, rgba.height() as usize);
    arrays::owned(py, rgba.into_raw(), &[h, w, 4])
}

fn rgba_shape(shape: &[usize], what: &str) -> PyResult<[u32; 2]> {
    match shape {
        [h, w, 4] if *h > 0 && *w > 0 => Ok([*w as u32, *h as u32]),
        _ => Err(errors::value(format!("{what}: expected an RGBA image of shape (height, width, 4), got {shape:?}"))),
    }
}

/// Writes float32 `(h, w, 4)` linear RGBA as EXR, or uint8 `(h, w, 4)` sRGB as PNG (by the
/// path's extension).
#[pyfunction]
pub fn write_image(path: PathBuf, image: &Bound<'_, PyAny>) -> PyResult<()> {
    let image = &arrays::aligned(image)?;
    let exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let what = path.display().to_string();
    if exr {
        let a: PyReadonlyArrayDyn<'_, f32> =
            image.extract().map_err(|_| errors::value(format!("{what}: an EXR is written from a float32 array")))?;
        let [w, h] = rgba_shape(a.shape(), &what)?;
        let texels: Vec<[f32; 4]> = a
            .as_array()
            .iter()
            .copied()
            .collect::<Vec<f32>>()
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect();
        errors::guarded("write_image", || {
            vkengine_demos::output::write_exr(&path, w, h, &texels).map_err(errors::engine)
        })
    } else {
        let a: PyReadonlyArrayDyn<'_, u8> =
            image.extract().map_err(|_| errors::value(format!("{what}: a PNG is written from a uint8 array")))?;
        let [w, h] = rgba_shape(a.shape(), &what)?;
        let bytes: Vec<u8> = a.as_array().iter().copied().collect();
        errors::guarded("write_image", || {
            vkengine_demos::output::write_png(&path, w, h, &bytes).map_err(errors::engine)
        })
    }
}

/// A renderer's frame read back with the GIL released, as float32 `(height, width, 4)`.
pub fn frame_hdr<'py>(
    py: Python<'py>,
    [w, h]: [u32; 2],
    read: impl FnOnce() -> vkengine::Result<Vec<[f32; 4]>> + Send,
) -> PyResult<Bound<'py, PyArrayDyn<f32>>> {
    let hdr = py.detach(|| errors::guarded("image", || read().map_err(errors::engine)))?;
    arrays::owned(py, arrays::flat_rgba(hdr), &[h as usize, w as usize, 4])
}

/// A renderer's tone-mapped frame read back with the GIL released, as uint8 `(height, width, 4)`.
pub fn frame_srgb<'py>(
    py: Python<'py>,
    [w, h]: [u32; 2],
    read: impl FnOnce() -> vkengine::Result<Vec<u8>> + Send,
) -> PyResult<Bound<'py, PyArrayDyn<u8>>> {
    let ldr = py.detach(|| errors::guarded("image_srgb", || read().map_err(errors::engine)))?;
    arrays::owned(py, ldr, &[h as usize, w as usize, 4])
}

/// Writes a renderer's frame as the CLI's `--out` does: `.exr` linear HDR, else PNG (sRGB).
pub fn save_frame(
    py: Python<'_>,
    path: PathBuf,
    [w, h]: [u32; 2],
    hdr: impl FnOnce() -> vkengine::Result<Vec<[f32; 4]>> + Send,
    ldr: impl FnOnce() -> vkengine::Result<Vec<u8>> + Send,
) -> PyResult<()> {
    let exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    py.detach(|| {
        errors::guarded("save", || {
            if exr {
                vkengine_demos::output::write_exr(&path, w, h, &hdr().map_err(errors::engine)?).map_err(errors::engine)
            } else {
                vkengine_demos::output::write_png(&path, w, h, &ldr().map_err(errors::engine)?).map_err(errors::engine)
            }
        })
    })
}

/// sRGB RGBA8 pixels as PNG bytes (what `_repr_png_` gives Jupyter).
pub fn png_bytes(w: u32, h: u32, rgba: &[u8]) -> PyResult<Vec<u8>> {
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        rgba,
        w,
        h,
        image::ExtendedColorType::Rgba8,
    )
    .map_err(|e| errors::value(format!("PNG encoding: {e}")))?;
    Ok(png)
}
