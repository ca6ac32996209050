//! Measured device limits: runs the micro-benchmarks of `vkengine_demos::limits` on the
//! selected device (each one a frame-graph pass timed by the graph's GPU timestamps, repeated
//! until stable) and writes `limits.csv`, `limits.json` and the bar chart `limits.png` under
//! `--out`: copy/storage-buffer/storage-image bandwidth, trilinear 3D-texture fetch rate, uint
//! and float atomic-add throughput (uncontended and contended), dispatch and draw overhead, and
//! one LPV propagation-like step in three SH grid layouts.

use clap::Parser;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vkengine::plot::{bars, Bar, BarGroup};
use vkengine::vk::{Context, ContextOptions, Validation};
use vkengine::{Error, Result};
use vkengine_demos::limits::{run_all, LimitRow, LimitsConfig};
use vkengine_demos::output::{write_json, DeviceReport};

#[derive(Parser)]
#[command(
    version,
    about = "Measured device limits: bandwidth, fetch and atomic rates, dispatch/draw overhead, LPV grid layouts"
)]
struct Args {
    /// Output folder (limits.csv, limits.json, limits.png).
    #[arg(long, default_value = "results/device_limits")]
    out: PathBuf,
    /// Smaller sizes and a shorter time limit per benchmark (about a quarter of the time).
    #[arg(long)]
    quick: bool,
    /// Pick a Vulkan device by (part of) its name; default prefers a discrete GPU.
    #[arg(long)]
    device: Option<String>,
    /// Enable the Khronos validation layer (slow: the numbers are then not representative).
    #[arg(long)]
    validation: bool,
    /// Stop each benchmark after this many seconds of measuring even if not yet stable.
    #[arg(long)]
    max_seconds: Option<f64>,
}

/// Everything `limits.json` holds.
#[derive(serde::Serialize)]
struct Report<'a> {
    device: DeviceReport,
    commit: Option<String>,
    cores: usize,
    quick: bool,
    seconds: f64,
    config: &'a LimitsConfig,
    rows: &'a [LimitRow],
}

/// `git rev-parse --short HEAD` of the working directory, when git and a repository are there.
fn commit() -> Option<String> {
    let out = std::process::Command::new("git").args(["rev-parse", "--short", "HEAD"]).output().ok()?;
    let s = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (out.status.success() && !s.is_empty()).then_some(s)
}

fn csv(rows: &[LimitRow], device: &DeviceReport) -> String {
    let mut s = format!(
        "# device: {} ({}), Vulkan {}\nname,unit,median,p10,p90,min,max,samples,stable,median_ms,work_per_run,work_unit,detail,skipped\n",
        device.name, device.driver, device.api_version
    );
    for r in rows {
        // Free text is quoted so commas in it cannot shift columns.
        let q = |t: &str| format!("\"{}\"", t.replace('"', "'"));
        let _ = writeln!(
            s,
            "{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{},{},{:.4},{},{},{},{}",
            r.name,
            r.unit,
            r.stats.median,
            r.stats.p10,
            r.stats.p90,
            r.stats.min,
            r.stats.max,
            r.stats.samples,
            r.stable,
            r.median_ms,
            r.work_per_run,
            r.work_unit,
            q(&r.detail),
            r.skipped.as_deref().map(q).unwrap_or_default()
        );
    }
    s
}

fn chart(path: &Path, rows: &[LimitRow], device: &DeviceReport) -> Result<()> {
    let mut groups: Vec<BarGroup> = Vec::new();
    for r in rows {
        let bar = Bar {
            label: if r.skipped.is_some() { format!("{} (skipped)", r.name) } else { r.name.clone() },
            value: r.stats.median,
            range: r.skipped.is_none().then_some((r.stats.p10, r.stats.p90)),
        };
        match groups.iter_mut().find(|g| g.title == r.unit) {
            Some(g) => g.bars.push(bar),
            None => groups.push(BarGroup { title: r.unit.clone(), bars: vec![bar] }),
        }
    }
    let title = format!("{} — {} (median, p10–p90)", device.name, device.driver);
    bars(path, &title, &groups)
}

fn run(args: &Args) -> Result<()> {
    let mut opts = ContextOptions::from_env();
    if args.validation {
        opts.validation = Validation::Required;
    }
    if args.device.is_some() {
        opts.device = args.device.clone();
    }
    let mut cfg = if args.quick { LimitsConfig::quick() } else { LimitsConfig::full() };
    if let Some(s) = args.max_seconds {
        if !(s.is_finite() && s > 0.0) {
            return Err(Error::Input(format!("--max-seconds {s}: must be a positive number of seconds")));
        }
        cfg.rule.max_seconds = s;
    }
    let ctx = Context::new(&opts)?;
    let device = DeviceReport::from(&ctx.info);
    println!("device: {} ({}), Vulkan {}", device.name, device.driver, device.api_version);
    let t0 = Instant::now();
    let rows = run_all(&ctx, &cfg, |r| match &r.skipped {
        Some(why) => println!("{:<26} skipped: {why}", r.name),
        None => println!(
            "{:<26} {:>10.3} {:<11} p10 {:>9.3}  p90 {:>9.3}  n={:<3}{}  ({:.3} ms/pass)",
            r.name,
            r.stats.median,
            r.unit,
            r.stats.p10,
            r.stats.p90,
            r.stats.samples,
            if r.stable { "" } else { " unstable" },
            r.median_ms
        ),
    })?;
    vkengine_demos::check_validation(&ctx)?;
    let seconds = t0.elapsed().as_secs_f64();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    std::fs::create_dir_all(&args.out).map_err(|source| Error::Io { path: args.out.display().to_string(), source })?;
    let csv_path = args.out.join("limits.csv");
    std::fs::write(&csv_path, csv(&rows, &device))
        .map_err(|source| Error::Io { path: csv_path.display().to_string(), source })?;
    let report = Report {
        device: device.clone(),
        commit: commit(),
        cores,
        quick: args.quick,
        seconds,
        config: &cfg,
        rows: &rows,
    };
    write_json(&args.out.join("limits.json"), &report)?;
    chart(&args.out.join("limits.png"), &rows, &device)?;
    println!("{} benchmarks in {seconds:.1} s; wrote {}/limits.{{csv,json,png}}", rows.len(), args.out.display());
    Ok(())
}

fn main() {
    let args = Args::parse();
    vkengine_demos::runner::exit_on_error(run(&args));
}
