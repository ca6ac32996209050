//! numpy arrays in and out: any real integer or float dtype in either byte order, any strides,
//! read in logical (`[z, y, x]`) order into the engine's x-fastest layout; images back as numpy arrays that own
//! the Rust buffer (no copy).

use crate::errors::value;
use numpy::{
    Element, PyArray1, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// The values of a 3D array as f32 in x-fastest order, with dims `[x, y, z]` from shape
/// `(z, y, x)`. `what` names the argument in messages. Any real integer or float dtype
/// (float16 included) in either byte order, and any strides (negative, zero, Fortran order):
/// the values are read in logical order straight into the engine's one f32 copy, byte-swapped
/// on the way where the array is not in native order; only an unaligned array is copied first.
pub fn volume_values(a: &Bound<'_, PyUntypedArray>, what: &str) -> PyResult<([u32; 3], Vec<f32>)> {
    let shape = a.shape().to_vec();
    if shape.len() != 3 {
        return Err(value(format!("{what}: expected a 3D array indexed [z, y, x], got shape {shape:?}")));
    }
    if shape.contains(&0) {
        return Err(value(format!("{what}: shape {shape:?} has an empty axis; every axis needs at least one voxel")));
    }
    let dtype = a.dtype();
    let (kind, size) = (dtype.kind(), dtype.itemsize());
    if !matches!((kind, size), (b'u' | b'i', 1 | 2 | 4 | 8) | (b'f', 2 | 4 | 8)) {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{what}: dtype {dtype} is not supported; a volume takes real integer or float values (uint8..int64, float16..float64, either byte order)"
        )));
    }
    let swap = dtype.is_native_byteorder() == Some(false);
    // The same bytes as native unsigned integers of the same size (a view, no copy, whatever the
    // strides): one reader below decodes them by the original dtype.
    let bits = a.call_method1("view", (format!("=u{size}"),))?;
    // Arrays deserialized from a byte stream (pickle 5 frames, as Dask ships them) or made by
    // `np.frombuffer` at an odd offset may be unaligned, which a typed view cannot read: an
    // aligned copy, in the same memory order.
    let bits = aligned(&bits)?.cast_into::<PyUntypedArray>()?;
    let dims = [shape[2], shape[1], shape[0]].map(|d| u32::try_from(d).unwrap_or(u32::MAX));
    macro_rules! read {
        ($u:ty, $decode:expr) => {{
            let typed = bits.cast::<PyArrayDyn<$u>>()?;
            let ro = typed.try_readonly()?;
            let decode = $decode;
            // `iter` walks the logical (row-major) order whatever the strides are.
            ro.as_array().iter().map(|&x| decode(if swap { x.swap_bytes() } else { x })).collect::<Vec<f32>>()
        }};
    }
    let v = match (kind, size) {
        (b'u', 1) => read!(u8, |x: u8| x as f32),
        (b'i', 1) => read!(u8, |x: u8| x as i8 as f32),
        (b'u', 2) => read!(u16, |x: u16| x as f32),
        (b'i', 2) => read!(u16, |x: u16| x as i16 as f32),
        (b'f', 2) => read!(u16, |x: u16| half::f16::from_bits(x).to_f32()),
        (b'u', 4) => read!(u32, |x: u32| x as f32),
        (b'i', 4) => read!(u32, |x: u32| x as i32 as f32),
        (b'f', 4) => read!(u32, f32::from_bits),
        (b'u', 8) => read!(u64, |x: u64| x as f32),
        (b'i', 8) => read!(u64, |x: u64| x as i64 as f32),
        _ => read!(u64, |x: u64| f64::from_bits(x) as f32),
    };
    Ok((dims, v))
}

/// `obj` itself, or an aligned copy of it when it is a numpy array whose data is unaligned (from
/// Dask's pickle frames or `np.frombuffer` at an odd offset): typed views panic on those.
pub fn aligned<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if obj.is_instance_of::<PyUntypedArray>() && !obj.getattr("flags")?.getattr("aligned")?.extract::<bool>()? {
        return obj.call_method1("copy", ("K",));
    }
    Ok(obj.clone())
}

/// A numpy array of `shape` that owns `data` (no copy).
pub fn owned<'py, T: Element>(py: Python<'py>, data: Vec<T>, shape: &[usize]) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    PyArray1::from_vec(py, data).reshape(shape)
}

/// RGBA texels as a flat f32 vector (no copy).
pub fn flat_rgba(texels: Vec<[f32; 4]>) -> Vec<f32> {
    bytemuck::allocation::cast_vec(texels)
}
