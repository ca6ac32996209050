//! Engine errors as Python exceptions, and the guard that keeps a Rust panic from crossing into
//! the interpreter.

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyTimeoutError, PyValueError};
use pyo3::PyErr;
use vkengine::volume::data::VolumeError;
use vkengine::Error;

pyo3::create_exception!(
    _native,
    ValidationError,
    PyRuntimeError,
    "The Vulkan validation layer reported messages during a render (printed on stderr)."
);
pyo3::create_exception!(
    _native,
    GpuError,
    PyRuntimeError,
    "The device failed: no Vulkan device, a lost device, an allocation or a frame-graph failure."
);

/// An engine error as the Python exception a caller would catch: bad input is `ValueError`, a
/// file that cannot be read `FileNotFoundError`/`OSError`, the GPU's own failures `GpuError`.
pub fn engine(e: Error) -> PyErr {
    let text = e.to_string();
    match e {
        Error::Input(_) => PyValueError::new_err(text),
        Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(text),
        Error::Io { .. } => PyOSError::new_err(text),
        Error::GpuTimeout { .. } => PyTimeoutError::new_err(text),
        Error::Validation(_) => ValidationError::new_err(text),
        _ => GpuError::new_err(text),
    }
}

/// A loader's error: the message starts with the file.
pub fn volume(e: VolumeError) -> PyErr {
    let text = e.to_string();
    match e {
        VolumeError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(text)
        }
        VolumeError::Io { .. } => PyOSError::new_err(text),
        _ => PyValueError::new_err(text),
    }
}

/// A `ValueError` with this message.
pub fn value(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// Runs `f`, turning a panic into a `RuntimeError` instead of unwinding through the interpreter
/// (pyo3 would raise its `PanicException`, a `BaseException` that `except Exception` misses).
pub fn guarded<T>(what: &str, f: impl FnOnce() -> Result<T, PyErr>) -> Result<T, PyErr> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)");
            Err(PyRuntimeError::new_err(format!("{what}: internal error (a bug in vkengine, please report): {msg}")))
        }
    }
}

/// Test hook: panics inside [`guarded`], so the tests can see a Rust panic arrive as
/// `RuntimeError` with the interpreter still running.
#[pyo3::pyfunction]
pub fn _panic_for_tests(message: String) -> pyo3::PyResult<()> {
    guarded("_panic_for_tests", || panic!("{message}"))
}

/// `ValidationError` if the validation layer reported messages since `seen` (which it advances):
/// a render that broke a Vulkan rule fails in Python as it fails a test.
pub fn check_validation(ctx: &vkengine::vk::Context, seen: &mut usize) -> pyo3::PyResult<()> {
    let n = ctx.validation_messages().len();
    if n > *seen {
        let new = n - *seen;
        *seen = n;
        return Err(ValidationError::new_err(format!(
            "the validation layer reported {new} message(s) (printed on stderr)"
        )));
    }
    Ok(())
}
