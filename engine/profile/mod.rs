//! Performance profiling: per-pass reports with efficiency against the device's measured limits
//! ([`report`]; the roofs come from a `device_limits` report, see [`limits_roofs`] — the
//! micro-benchmarks that measure them live with the demos, in `vkengine_demos::limits`), and
//! run-to-run comparison that knows its own noise ([`compare`]).
//! `compare` uses `report`. Uses `crate::graph` (pass timings); used by the demos.

pub mod compare;
pub mod report;

use crate::error::{Error, Result};
use report::Roofs;

/// Roofs from a `device_limits` JSON report: the best bandwidth, the trilinear fetch rate and the
/// uncontended integer atomic rate. `None` if the report is from another device.
pub fn limits_roofs(v: &serde_json::Value, device: &str, source: &str) -> Result<Option<Roofs>> {
    let measured_on = v.pointer("/device/name").and_then(|n| n.as_str()).unwrap_or("");
    if measured_on != device {
        return Ok(None);
    }
    let rows = v
        .get("rows")
        .and_then(|r| r.as_array())
        .ok_or_else(|| Error::Input(format!("{source}: no `rows` in the device limits report")))?;
    let best = |pred: &dyn Fn(&str, &str) -> bool| -> f64 {
        rows.iter()
            .filter_map(|r| {
                let name = r.get("name")?.as_str()?;
                let unit = r.get("unit")?.as_str()?;
                let median = r.get("median")?.as_f64()?;
                pred(name, unit).then_some(median)
            })
            .fold(0.0, f64::max)
    };
    Ok(Some(Roofs {
        // Shaders cannot reach the copy engine's memcpy rate: the roof for a pass's bytes is the
        // best shader-side bandwidth (storage buffer or image, read or write).
        bytes_per_s: best(&|name, unit| unit == "GB/s" && !name.contains("copy")) * 1e9,
        fetches_per_s: best(&|name, unit| unit == "Gfetch/s" && name.contains("coherent")) * 1e9,
        atomics_per_s: best(&|name, unit| unit == "Gatomic/s" && name.contains("uint") && name.contains("uncontended"))
            * 1e9,
        source: format!("{source} ({measured_on})"),
    }))
}

/// Linear-interpolated percentile `q` in [0, 1] of ascending `sorted` (0 when empty).
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    match sorted.len() {
        0 => 0.0,
        1 => sorted[0],
        n => {
            let pos = q.clamp(0.0, 1.0) * (n - 1) as f64;
            let lo = pos.floor() as usize;
            let hi = (lo + 1).min(n - 1);
            sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
        }
    }
}
