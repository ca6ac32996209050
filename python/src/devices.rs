//! The machine's Vulkan devices (`vkengine.devices()`, for spreading workers over them) and the
//! device memory this process's live renderers hold, per device (their reports' figure, which
//! `close()` lowers at once).

use crate::errors;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Mutex, PoisonError};
use vkengine::vk::select::format_uuid;
use vkengine::vk::Context;

/// Every live renderer's device, by a registration number.
static LIVE: Mutex<Vec<(u64, Context)>> = Mutex::new(Vec::new());
static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Holds `ctx` in the registry until dropped (drop it before the last other handle of `ctx`,
/// or the registry keeps the device alive).
pub struct Registered(u64);

impl Registered {
    /// Registers `ctx`.
    pub fn new(ctx: &Context) -> Self {
        let id = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        LIVE.lock().unwrap_or_else(PoisonError::into_inner).push((id, ctx.clone()));
        Self(id)
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        LIVE.lock().unwrap_or_else(PoisonError::into_inner).retain(|(id, _)| *id != self.0);
    }
}

/// Bytes of device memory held by this process's live renderers on the device with `uuid`.
pub fn reserved_bytes(uuid: &str) -> u64 {
    let live = LIVE.lock().unwrap_or_else(PoisonError::into_inner);
    live.iter().filter(|(_, c)| c.info.uuid == uuid).map(|(_, c)| c.reserved_bytes()).sum()
}

/// The machine's Vulkan devices in the order `device="#N"` counts them: dicts with `index`,
/// `name`, `type`, `uuid` and `unsupported` (why the engine cannot use it, else `None`).
#[pyfunction]
pub fn devices<'py>(py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let list = py.detach(|| errors::guarded("devices", || vkengine::vk::list_devices().map_err(errors::engine)))?;
    list.iter()
        .enumerate()
        .map(|(i, c)| {
            let d = PyDict::new(py);
            d.set_item("index", i)?;
            d.set_item("name", &c.name)?;
            d.set_item("type", format!("{:?}", c.kind))?;
            d.set_item("uuid", format_uuid(&c.uuid))?;
            d.set_item("unsupported", c.unsupported.clone())?;
            Ok(d)
        })
        .collect()
}
