//! `labels=` and `label_colors=` as Python objects: a numpy integer array on the scan's grid and
//! colours as a dict (a path still goes through the CLI's `labels=`/`label_colors=` settings).

use crate::{arrays, errors};
use numpy::{PyArrayDescrMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use vkengine::volume::data::labels::{LabelVolume, MAX_LABEL};
use vkengine::volume::data::Volume;
use vkengine::volume::optics::label_table::{self, LabelTable};

/// The label keywords taken out of the settings: ids in x-fastest order with their dims, and a
/// colour table as JSON text.
#[derive(Default)]
pub struct LabelArgs {
    array: Option<([u32; 3], Vec<u8>)>,
    colors: Option<String>,
}

impl LabelArgs {
    /// Takes `labels` (when it is not a path) and `label_colors` (when it is a dict) out of `kw`.
    pub fn take(kw: &Bound<'_, PyDict>) -> PyResult<Self> {
        let mut out = Self::default();
        if let Some(v) = kw.get_item("labels")?.filter(|v| !v.is_none() && !v.is_instance_of::<PyString>()) {
            let a = v
                .cast::<PyUntypedArray>()
                .map_err(|_| errors::value("labels: expected a path or a 3D numpy integer array indexed [z, y, x]"))?;
            let dtype = a.dtype();
            if !matches!(dtype.kind(), b'u' | b'i') {
                return Err(errors::value(format!(
                    "labels: dtype {dtype} is not an integer type; a label map holds ids 0..={MAX_LABEL}"
                )));
            }
            let (dims, ids) = arrays::volume_values(a, "labels")?;
            if let Some(i) = ids.iter().position(|x| !(0.0..=MAX_LABEL as f32).contains(x)) {
                let [nx, ny, _] = dims.map(|d| d as usize);
                let at = [i / (nx * ny), i / nx % ny, i % nx];
                return Err(errors::value(format!(
                    "labels: voxel [z, y, x] = {at:?} holds id {}; ids must be in 0..={MAX_LABEL}",
                    ids[i]
                )));
            }
            out.array = Some((dims, ids.into_iter().map(|x| x as u8).collect()));
            kw.del_item("labels")?;
        }
        if let Some(v) = kw.get_item("label_colors")?.filter(|v| v.is_instance_of::<PyDict>()) {
            // `{label: {...}}` or the JSON file's own `{"labels": {label: {...}}}`.
            let table = if v.cast::<PyDict>()?.contains("labels")? {
                v
            } else {
                let d = PyDict::new(kw.py());
                d.set_item("labels", v)?;
                d.into_any()
            };
            let json = kw
                .py()
                .import("json")?
                .call_method1("dumps", (table,))
                .map_err(|e| errors::value(format!("label_colors: the dict is not JSON ({e})")))?;
            out.colors = Some(json.extract()?);
            kw.del_item("label_colors")?;
        }
        Ok(out)
    }

    /// Whether the caller gave a label array (the settings then name no label file).
    pub fn has_array(&self) -> bool {
        self.array.is_some()
    }

    /// The label map and table for `scan`: the array's (refused unless on the scan's grid), else
    /// `from_file`'s; the dict's colours over either. `colors_file`: `label_colors=PATH`.
    pub fn resolve(
        self,
        scan: &Volume,
        colors_file: Option<&str>,
        from_file: Option<(LabelVolume, LabelTable)>,
    ) -> PyResult<Option<(LabelVolume, LabelTable)>> {
        let found = match self.array {
            Some((dims, ids)) => {
                if dims != scan.dims {
                    let [x, y, z] = dims;
                    let [sx, sy, sz] = scan.dims;
                    return Err(errors::value(format!(
                        "labels: shape ({z}, {y}, {x}) does not match the scan's grid ({sz}, {sy}, {sx}) [z, y, x]"
                    )));
                }
                let labels = LabelVolume {
                    dims,
                    spacing: scan.spacing,
                    labels: ids,
                    source: "labels array".into(),
                    segments: Vec::new(),
                    patient_axes: scan.patient_axes,
                    directions: None,
                };
                let table =
                    LabelTable::with_colors(&labels, colors_file.map(std::path::Path::new)).map_err(errors::engine)?;
                Some((labels, table))
            }
            None => from_file,
        };
        match (found, self.colors) {
            (Some((labels, mut table)), Some(json)) => {
                let present = label_table::present(&labels);
                table
                    .apply_json_text(&json, Some(&present))
                    .map_err(|e| errors::value(format!("label_colors: {e}")))?;
                Ok(Some((labels, table)))
            }
            (None, Some(_)) => Err(errors::value("label_colors: no label map is given (labels=)")),
            (found, None) => Ok(found),
        }
    }
}
