//! `vkengine.TransferFunction`: presets, JSON (text or file) and arrays of control points.

use crate::errors;
use numpy::{PyArrayDescrMethods, PyReadonlyArrayDyn, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::path::Path;
use vkengine::volume::optics::tf::{TfPoint, TransferFunction};

/// A transfer function: normalized value (× gradient magnitude) → colour and extinction.
#[pyclass(name = "TransferFunction", module = "vkengine", frozen)]
#[derive(Clone)]
pub struct PyTransferFunction {
    pub(crate) inner: TransferFunction,
}

fn checked(tf: TransferFunction, what: &str) -> PyResult<PyTransferFunction> {
    tf.validate().map_err(|e| errors::value(format!("{what}: {e}")))?;
    Ok(PyTransferFunction { inner: tf })
}

#[pymethods]
impl PyTransferFunction {
    /// A built-in preset: `default`, `cloud`, `bone`, `edges`.
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Self> {
        checked(TransferFunction::preset(name).map_err(errors::engine)?, name)
    }

    /// From JSON text (`{"points": [...]}` or `{"boxes": [...]}`) or a `.json` file path.
    #[staticmethod]
    fn from_json(text_or_path: &str) -> PyResult<Self> {
        if text_or_path.trim_start().starts_with('{') {
            let tf: TransferFunction = serde_json::from_str(text_or_path)
                .map_err(|e| errors::value(format!("transfer function JSON: {e}")))?;
            checked(tf, "transfer function JSON")
        } else {
            let tf = TransferFunction::load(Path::new(text_or_path)).map_err(errors::engine)?;
            checked(tf, text_or_path)
        }
    }

    /// From `(N, 5)` control points `value, r, g, b, extinction` (value in [0, 1], increasing;
    /// extinction per unit length of the volume's largest axis): any real numpy array or a
    /// list of rows.
    #[staticmethod]
    fn from_points(py: Python<'_>, points: &Bound<'_, PyAny>) -> PyResult<Self> {
        const EXPECTED: &str = "points: expected (N, 5) real numbers (value, r, g, b, extinction)";
        if let Ok(a) = points.cast::<PyUntypedArray>() {
            if !matches!(a.dtype().kind(), b'u' | b'i' | b'f') {
                return Err(errors::value(format!("{EXPECTED}, got dtype {}", a.dtype())));
            }
        }
        let points = py
            .import("numpy")?
            .call_method1("asarray", (points, "float64"))
            .map_err(|e| errors::value(format!("{EXPECTED}: {e}")))?;
        let points = crate::arrays::aligned(&points)?;
        let points: PyReadonlyArrayDyn<'_, f64> = points.extract().map_err(|_| errors::value(EXPECTED))?;
        let shape = points.shape().to_vec();
        if shape.len() != 2 || shape[1] != 5 || shape[0] < 2 {
            return Err(errors::value(format!(
                "points: expected shape (N, 5) with N >= 2 (value, r, g, b, extinction), got {shape:?}"
            )));
        }
        let flat: Vec<f64> = points.as_array().iter().copied().collect();
        let pts = flat
            .chunks_exact(5)
            .map(|r| TfPoint {
                value: r[0] as f32,
                color: [r[1] as f32, r[2] as f32, r[3] as f32],
                extinction: r[4] as f32,
            })
            .collect();
        checked(TransferFunction::OneD { points: pts }, "points")
    }

    /// The function as JSON (what `from_json` and the CLI's `--set tf=FILE.json` read).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner).map_err(|e| errors::value(e.to_string()))
    }

    /// Pickles as its JSON (`from_json` rebuilds it).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let from_json = py.get_type::<Self>().getattr("from_json")?;
        Ok((from_json, (self.to_json()?,)))
    }

    fn __repr__(&self) -> String {
        match &self.inner {
            TransferFunction::OneD { points } => format!("TransferFunction({} points)", points.len()),
            TransferFunction::TwoD { boxes } => format!("TransferFunction({} boxes)", boxes.len()),
        }
    }
}
