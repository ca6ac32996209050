//! `fuzz_loaders`: mutation fuzzing of every file loader (see `vkengine_demos::fuzz`).
//!
//! `cargo run --release -p vkengine-demos --bin fuzz_loaders -- --cases 10000 --seed 1`
//! runs that many cases per format, prints one line per format and every failing case (its files
//! saved under `--work`), and exits 1 if any case panicked, hung or over-allocated.

use clap::Parser;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use vkengine_demos::fuzz::{self, CountingAlloc, Problem};

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Mutation fuzzing of the volume, scene, session, transfer-function and environment-map loaders.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Cases per format (the first is the unmutated seed).
    #[arg(long, default_value_t = 10_000)]
    cases: u64,
    /// Seed of the mutation streams.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Only formats whose name contains this.
    #[arg(long)]
    only: Option<String>,
    /// Seconds one case may take before it counts as a hang.
    #[arg(long, default_value_t = 10.0)]
    time_limit: f64,
    /// Folder for case files (failing cases are kept there).
    #[arg(long, default_value = "target/fuzz_loaders")]
    work: PathBuf,
}

fn main() {
    let args = Args::parse();
    if !(args.time_limit.is_finite() && args.time_limit > 0.0) {
        eprintln!("error: --time-limit must be a positive number of seconds");
        std::process::exit(2);
    }
    let limit = Duration::from_secs_f64(args.time_limit);
    let mut failed = false;
    let mut total = 0;
    for format in fuzz::FORMATS.iter().filter(|f| args.only.as_deref().is_none_or(|o| f.name.contains(o))) {
        let start = Instant::now();
        let report = match fuzz::fuzz(format, args.cases, args.seed, limit, &args.work) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: {}: {e}", args.work.display());
                std::process::exit(1);
            }
        };
        total += report.cases;
        println!(
            "{:<15} {:>7} cases  {:>6} accepted  {:>7} rejected  {} failing  peak {:.1} MiB  {:.1} s",
            format.name,
            report.cases,
            report.accepted,
            report.rejected,
            report.findings.len(),
            report.max_peak as f64 / (1 << 20) as f64,
            start.elapsed().as_secs_f64()
        );
        if let Some(e) = &report.seed_error {
            println!("  the unmutated seed does not load: {e}");
            failed = true;
        }
        for f in &report.findings {
            failed = true;
            let what = match &f.problem {
                Problem::Panic(m) => format!("panic: {m}"),
                Problem::Hang => format!("no result within {} s", args.time_limit),
                Problem::Alloc { bytes, limit } => format!("allocated {bytes} bytes, limit {limit}"),
            };
            println!("  case {}: {what} ({})", f.case, f.saved.display());
        }
    }
    println!("{total} cases in all");
    std::process::exit(i32::from(failed));
}
