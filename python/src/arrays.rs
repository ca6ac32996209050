//! numpy arrays in and out: any integer or float dtype, C or Fortran order, read in logical
//! (`[z, y, x]`) order into the engine's x-fastest layout; images back as numpy arrays that own
//! the Rust buffer (no copy).

use crate::errors::value;
use numpy::{
    Element, PyArray1, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

/// The values of a 3D array as f32 in x-fastest order, with dims `[x, y, z]` from shape
/// `(z, y, x)`. `what` names the argument in messages.
pub fn volume_values(a: &Bound<'_, PyUntypedArray>, what: &str) -> PyResult<([u32; 3], Vec<f32>)> {
    let shape = a.shape().to_vec();
    if shape.len() != 3 {
        return Err(value(format!("{what}: expected a 3D array indexed [z, y, x], got shape {shape:?}")));
    }
    if shape.contains(&0) {
        return Err(value(format!("{what}: shape {shape:?} has an empty axis; every axis needs at least one voxel")));
    }
    if !(a.is_c_contiguous() || a.is_fortran_contiguous()) {
        // A strided view would be read element by element through Python's buffer rules; the
        // copy the caller makes instead is explicit and just as fast.
        return Err(value(format!(
            "{what}: a non-contiguous view (strides {:?}); pass np.ascontiguousarray(a)",
            strides(a)
        )));
    }
    // Arrays deserialized from a byte stream (pickle 5 frames, as Dask ships them) or made by
    // `np.frombuffer` at an odd offset may be unaligned, which a typed view cannot read: an
    // aligned copy, in the same memory order.
    let aligned_copy;
    let a = if a.getattr("flags")?.getattr("aligned")?.extract::<bool>()? {
        a
    } else {
        aligned_copy = a.call_method1("copy", ("K",))?.cast_into::<PyUntypedArray>()?;
        &aligned_copy
    };
    let dims = [shape[2], shape[1], shape[0]].map(|d| u32::try_from(d).unwrap_or(u32::MAX));
    macro_rules! by_type {
        ($($t:ty),*) => {
            $(if a.dtype().is_equiv_to(&numpy::dtype::<$t>(a.py())) {
                let typed = a.cast::<PyArrayDyn<$t>>()?;
                let ro = typed.try_readonly()?;
                // `iter` walks the logical (row-major) order whatever the memory order is.
                let v: Vec<f32> = ro.as_array().iter().map(|&x| x as f32).collect();
                return Ok((dims, v));
            })*
        };
    }
    by_type!(u8, i8, u16, i16, u32, i32, u64, i64, f32, f64);
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "{what}: dtype {} is not supported; use an integer or float dtype (uint8..int64, float16..float64)",
        a.dtype()
    )))
}

fn strides(a: &Bound<'_, PyUntypedArray>) -> Vec<isize> {
    a.strides().to_vec()
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
