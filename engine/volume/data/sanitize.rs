//! The sanitizing rules of the module docs, applied to decoded values in memory.

use super::VolumeError;

pub(crate) fn coord(dims: [u32; 3], i: usize) -> [u32; 3] {
    let (nx, ny) = (dims[0] as usize, dims[1] as usize);
    [(i % nx) as u32, ((i / nx) % ny) as u32, (i / (nx * ny)) as u32]
}

/// Applies the sanitizing rules from the module docs in place; returns warnings.
pub(crate) fn sanitize(
    file: &str,
    dims: [u32; 3],
    data: &mut [f32],
    allow_negative: bool,
) -> Result<Vec<String>, VolumeError> {
    let mut nan = (0u64, None::<usize>);
    let mut inf = (0u64, None::<usize>);
    let mut neg = (0u64, None::<usize>);
    let mut min_finite = f32::INFINITY;
    for (i, &v) in data.iter().enumerate() {
        if v.is_nan() {
            nan.0 += 1;
            nan.1.get_or_insert(i);
        } else if v.is_infinite() {
            inf.0 += 1;
            inf.1.get_or_insert(i);
        } else {
            min_finite = min_finite.min(v);
            if v < 0.0 {
                neg.0 += 1;
                neg.1.get_or_insert(i);
            }
        }
    }
    if let Some(i) = inf.1 {
        return Err(VolumeError::NonFinite {
            file: file.to_owned(),
            count: inf.0,
            value: data[i],
            first: coord(dims, i),
        });
    }
    if !allow_negative {
        if let Some(i) = neg.1 {
            return Err(VolumeError::Negative {
                file: file.to_owned(),
                count: neg.0,
                min: min_finite,
                first: coord(dims, i),
            });
        }
    }
    let mut warnings = Vec::new();
    if let Some(i) = nan.1 {
        if !min_finite.is_finite() {
            return Err(VolumeError::NonFinite {
                file: file.to_owned(),
                count: nan.0,
                value: f32::NAN,
                first: coord(dims, i),
            });
        }
        for v in data.iter_mut().filter(|v| v.is_nan()) {
            *v = min_finite;
        }
        let [x, y, z] = coord(dims, i);
        warnings.push(format!(
            "{file}: {} NaN voxel(s) replaced by the minimum finite value {min_finite}, first at ({x}, {y}, {z})",
            nan.0
        ));
    }
    Ok(warnings)
}
