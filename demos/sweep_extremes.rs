//! `sweep_extremes`: every numeric setting of the volume renderers (each renderer) and of the
//! mesh renderer at both ends of its range (see `vkengine_demos::extremes`), on lavapipe or any
//! device. Writes `results/extremes/sweep.csv` (with the device and driver) and exits 1 if any
//! case panicked, produced a non-finite or negative pixel, failed other than by a clear input
//! error, or ran past `--limit`.
//!
//! `cargo run --release -p vkengine-demos --bin sweep_extremes`

use clap::Parser;
use std::io::Write;
use std::path::PathBuf;
use vkengine_demos::extremes::{sweep, Outcome, Selection};

/// The parameter-extreme sweep.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Volume renderers, comma-separated.
    #[arg(long, default_value = "mip,iso,eam,eam-b2f,lao,dos,mcs,mcm")]
    renderers: String,
    /// Only these keys, comma-separated (default: every numeric key).
    #[arg(long, default_value = "")]
    keys: String,
    /// Skip the mesh renderer.
    #[arg(long)]
    no_mesh: bool,
    /// Seconds a case may take.
    #[arg(long, default_value_t = 60.0)]
    limit: f64,
    /// CSV to write.
    #[arg(long, default_value = "results/extremes/sweep.csv")]
    out: PathBuf,
}

fn main() {
    let args = Args::parse();
    if !(args.limit.is_finite() && args.limit > 0.0) {
        eprintln!("error: --limit must be a positive number of seconds");
        std::process::exit(2);
    }
    let ctx = match vkengine::vk::Context::new(&Default::default()) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let renderers: Vec<&str> = args.renderers.split(',').filter(|s| !s.is_empty()).collect();
    let keys: Vec<&str> = args.keys.split(',').filter(|s| !s.is_empty()).collect();
    let sel = Selection {
        renderers: &renderers,
        keys: &keys,
        mesh: !args.no_mesh,
        limit: std::time::Duration::from_secs_f64(args.limit),
    };
    let cases = sweep(&ctx, &sel);
    let failed = cases.iter().filter(|c| matches!(c.outcome, Outcome::Failed(_))).count();
    let refused = cases.iter().filter(|c| matches!(c.outcome, Outcome::Refused(_))).count();
    let write = || -> std::io::Result<()> {
        if let Some(dir) = args.out.parent() {
            std::fs::create_dir_all(dir)?;
        }
        let mut f = std::fs::File::create(&args.out)?;
        writeln!(f, "# device: {} ({})", ctx.info.name, ctx.info.driver)?;
        writeln!(f, "target,key,value,outcome,ms,message")?;
        for c in &cases {
            let (o, m) = match &c.outcome {
                Outcome::Ok => ("ok", String::new()),
                Outcome::Refused(m) => ("refused", m.clone()),
                Outcome::Failed(m) => ("FAILED", m.clone()),
            };
            writeln!(f, "{},{},{},{o},{:.1},\"{}\"", c.target, c.key, c.value, c.ms, m.replace('"', "'"))?;
        }
        Ok(())
    };
    if let Err(e) = write() {
        eprintln!("error: {}: {e}", args.out.display());
        std::process::exit(1);
    }
    eprintln!(
        "{} cases: {} ok, {refused} refused with a clear error, {failed} failed → {}",
        cases.len(),
        cases.len() - failed - refused,
        args.out.display()
    );
    std::process::exit(i32::from(failed > 0));
}
