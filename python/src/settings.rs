//! Python keyword arguments as the CLI's `--set key=value` pairs, parsed by the CLI's own
//! command line so that every key, range and message is the `volume` program's.

use crate::errors;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use vkengine::volume::render::settings::SCHEMA;
use vkengine_demos::cli::DemoArgs;

/// A keyword's value as the text `--set` takes: booleans `true`/`false`, numbers as Python
/// prints them, sequences as `X,Y,Z`.
fn text(key: &str, v: &Bound<'_, PyAny>) -> PyResult<String> {
    if v.is_instance_of::<PyBool>() {
        return Ok(if v.extract::<bool>()? { "true" } else { "false" }.into());
    }
    if v.is_instance_of::<PyString>() || v.is_instance_of::<PyInt>() || v.is_instance_of::<PyFloat>() {
        return Ok(v.str()?.to_string());
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let parts: PyResult<Vec<String>> = v.try_iter()?.map(|x| text(key, &x?)).collect();
        return Ok(parts?.join(","));
    }
    // numpy scalars and other numbers print like Python's own.
    if v.hasattr("__float__")? {
        return Ok(v.call_method0("__float__")?.str()?.to_string());
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "{key}={}: expected a bool, number, string or sequence of numbers",
        v.repr()?
    )))
}

/// The `--set` pairs of `kwargs` (`None` values are left at their defaults), in the given order.
pub fn pairs(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, String)>> {
    let mut out = Vec::new();
    if let Some(kw) = kwargs {
        for (k, v) in kw.iter() {
            let key: String = k.extract()?;
            if v.is_none() {
                continue;
            }
            let t = text(&key, &v)?;
            out.push((key, t));
        }
    }
    Ok(out)
}

/// The CLI's parsed arguments for a headless run with these settings, size, seed and scene
/// file; a malformed `--set` or size is `ValueError` with clap's message.
pub fn cli_args(sets: &[(String, String)], size: [u32; 2], seed: u64, scene: Option<&str>) -> PyResult<DemoArgs> {
    let [w, h] = size;
    vkengine_demos::cli::parse_size(&format!("{w}x{h}")).map_err(|e| errors::value(format!("size={size:?}: {e}")))?;
    let mut argv: Vec<String> = vec![
        "volume".into(),
        "--headless".into(),
        "--size".into(),
        format!("{w}x{h}"),
        "--seed".into(),
        seed.to_string(),
    ];
    if let Some(path) = scene {
        argv.push("--scene".into());
        argv.push(path.into());
    }
    for (k, v) in sets {
        argv.push("--set".into());
        argv.push(format!("{k}={v}"));
    }
    // `try_parse_from`: clap's `parse_from` would exit the interpreter on a bad value.
    <DemoArgs as clap::Parser>::try_parse_from(&argv).map_err(|e| errors::value(e.to_string().trim().to_string()))
}

/// [`cli_args`] for the volume renderer, checked by its schema (unknown keys, ranges) with the
/// CLI's messages.
pub fn demo_args(sets: &[(String, String)], size: [u32; 2], seed: u64) -> PyResult<DemoArgs> {
    let args = cli_args(sets, size, seed, None)?;
    vkengine_demos::volume_scene::volume_setup(&args).map_err(errors::engine)?;
    Ok(args)
}

/// Every key `Renderer` (or, with `mesh=True`, `MeshRenderer`) accepts: `(key, type,
/// description)` in schema order.
#[pyfunction]
#[pyo3(signature = (mesh=false))]
pub fn setting_keys(mesh: bool) -> Vec<(String, String, String)> {
    match mesh {
        false => SCHEMA.keys().map(|k| (k.key.to_string(), k.type_name(), k.doc.to_string())).collect(),
        true => vkengine::mesh::settings::SCHEMA
            .keys()
            .map(|k| (k.key.to_string(), k.type_name(), k.doc.to_string()))
            .collect(),
    }
}
