//! One profile run as a report folder: per-pass GPU ms (median, p95), CPU ms, the pass's work
//! as a fraction of the device's measured limits (a simple roofline), every frame's samples (so
//! two folders can be compared, see `compare`), a Chrome trace, and a frame-budget bar chart.

use crate::error::{Error, Result};
use crate::graph::trace::PassTiming;
use crate::graph::{Commands, Work};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// The device's peak rates (from `device_limits`), the roofs a pass is measured against.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Roofs {
    /// Best shader-side memory bandwidth, bytes/s (storage buffer or image, read or write).
    pub bytes_per_s: f64,
    /// Filtered 3D-texture fetches/s (coherent coordinates).
    pub fetches_per_s: f64,
    /// Uncontended 32-bit integer atomic adds/s.
    pub atomics_per_s: f64,
    /// Where the numbers came from (file and device).
    pub source: String,
}

/// Device facts for reports.
#[derive(serde::Serialize, serde::Deserialize, Debug, Clone)]
pub struct DeviceReport {
    /// Device name.
    pub name: String,
    /// Index among the machine's Vulkan devices (`--device '#N'`).
    #[serde(default)]
    pub index: usize,
    /// `deviceUUID` (`--device uuid:…`; `nvidia-smi -L`'s `GPU-…` on NVIDIA).
    #[serde(default)]
    pub uuid: String,
    /// Driver name and version.
    pub driver: String,
    /// Vulkan API version.
    pub api_version: String,
    /// Validation active.
    pub validation: bool,
}

impl From<&crate::vk::DeviceInfo> for DeviceReport {
    fn from(i: &crate::vk::DeviceInfo) -> Self {
        Self {
            name: i.name.clone(),
            index: i.index,
            uuid: i.uuid.clone(),
            driver: i.driver.clone(),
            api_version: i.api_version.clone(),
            validation: i.validation,
        }
    }
}

/// One pass over the measured frames.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PassProfile {
    /// Pass name.
    pub name: String,
    /// Median GPU ms.
    pub gpu_median_ms: f64,
    /// 95th-percentile GPU ms.
    pub gpu_p95_ms: f64,
    /// Median CPU ms spent recording it.
    pub cpu_median_ms: f64,
    /// Declared or derived work per frame.
    pub work: Work,
    /// Achieved rates at the median time: bytes/s, fetches/s, atomics/s.
    pub achieved: [f64; 3],
    /// The largest fraction of a roof the pass reaches, and which roof (`bytes`, `fetches`,
    /// `atomics`); `None` without measured roofs or without work.
    pub efficiency: Option<(f64, String)>,
    /// GPU ms of every measured frame, in order.
    pub samples_ms: Vec<f64>,
    /// Dispatches, barriers and transfer bytes the pass recorded in its first measured frame.
    #[serde(default)]
    pub commands: Commands,
}

/// A whole profile run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Profile {
    /// Demo and its command line.
    pub demo: String,
    /// Arguments the demo ran with.
    pub args: Vec<String>,
    /// Device, driver, API version.
    pub device: DeviceReport,
    /// `git rev-parse --short HEAD` where it ran, if available.
    pub commit: Option<String>,
    /// Logical CPU cores of the machine.
    pub cores: usize,
    /// Frames rendered and discarded first.
    pub warmup: u64,
    /// Frames measured.
    pub frames: usize,
    /// Median GPU ms of a whole frame.
    pub frame_median_ms: f64,
    /// Roofs used for `efficiency`.
    pub roofs: Option<Roofs>,
    /// Passes in execution order.
    pub passes: Vec<PassProfile>,
    /// Dispatches, barriers and transfer bytes of the first measured frame, all passes.
    #[serde(default)]
    pub commands: Commands,
}

/// The q-quantile of unsorted samples (linear interpolation, as the device limits use).
pub fn quantile(samples: &[f64], q: f64) -> f64 {
    let mut v = samples.to_vec();
    v.sort_by(f64::total_cmp);
    super::percentile(&v, q)
}

/// Achieved rates of `work` done in `ms`, and the largest fraction of a roof among them.
pub fn efficiency(work: &Work, ms: f64, roofs: Option<&Roofs>) -> ([f64; 3], Option<(f64, String)>) {
    let s = (ms * 1e-3).max(1e-12);
    let achieved = [work.bytes as f64 / s, work.texel_fetches as f64 / s, work.atomics as f64 / s];
    let best = roofs.and_then(|r| {
        let roofs = [(r.bytes_per_s, "bytes"), (r.fetches_per_s, "fetches"), (r.atomics_per_s, "atomics")];
        achieved
            .iter()
            .zip(roofs)
            .filter(|(&a, (roof, _))| a > 0.0 && *roof > 0.0)
            .map(|(&a, (roof, name))| (a / roof, name.to_string()))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    });
    (achieved, best)
}

impl Profile {
    /// Summarises per-frame pass timings (warm-up frames already left out).
    pub fn new(
        demo: &str,
        args: Vec<String>,
        device: DeviceReport,
        warmup: u64,
        frames: &[Vec<PassTiming>],
        roofs: Option<Roofs>,
    ) -> Self {
        let mut names: Vec<(String, Work, Commands)> = Vec::new();
        for t in frames.iter().flatten() {
            if !names.iter().any(|(n, ..)| *n == t.name) {
                names.push((t.name.clone(), t.work, t.commands));
            }
        }
        let passes = names
            .into_iter()
            .map(|(name, work, commands)| {
                let of = |f: &dyn Fn(&PassTiming) -> f64| -> Vec<f64> {
                    frames.iter().flat_map(|fr| fr.iter().filter(|t| t.name == name).map(f)).collect()
                };
                let samples_ms = of(&|t| t.gpu_end_ns.saturating_sub(t.gpu_begin_ns) as f64 * 1e-6);
                let cpu = of(&|t| t.cpu_ns as f64 * 1e-6);
                let median = quantile(&samples_ms, 0.5);
                let (achieved, efficiency) = efficiency(&work, median, roofs.as_ref());
                PassProfile {
                    gpu_median_ms: median,
                    gpu_p95_ms: quantile(&samples_ms, 0.95),
                    cpu_median_ms: quantile(&cpu, 0.5),
                    work,
                    achieved,
                    efficiency,
                    samples_ms,
                    name,
                    commands,
                }
            })
            .collect();
        let frame_ms: Vec<f64> =
            frames.iter().map(|f| f.iter().map(|t| t.gpu_end_ns).max().unwrap_or(0) as f64 * 1e-6).collect();
        Self {
            demo: demo.into(),
            args,
            device,
            commit: git_commit(),
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            warmup,
            frames: frames.len(),
            frame_median_ms: quantile(&frame_ms, 0.5),
            roofs,
            passes,
            commands: Commands::total(frames.first().into_iter().flatten().map(|t| &t.commands)),
        }
    }

    /// The per-pass table as Markdown.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{} on {} ({}), commit {}, {} cores; {} frames after {} warm-up\n\n",
            self.demo,
            self.device.name,
            self.device.driver,
            self.commit.as_deref().unwrap_or("unknown"),
            self.cores,
            self.frames,
            self.warmup
        );
        let c = &self.commands;
        let _ = writeln!(
            out,
            "Per frame: {} dispatches, {} barriers, {:.2} MB written by transfer commands.\n",
            c.dispatches,
            c.barriers,
            c.transfer_bytes as f64 / 1e6
        );
        out += "| pass | GPU ms median | GPU ms p95 | CPU ms | work | achieved | of roof | dispatches | barriers |\n|---|---|---|---|---|---|---|---|---|\n";
        for p in &self.passes {
            let w = &p.work;
            let mut work = String::new();
            if w.bytes > 0 {
                let _ = write!(work, "{:.1} MB", w.bytes as f64 / 1e6);
            }
            if w.texel_fetches > 0 {
                let _ = write!(work, " {:.2} M fetches", w.texel_fetches as f64 / 1e6);
            }
            if w.atomics > 0 {
                let _ = write!(work, " {:.2} M atomics", w.atomics as f64 / 1e6);
            }
            if !w.declared && w.bytes > 0 {
                work += " (derived)";
            }
            let [b, f, a] = p.achieved;
            // The roof's rate if there is one, else the most specific kind of work declared.
            let kind = p.efficiency.as_ref().map(|e| e.1.as_str()).unwrap_or(if w.texel_fetches > 0 {
                "fetches"
            } else if w.atomics > 0 {
                "atomics"
            } else {
                "bytes"
            });
            let achieved = match kind {
                "fetches" => format!("{:.3} Gfetch/s", f / 1e9),
                "atomics" => format!("{:.3} Gatomic/s", a / 1e9),
                _ => format!("{:.2} GB/s", b / 1e9),
            };
            let roof = p.efficiency.as_ref().map_or("–".into(), |(f, r)| format!("{:.1} % {r}", f * 100.0));
            let _ = writeln!(
                out,
                "| {} | {:.3} | {:.3} | {:.3} | {} | {} | {} | {} | {} |",
                p.name,
                p.gpu_median_ms,
                p.gpu_p95_ms,
                p.cpu_median_ms,
                work.trim(),
                achieved,
                roof,
                p.commands.dispatches,
                p.commands.barriers
            );
        }
        let _ =
            writeln!(out, "| **frame** | {:.3} | | | | | | {} | {} |", self.frame_median_ms, c.dispatches, c.barriers);
        out
    }

    /// Writes `profile.json`, `passes.md`, `trace.json` and `budget.png` into `dir`.
    pub fn write(&self, dir: &Path, frames: &[Vec<PassTiming>]) -> Result<()> {
        let io = |path: &Path| {
            let p = path.display().to_string();
            move |source| Error::Io { path: p, source }
        };
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let json = serde_json::to_string_pretty(self).map_err(|e| Error::Input(format!("profile: {e}")))?;
        let path = dir.join("profile.json");
        std::fs::write(&path, json).map_err(io(&path))?;
        let path = dir.join("passes.md");
        std::fs::write(&path, self.table()).map_err(io(&path))?;
        let path = dir.join("trace.json");
        std::fs::write(&path, crate::graph::trace::chrome_trace_string(frames)).map_err(io(&path))?;
        let bars = self
            .passes
            .iter()
            .map(|p| crate::plot::Bar {
                label: p.name.clone(),
                value: p.gpu_median_ms,
                range: Some((quantile(&p.samples_ms, 0.05), p.gpu_p95_ms)),
            })
            .collect();
        let group = crate::plot::BarGroup { title: "GPU ms per pass (median, p5–p95)".into(), bars };
        let title = format!("{}: frame budget, {:.1} ms GPU ({})", self.demo, self.frame_median_ms, self.device.name);
        crate::plot::bars(&dir.join("budget.png"), &title, &[group])
    }

    /// Reads a `profile.json` (from a folder or the file itself).
    pub fn load(path: &Path) -> Result<Self> {
        let file = if path.is_dir() { path.join("profile.json") } else { path.to_path_buf() };
        // A missing or unreadable report is the user's input, not a runtime failure.
        let text = std::fs::read_to_string(&file)
            .map_err(|e| Error::Input(format!("{}: cannot read the profile report: {e}", file.display())))?;
        serde_json::from_str(&text).map_err(|e| Error::Input(format!("{}: not a profile report: {e}", file.display())))
    }
}

/// Peak rates from a `device_limits` report, if it was measured on this device.
pub fn load_roofs(path: &Path, device: &str) -> Result<Option<Roofs>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(Error::Io { path: path.display().to_string(), source }),
    };
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::Input(format!("{}: not JSON: {e}", path.display())))?;
    super::limits_roofs(&v, device, &path.display().to_string())
}

fn git_commit() -> Option<String> {
    let out = std::process::Command::new("git").args(["rev-parse", "--short", "HEAD"]).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_unsorted_samples() {
        let v = [5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert!((quantile(&v, 0.95) - 4.8).abs() < 1e-12);
        assert_eq!(quantile(&v, 0.0), 1.0);
    }

    #[test]
    fn efficiency_picks_the_tightest_roof() {
        let roofs = Roofs { bytes_per_s: 10e9, fetches_per_s: 1e9, atomics_per_s: 0.5e9, source: "t".into() };
        // 1 ms: 5 MB → 5 GB/s = 50 %; 0.8 M fetches → 0.8 G/s = 80 %.
        let w = Work { bytes: 5_000_000, texel_fetches: 800_000, atomics: 0, loop_iterations: 0, declared: true };
        let (achieved, e) = efficiency(&w, 1.0, Some(&roofs));
        assert!((achieved[0] - 5e9).abs() < 1.0);
        let (f, r) = e.expect("has roofs");
        assert!((f - 0.8).abs() < 1e-9 && r == "fetches", "{f} {r}");
        assert!(efficiency(&w, 1.0, None).1.is_none());
    }
}
