//! Profiling: `profile run DEMO [demo flags]` renders a demo scene headless for N frames after a
//! warm-up and writes one report folder (per-pass GPU ms median/p95, CPU ms, fraction of the
//! device's measured limits, Chrome trace, frame-budget chart, device/driver/commit);
//! `profile compare A B [--repeat A2]` prints per-pass ratios between two report folders and flags
//! only the changes beyond the noise measured in those reports (frame-to-frame spread, drift
//! within a run, and, with a second run of the baseline, each pass's run-to-run change).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use vkengine::profile::{compare, report::Profile};
use vkengine_demos::{mesh_app, volume_app, DemoArgs};

#[derive(Parser)]
#[command(about = "Per-pass profile reports and run-to-run comparison")]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Profile a demo scene: volume, cornell, atrium, or scene (with `--scene FILE`).
    Run {
        /// Demo to run.
        #[arg(value_parser = ["volume", "cornell", "atrium", "scene"])]
        demo: String,
        /// The demo's own flags (`--set`, `--size`, `--scene`, ...); defaults added here:
        /// `--frames 20 --warmup 3 --profile results/profile/DEMO`.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        flags: Vec<String>,
    },
    /// Compare two report folders (B relative to A).
    Compare {
        /// Baseline report folder (or its profile.json).
        a: PathBuf,
        /// Report folder to compare with the baseline.
        b: PathBuf,
        /// Another run of the baseline (repeatable): measures each pass's run-to-run noise.
        #[arg(long)]
        repeat: Vec<PathBuf>,
        /// Run-to-run noise assumed without `--repeat` (fraction).
        #[arg(long, default_value_t = compare::DEFAULT_FLOOR)]
        floor: f64,
    },
}

fn with_default(flags: &mut Vec<String>, flag: &str, value: &str) {
    if !flags.iter().any(|f| f == flag || f.starts_with(&format!("{flag}="))) {
        flags.extend([flag.to_string(), value.to_string()]);
    }
}

fn run(demo: &str, mut flags: Vec<String>) -> vkengine::Result<()> {
    with_default(&mut flags, "--frames", "20");
    with_default(&mut flags, "--warmup", "3");
    with_default(&mut flags, "--profile", &format!("results/profile/{demo}"));
    if !flags.iter().any(|f| f == "--headless") {
        flags.push("--headless".into());
    }
    let args = DemoArgs::try_parse_from(std::iter::once(demo.to_string()).chain(flags))
        .map_err(|e| vkengine::Error::Input(e.to_string()))?;
    match demo {
        "volume" => volume_app::run(&args),
        "scene" => mesh_app::run(&args, "scene", "cornell"),
        name => mesh_app::run(&args, name, name),
    }
}

fn main() {
    let args = Args::parse();
    let result = match args.command {
        Command::Run { demo, flags } => run(&demo, flags),
        Command::Compare { a, b, repeat, floor } => Profile::load(&a).and_then(|pa| {
            let pb = Profile::load(&b)?;
            let reps = repeat.iter().map(|p| Profile::load(p)).collect::<vkengine::Result<Vec<_>>>()?;
            if !(0.0..10.0).contains(&floor) {
                return Err(vkengine::Error::Input(format!("--floor {floor}: must be a fraction in [0, 10)")));
            }
            let floor = if reps.is_empty() { compare::Floor::Fixed(floor) } else { compare::Floor::Repeats(&reps) };
            print!("{}", compare::format(&pa, &pb, &floor));
            Ok(())
        }),
    };
    vkengine_demos::runner::exit_on_error(result);
}
