//! Timing reports: Chrome trace JSON (Perfetto, chrome://tracing) and a plain-text table.

use std::fmt::Write as _;

use serde_json::{json, Value};

/// Measured cost of one pass in one frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PassTiming {
    /// Pass name.
    pub name: String,
    /// GPU timestamp before the pass, in nanoseconds (any origin).
    pub gpu_begin_ns: u64,
    /// GPU timestamp after the pass, in nanoseconds (same origin).
    pub gpu_end_ns: u64,
    /// CPU time spent recording the pass, in nanoseconds.
    pub cpu_ns: u64,
    /// What the pass does (declared or derived), for efficiency against device limits.
    pub work: super::Work,
    /// Dispatches, barriers and transfer bytes the pass recorded.
    pub commands: super::Commands,
}

impl PassTiming {
    /// GPU milliseconds between the pass's timestamps.
    pub fn gpu_ms(&self) -> f64 {
        (self.gpu_end_ns - self.gpu_begin_ns) as f64 * 1e-6
    }
}

const PID: u32 = 1;
const GPU_TID: u32 = 1;
const CPU_TID: u32 = 2;

fn complete(name: &str, tid: u32, ts_ns: u64, dur_ns: u64) -> Value {
    json!({
        "name": name,
        "cat": if tid == GPU_TID { "gpu" } else { "cpu" },
        "ph": "X",
        "pid": PID,
        "tid": tid,
        "ts": ts_ns as f64 / 1000.0,
        "dur": dur_ns as f64 / 1000.0,
    })
}

fn thread_name(tid: u32, name: &str) -> Value {
    json!({ "name": "thread_name", "ph": "M", "pid": PID, "tid": tid, "args": { "name": name } })
}

/// Chrome trace of consecutive frames: GPU passes at their timestamps (relative to the
/// earliest), CPU recording laid end to end per frame, aligned with the frame's GPU start.
pub fn chrome_trace(frames: &[Vec<PassTiming>]) -> Value {
    let origin = frames.iter().flatten().map(|t| t.gpu_begin_ns).min().unwrap_or(0);
    let mut events = vec![thread_name(GPU_TID, "GPU"), thread_name(CPU_TID, "CPU record")];
    for frame in frames {
        // CPU and GPU clocks differ; only the per-frame alignment is meaningful.
        let mut cpu_ts = frame.iter().map(|t| t.gpu_begin_ns).min().unwrap_or(origin) - origin;
        for t in frame {
            let gpu_dur = t.gpu_end_ns.saturating_sub(t.gpu_begin_ns);
            events.push(complete(&t.name, GPU_TID, t.gpu_begin_ns - origin, gpu_dur));
            events.push(complete(&t.name, CPU_TID, cpu_ts, t.cpu_ns));
            cpu_ts += t.cpu_ns;
        }
    }
    json!({ "traceEvents": events, "displayTimeUnit": "ms" })
}

/// `chrome_trace` serialized, ready to write to a `.json` file.
pub fn chrome_trace_string(frames: &[Vec<PassTiming>]) -> String {
    chrome_trace(frames).to_string()
}

/// One frame as an aligned text table with a total row.
pub fn format_table(frame: &[PassTiming]) -> String {
    let width = frame.iter().map(|t| t.name.len()).chain(std::iter::once("total".len())).max().unwrap_or(0);
    let mut out = format!("{:<width$}  {:>9}  {:>9}\n", "pass", "GPU ms", "CPU ms");
    let (mut gpu_total, mut cpu_total) = (0u64, 0u64);
    for t in frame {
        let gpu = t.gpu_end_ns.saturating_sub(t.gpu_begin_ns);
        gpu_total += gpu;
        cpu_total += t.cpu_ns;
        let _ = writeln!(out, "{:<width$}  {:>9.3}  {:>9.3}", t.name, gpu as f64 / 1e6, t.cpu_ns as f64 / 1e6);
    }
    let _ = writeln!(out, "{:<width$}  {:>9.3}  {:>9.3}", "total", gpu_total as f64 / 1e6, cpu_total as f64 / 1e6);
    out
}
