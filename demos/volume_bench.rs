//! Volume renderer timings: GPU ms per frame for MIP / ISO / EAM (with and without empty-space
//! skipping) on procedural 128³ scenes at 512², medians of N frames after a warm-up frame.
//! Writes `results/volume_bench/timings.csv` with the device it ran on.

use clap::Parser;
use std::fmt::Write as _;
use std::path::PathBuf;
use vkengine::vk::{Context, ContextOptions};
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::procedural;
use vkengine::volume::renderer::{render_frame, RenderSettings, RendererKind, Targets, VolumeRenderer};
use vkengine::volume::tf::TransferFunction;

#[derive(Parser)]
#[command(about = "Volume renderer benchmark")]
struct Args {
    /// Output folder.
    #[arg(long, default_value = "results/volume_bench")]
    out: PathBuf,
    /// Measured frames per configuration.
    #[arg(long, default_value_t = 5)]
    frames: u64,
    /// Volume edge length.
    #[arg(long, default_value_t = 128)]
    n: u32,
    /// Image edge length.
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// Also run the Monte Carlo error-vs-time study (reference, then RMSE after 1, 2, 4, … frames).
    #[arg(long)]
    convergence: bool,
    /// Convergence study: image edge length.
    #[arg(long, default_value_t = 128)]
    conv_size: u32,
    /// Convergence study: frames per variant (a power of two).
    #[arg(long, default_value_t = 256)]
    conv_frames: u64,
    /// Convergence study: frames in each reference.
    #[arg(long, default_value_t = 2048)]
    reference_frames: u64,
    /// Convergence study: extinction multiplier of the cloud (dense media favour residual tracking).
    #[arg(long, default_value_t = 6.0)]
    density: f32,
    /// Convergence study: only the MCS shadow-ray estimators (ratio, residual ratio, delta).
    #[arg(long)]
    shadow_only: bool,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let ctx = Context::new(&ContextOptions::from_env())?;
    let d = [args.n; 3];
    let scenes = [
        ("cloud", procedural::cloud(d, 0)?, TransferFunction::preset("cloud")?),
        ("checker", procedural::checker_shell(d, 8)?, TransferFunction::preset("default")?),
        ("sphere", procedural::smooth_sphere(d, 0.45)?, TransferFunction::ramp(0.5, 0.9, [1.0, 0.6, 0.3], 20.0)),
    ];
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    let mut csv = format!(
        "# device: {} ({}); volume {}^3, image {}^2, median of {} frames\nscene,renderer,ess,precomputed_gradients,empty_block_fraction,gpu_ms_median,gpu_ms_min,gpu_ms_max\n",
        ctx.info.name, ctx.info.driver, args.n, args.size, args.frames
    );
    for (name, vol, tf) in &scenes {
        let r = VolumeRenderer::new(&ctx, vol, tf)?;
        let mut t = Targets::new(&ctx, [args.size; 2])?;
        for (kind, ess, pre) in [
            (RendererKind::Mip, false, false),
            (RendererKind::Iso, false, false),
            (RendererKind::Eam, false, false),
            (RendererKind::Eam, true, false),
            (RendererKind::Eam, false, true),
            (RendererKind::Eam, true, true),
        ] {
            let s = RenderSettings {
                renderer: kind,
                empty_space_skipping: ess,
                precomputed_gradients: pre,
                ..Default::default()
            };
            let mut ms = Vec::new();
            for frame in 0..=args.frames {
                let run = render_frame(&ctx, &r, &mut t, &cam, &s, frame)?;
                if frame > 0 {
                    ms.push(run.timings.last().map(|t| t.gpu_end_ns as f64 * 1e-6).unwrap_or(0.0));
                }
            }
            ms.sort_by(f64::total_cmp);
            let (med, lo, hi) = (ms[ms.len() / 2], ms[0], ms[ms.len() - 1]);
            let (e, p) = (u8::from(ess), u8::from(pre));
            let empty = r.empty_fraction;
            println!(
                "{name:<8} {:<4} ess={e} pregrad={p} {med:>9.2} ms (empty blocks {:.0}%)",
                kind.name(),
                empty * 100.0
            );
            writeln!(csv, "{name},{},{e},{p},{empty:.4},{med:.3},{lo:.3},{hi:.3}", kind.name())?;
        }
    }
    std::fs::create_dir_all(&args.out)?;
    let path = args.out.join("timings.csv");
    std::fs::write(&path, csv)?;
    println!("wrote {}", path.display());
    if args.convergence {
        convergence(&ctx, &args)?;
    }
    Ok(())
}

/// RMSE against a long-run reference after 1, 2, 4, … frames, with cumulative GPU time, for each
/// Monte Carlo variant; writes `convergence.csv` and `error_vs_time.png`.
fn convergence(ctx: &Context, args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    use vkengine::metrics::compare;
    use vkengine::plot::{loglog, loglog_slope, Series};
    use vkengine::volume::renderer::{McSettings, TransmittanceEstimator};
    let vol = procedural::cloud([args.n; 3], 0)?;
    let tf = TransferFunction::preset("cloud")?;
    let r = VolumeRenderer::new(ctx, &vol, &tf)?;
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    let size = [args.conv_size; 2];
    let base = McSettings { density_scale: args.density, ..Default::default() };
    let settings = |kind, grid, est| RenderSettings {
        renderer: kind,
        jitter: true,
        mc: McSettings { majorant_grid: grid, transmittance: est, ..base },
        ..Default::default()
    };
    let (ratio, residual, delta) =
        (TransmittanceEstimator::Ratio, TransmittanceEstimator::ResidualRatio, TransmittanceEstimator::Delta);
    let variants = [
        ("MCS grid ratio", RendererKind::Mcs, true, ratio),
        ("MCS global ratio", RendererKind::Mcs, false, ratio),
        ("MCS grid residual", RendererKind::Mcs, true, residual),
        ("MCS grid delta", RendererKind::Mcs, true, delta),
        ("MCM grid ratio", RendererKind::Mcm, true, ratio),
        ("MCM global ratio", RendererKind::Mcm, false, ratio),
    ];
    let mut csv = format!(
        "# device: {} ({}); cloud {}^3 density x{}, image {}^2, reference {} frames\nvariant,frames,gpu_ms_cumulative,rmse,rel_mse,psnr_db\n",
        ctx.info.name, ctx.info.driver, args.n, base.density_scale, args.conv_size, args.reference_frames
    );
    let mut series = Vec::new();
    let kinds: &[RendererKind] =
        if args.shadow_only { &[RendererKind::Mcs] } else { &[RendererKind::Mcs, RendererKind::Mcm] };
    for &kind in kinds {
        // Independent of the runs below: frame numbers (the random streams) start far away.
        let mut t = Targets::new(ctx, size)?;
        let s = settings(kind, true, ratio);
        for f in 0..args.reference_frames {
            render_frame(ctx, &r, &mut t, &cam, &s, 1_000_000 + f)?;
        }
        let reference = t.read_hdr(ctx)?;
        let exr = args.out.join(format!("reference-{}.exr", kind.name()));
        vkengine::demo::output::write_exr(&exr, size[0], size[1], &reference)?;
        println!("reference {} written: {}", kind.name(), exr.display());
        let shadow = |label: &&str| !args.shadow_only || label.starts_with("MCS grid");
        for (label, _, grid, est) in variants.iter().filter(|v| v.1 == kind && shadow(&v.0)) {
            let s = settings(kind, *grid, *est);
            let mut t = Targets::new(ctx, size)?;
            let mut cum_ms = 0.0;
            let mut points = Vec::new();
            let mut by_frames = Vec::new();
            for f in 0..args.conv_frames {
                let run = render_frame(ctx, &r, &mut t, &cam, &s, f)?;
                cum_ms += run.timings.iter().map(|t| (t.gpu_end_ns - t.gpu_begin_ns) as f64 * 1e-6).sum::<f64>();
                let n = f + 1;
                if n.is_power_of_two() {
                    let e = compare(&t.read_hdr(ctx)?, &reference)?;
                    writeln!(csv, "{label},{n},{cum_ms:.3},{:.6},{:.6},{:.3}", e.rmse, e.rel_mse, e.psnr_db)?;
                    points.push((cum_ms, e.rmse));
                    by_frames.push((n as f64, e.rmse));
                }
            }
            let slope = loglog_slope(&by_frames);
            println!(
                "{label:<20} RMSE after {} frames {:.5} in {cum_ms:.0} ms; slope vs frames {slope:.3}",
                args.conv_frames,
                points.last().map(|p| p.1).unwrap_or(0.0)
            );
            series.push(Series { name: format!("{label} (slope {slope:.2})"), points });
        }
    }
    std::fs::write(args.out.join("convergence.csv"), csv)?;
    let plot = args.out.join("error_vs_time.png");
    loglog(
        &plot,
        "Monte Carlo volume rendering: error vs GPU time",
        "cumulative GPU time (ms)",
        "RMSE vs reference",
        &series,
    )?;
    println!("wrote {}", plot.display());
    Ok(())
}
