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
    Ok(())
}
