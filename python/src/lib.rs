//! The `vkengine` Python module's native part (`vkengine._native`): volumes from numpy arrays
//! and files, transfer functions, the volume renderer with progressive and exact accumulation,
//! and EXR/PNG input and output. The pure-Python package around it adds distributed rendering.
#![warn(missing_docs)]

mod arrays;
mod devices;
mod errors;
mod image_io;
mod labels;
mod locked;
mod mesh;
mod renderer;
mod settings;
mod tf;
mod volume;

use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<volume::PyVolume>()?;
    m.add_class::<tf::PyTransferFunction>()?;
    m.add_class::<renderer::PyRenderer>()?;
    m.add_class::<mesh::PyMeshRenderer>()?;
    m.add_function(wrap_pyfunction!(image_io::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(image_io::write_image, m)?)?;
    m.add_function(wrap_pyfunction!(settings::setting_keys, m)?)?;
    m.add_function(wrap_pyfunction!(devices::devices, m)?)?;
    m.add_function(wrap_pyfunction!(errors::_panic_for_tests, m)?)?;
    // The CLI a test compares with bit for bit must share it: release builds optimize SPIR-V.
    m.add("BUILD_PROFILE", if cfg!(debug_assertions) { "debug" } else { "release" })?;
    m.add("ValidationError", m.py().get_type::<errors::ValidationError>())?;
    m.add("GpuError", m.py().get_type::<errors::GpuError>())?;
    Ok(())
}
