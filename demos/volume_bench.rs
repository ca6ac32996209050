//! Volume renderer timings: GPU ms per frame for MIP / ISO / EAM (with and without empty-space
//! skipping) on procedural 128³ scenes at 512², medians of N frames after a warm-up frame.
//! Writes `results/volume_bench/timings.csv` with the device it ran on.

use clap::Parser;
use std::fmt::Write as _;
use std::path::PathBuf;
use vkengine::vk::{Context, ContextOptions};
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::procedural;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{render_frame, RenderSettings, RendererKind, Targets, VolumeRenderer};

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
    /// Also run the transmittance-estimator study: per-pixel variance of camera-ray transmittance
    /// estimates and GPU time per frame for delta, ratio and residual ratio tracking, at several
    /// density scales on the cloud and the smooth sphere (writes `transmittance.csv`).
    #[arg(long)]
    transmittance: bool,
    /// Convergence study: the volume, `cloud` (one 128³ fBm cloud, ~40 % of blocks occupied) or
    /// `sparse` (six small puffs, ~7 % of blocks occupied), or `sphere` (a smooth radial ramp: dense
    /// and slowly varying, where each grid cell's extinction range is narrow).
    #[arg(long, default_value = "cloud")]
    conv_scene: String,
    /// Also time the occlusion renderers (LAO, DOS) and EAM with depth output against plain EAM
    /// on the same scenes (writes `occlusion.csv`). Time only: they approximate a different
    /// lighting model, so no error against the Monte Carlo reference is meaningful.
    #[arg(long)]
    occlusion: bool,
    /// Also run the image-based-lighting study on the cloud at `--conv-size`: MCS and MCM with
    /// the constant environment, the procedural sky map, and the map with hybrid scattering,
    /// relative error after 1, 2, 4, … `--conv-frames` frames against a `--reference-frames` MCM
    /// reference of the same lighting, vs cumulative GPU time (`ibl.csv`, `ibl_convergence.csv`,
    /// `ibl_error_vs_time.png`).
    #[arg(long)]
    ibl: bool,
    /// Instead, each Monte Carlo variant's relative error of the foreground vs wall time at
    /// `--size` on a scene: `vpt` is terier/vpt's default MCM scene (its 128³ cloud from
    /// `--peer-volume`; `peer_vpt.csv`, `peer_vpt_error_vs_time.png`, beside vpt's own curve),
    /// `cloud` this engine's default cloud with the sun (`peer_cloud.*`).
    #[arg(long, value_parser = ["vpt", "cloud"])]
    peer_scene: Option<String>,
    /// `--peer-scene vpt`: the raw 128³ u8 cloud (`python3 ../shared/peers/vpt/harness/make_volume.py PATH`).
    #[arg(long, default_value = "../shared/peers/vpt/data/cloud128.raw")]
    peer_volume: PathBuf,
    /// `--peer-scene`: frames per variant (checkpoints at powers of two).
    #[arg(long, default_value_t = 64)]
    peer_frames: u64,
    /// `--peer-scene`: frames of the reference.
    #[arg(long, default_value_t = 256)]
    peer_reference_frames: u64,
    /// `--peer-scene`: only the variants whose label contains one of these (comma-separated).
    #[arg(long, value_delimiter = ',')]
    peer_variants: Vec<String>,
    /// Instead, dense against sparse volume layout: MIP, EAM, LAO and MCM on the default cloud and
    /// a CT-like volume (`--n`, `--size`, `--frames` per layout, interleaved; `layout.csv`).
    #[arg(long)]
    layout: bool,
    /// Instead, what a label map costs: MIP, EAM, LAO and MCM on the CT-like volume (`--n`,
    /// `--size`, `--frames`) without and with three labels, two rounds interleaved (`labels.csv`).
    #[arg(long)]
    labels: bool,
    /// `--labels`: only the renderers named (comma-separated: mip, eam, lao, mcm).
    #[arg(long, value_delimiter = ',')]
    label_renderers: Vec<String>,
    /// `--layout`: only the renderers named (comma-separated: mip, eam, lao, mcm).
    #[arg(long, value_delimiter = ',')]
    layout_renderers: Vec<String>,
    /// `--layout`: instead, empty-space skipping on this sparse VDB cloud against its dense
    /// bounding box (EAM, MCM; `layout_cloud.csv`). `tools/make_vdb_sparse_cloud.py --bench`
    /// writes one whose dense box fits the device.
    #[arg(long)]
    layout_vdb: Option<PathBuf>,
    /// Instead, clean images fast: the shown image's relative error against time for one whole
    /// path a frame (the baseline), the raw default, adaptive sampling, the denoiser and both, on
    /// these scenes (comma-separated: vpt, ct, mr, vdb) at `--size` (`clean_*.csv`,
    /// `clean_summary.csv`).
    #[arg(long, value_delimiter = ',')]
    clean: Vec<String>,
    /// `--clean`: wall seconds per variant.
    #[arg(long, default_value_t = 30.0)]
    clean_seconds: f64,
    /// `--clean`, `--clean-path`: frames of bounded work 512/4 in each reference.
    #[arg(long, default_value_t = 256)]
    clean_reference_frames: u64,
    /// `--clean`: only these variants (comma-separated: whole, raw, adaptive, denoised,
    /// adaptive+denoised, bounded, bounded+adaptive+denoised; the first one run is the speed-ups'
    /// baseline); all when empty.
    #[arg(long, value_delimiter = ',')]
    clean_variants: Vec<String>,
    /// `--clean`: keep each scene's reference in `--out` (`clean_<scene>_<size>_<frames>.ref`)
    /// and reuse it when it exists: a reference of many frames costs minutes.
    #[arg(long)]
    clean_reference_cache: bool,
    /// `--clean mr`: the MNI152 T1 template (`tools/make_gallery.sh` fetches it).
    #[arg(long, default_value = "out/gallery/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz")]
    clean_mr: PathBuf,
    /// `--clean vdb`: a sparse OpenVDB cloud (`/usr/bin/python3 tools/make_vdb_sparse_cloud.py --bench PATH`).
    #[arg(long, default_value = "out/sparse_cloud.vdb")]
    clean_vdb: PathBuf,
    /// Instead, the camera path on vpt's scene at `--size`: 60 views 3° apart, this many paths a
    /// view, raw against denoised with temporal reuse (`clean_path.csv`).
    #[arg(long)]
    clean_path: Option<u64>,
}

fn main() {
    vkengine_demos::runner::exit_on_bench_error(run());
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let ctx = Context::new(&ContextOptions::from_env())?;
    if let (true, Some(vdb)) = (args.layout, &args.layout_vdb) {
        return vkengine_demos::layout_bench::run_cloud(&ctx, &args.out, vdb, args.size, args.frames);
    }
    let inputs = || vkengine_demos::clean_bench::Inputs {
        vpt: args.peer_volume.clone(),
        mr: args.clean_mr.clone(),
        vdb: args.clean_vdb.clone(),
    };
    if let Some(paths) = args.clean_path {
        return vkengine_demos::clean_bench::run_path(
            &ctx,
            &args.out,
            &inputs(),
            args.size,
            paths,
            args.clean_reference_frames,
        );
    }
    if !args.clean.is_empty() {
        let a = &args;
        return vkengine_demos::clean_bench::run(
            &ctx,
            &a.out,
            &a.clean,
            &inputs(),
            a.size,
            &vkengine_demos::clean_bench::Options {
                seconds: a.clean_seconds,
                reference_frames: a.clean_reference_frames,
                variants: a.clean_variants.clone(),
                reference_cache: a.clean_reference_cache,
            },
        );
    }
    if args.labels {
        let a = &args;
        return vkengine_demos::label_bench::run(&ctx, &a.out, a.n, a.size, a.frames, 2, &a.label_renderers);
    }
    if args.layout {
        let a = &args;
        return vkengine_demos::layout_bench::run(
            &ctx,
            &a.out,
            a.n,
            a.size,
            a.frames,
            &a.peer_volume,
            &a.layout_renderers,
        );
    }
    if args.peer_scene.is_some() {
        let p = &args;
        return vkengine_demos::vpt_peer::run(
            &ctx,
            &p.out,
            p.peer_scene.as_deref().unwrap_or("vpt"),
            &p.peer_volume,
            p.size,
            p.peer_frames,
            p.peer_reference_frames,
            &p.peer_variants,
        );
    }
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
    if args.occlusion {
        occlusion_timings(&ctx, &args, &scenes, &cam)?;
    }
    if args.convergence {
        convergence(&ctx, &args)?;
    }
    if args.transmittance {
        transmittance_study(&ctx, &args)?;
    }
    if args.ibl {
        ibl_study(&ctx, &args)?;
    }
    Ok(())
}

/// Time vs error of image-based lighting and hybrid scattering (see `Args::ibl`): for each
/// lighting (constant environment, sky map, sky map + hybrid 1) one long MCM reference, then MCS
/// and MCM swept over 1, 2, 4, … `--conv-frames` frames with cumulative GPU time and relative
/// error against it. MCS is compared with the MCM reference on purpose: its curve flattens at the
/// single-scattering bias. Writes `ibl.csv` (per variant: GPU ms/frame, error at the last count),
/// `ibl_convergence.csv` and `ibl_error_vs_time.png`.
fn ibl_study(ctx: &Context, args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    use vkengine::metrics::compare;
    use vkengine::plot::{loglog, loglog_slope, Series};
    use vkengine::volume::optics::envmap::EnvMap;
    use vkengine::volume::render::renderer::McSettings;
    let vol = procedural::cloud([args.n; 3], 0)?;
    let mut r = VolumeRenderer::new(ctx, &vol, &TransferFunction::preset("cloud")?)?;
    r.set_environment(ctx, Some(&EnvMap::procedural_sky(512, 256, [0.4, 0.8, 0.45])?))?;
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    let size = [args.conv_size; 2];
    // One whole path per frame, as these variants were measured (auto may bound the work).
    let base = McSettings { density_scale: args.density, sun_dir: None, budget: 0, ..Default::default() };
    let settings = |kind, env_map, hybrid| RenderSettings {
        renderer: kind,
        jitter: true,
        mc: McSettings { env_map, hybrid, ..base },
        ..Default::default()
    };
    let lightings = [("constant env", false, 0.0f32), ("sky map", true, 0.0), ("sky map + hybrid 1", true, 1.0)];
    let header = format!(
        "# device: {} ({}); cloud {}^3 density x{}, image {}^2, sun off, jittered; reference: MCM {} frames per lighting (independent streams); rel_rmse = sqrt(rel_mse), rel_mse = mean (x-r)^2/(r^2+0.01)",
        ctx.info.name, ctx.info.driver, args.n, args.density, args.conv_size, args.reference_frames
    );
    let mut summary = format!("{header}\nvariant,gpu_ms_median,frames,rmse,rel_mse\n");
    let mut curves = format!("{header}\nvariant,frames,gpu_ms_cumulative,rmse,rel_mse,rel_rmse\n");
    let mut series = Vec::new();
    for (light, env_map, hybrid) in lightings {
        let mut t = Targets::new(ctx, size)?;
        let s = settings(RendererKind::Mcm, env_map, hybrid);
        for f in 0..args.reference_frames {
            render_frame(ctx, &r, &mut t, &cam, &s, 1_000_000 + f)?;
        }
        let reference = t.read_hdr(ctx)?;
        println!("reference MCM {light}: {} frames", args.reference_frames);
        for kind in [RendererKind::Mcs, RendererKind::Mcm] {
            let label = format!("{} {light}", kind.name().to_uppercase());
            let s = settings(kind, env_map, hybrid);
            let mut t = Targets::new(ctx, size)?;
            let (mut cum_ms, mut ms, mut points, mut by_frames) = (0.0, Vec::new(), Vec::new(), Vec::new());
            let mut last = None;
            for f in 0..args.conv_frames {
                let run = render_frame(ctx, &r, &mut t, &cam, &s, f)?;
                let frame_ms = run.gpu_ms();
                cum_ms += frame_ms;
                ms.push(frame_ms);
                let n = f + 1;
                if n.is_power_of_two() || n == args.conv_frames {
                    let e = compare(&t.read_hdr(ctx)?, &reference)?;
                    let rel = e.rel_mse.sqrt();
                    writeln!(curves, "{label},{n},{cum_ms:.3},{:.6},{:.6},{rel:.6}", e.rmse, e.rel_mse)?;
                    points.push((cum_ms, rel));
                    by_frames.push((n as f64, rel));
                    last = Some(e);
                }
            }
            ms.sort_by(f64::total_cmp);
            let med = ms.get(ms.len() / 2).copied().unwrap_or(0.0);
            let slope = loglog_slope(&by_frames);
            if let Some(e) = last {
                println!(
                    "{label:<26} {med:>8.2} ms/frame; after {} frames RMSE {:.5}, relative {:.4}; slope vs frames {slope:.2}",
                    args.conv_frames,
                    e.rmse,
                    e.rel_mse.sqrt()
                );
                writeln!(summary, "{label},{med:.3},{},{:.6},{:.6}", args.conv_frames, e.rmse, e.rel_mse)?;
            }
            series.push(Series { name: format!("{label} (slope {slope:.2})"), points });
        }
    }
    std::fs::create_dir_all(&args.out)?;
    std::fs::write(args.out.join("ibl.csv"), summary)?;
    std::fs::write(args.out.join("ibl_convergence.csv"), curves)?;
    let plot = args.out.join("ibl_error_vs_time.png");
    loglog(
        &plot,
        "Image-based lighting: relative error vs GPU time (reference: MCM)",
        "cumulative GPU time (ms)",
        "relative RMSE vs MCM reference",
        &series,
    )?;
    println!("wrote {}", plot.display());
    Ok(())
}

/// RMSE against a long-run reference after 1, 2, 4, … frames, with cumulative GPU time, for each
/// Monte Carlo variant; writes `convergence.csv` and `error_vs_time.png`.
fn convergence(ctx: &Context, args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    use vkengine::metrics::compare;
    use vkengine::plot::{loglog, loglog_slope, Series};
    use vkengine::volume::render::renderer::{McSettings, TransmittanceEstimator};
    let vol = match args.conv_scene.as_str() {
        "cloud" => procedural::cloud([args.n; 3], 0)?,
        "sparse" => procedural::sparse_clouds([args.n; 3], 0)?,
        "sphere" => procedural::smooth_sphere([args.n; 3], 0.45)?,
        other => return Err(format!("--conv-scene {other}: expected cloud, sparse or sphere").into()),
    };
    let tf = TransferFunction::preset("cloud")?;
    let r = VolumeRenderer::new(ctx, &vol, &tf)?;
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    let size = [args.conv_size; 2];
    let base = McSettings { density_scale: args.density, budget: 0, ..Default::default() };
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
    // Efficiency = 1 / (time · MSE): how much sooner a variant reaches a given RMSE, since both
    // fall as n^-1/2. Averaged over the last three power-of-two points to damp timing noise.
    let mut efficiency: Vec<(String, f64)> = Vec::new();
    let mut csv = format!(
        "# device: {} ({}); {} {}^3 density x{}, image {}^2, reference {} frames\nvariant,frames,gpu_ms_cumulative,rmse,rel_mse,psnr_db\n",
        ctx.info.name, ctx.info.driver, args.conv_scene, args.n, base.density_scale, args.conv_size, args.reference_frames
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
        vkengine_demos::output::write_exr(&exr, size[0], size[1], &reference)?;
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
                cum_ms += run.gpu_ms();
                let n = f + 1;
                if n.is_power_of_two() {
                    let e = compare(&t.read_hdr(ctx)?, &reference)?;
                    writeln!(csv, "{label},{n},{cum_ms:.3},{:.6},{:.6},{:.3}", e.rmse, e.rel_mse, e.psnr_db)?;
                    points.push((cum_ms, e.rmse));
                    by_frames.push((n as f64, e.rmse));
                }
            }
            let tail = &points[points.len().saturating_sub(3)..];
            let eff = tail.iter().map(|&(t, e)| 1.0 / (t * e * e)).sum::<f64>() / tail.len().max(1) as f64;
            efficiency.push((label.to_string(), eff));
            let slope = loglog_slope(&by_frames);
            println!(
                "{label:<20} RMSE after {} frames {:.5} in {cum_ms:.0} ms; slope vs frames {slope:.3}",
                args.conv_frames,
                points.last().map(|p| p.1).unwrap_or(0.0)
            );
            series.push(Series { name: format!("{label} (slope {slope:.2})"), points });
        }
    }
    let eff = |name: &str| efficiency.iter().find(|e| e.0 == name).map(|e| e.1);
    let mut summary = String::from("comparison,efficiency_ratio\n");
    for (a, b) in [
        ("MCS grid ratio", "MCS global ratio"),
        ("MCM grid ratio", "MCM global ratio"),
        ("MCS grid residual", "MCS grid ratio"),
        ("MCS grid ratio", "MCS grid delta"),
    ] {
        if let (Some(x), Some(y)) = (eff(a), eff(b)) {
            println!("{a} vs {b}: {:.2}x as efficient (1 / time·MSE)", x / y);
            writeln!(summary, "{a} vs {b},{:.3}", x / y)?;
        }
    }
    std::fs::write(args.out.join("efficiency.csv"), summary)?;
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

/// Variance × time of the shadow-ray estimators, measured on camera rays (the renderer's
/// transmittance test mode) so the image's other noise sources do not hide the difference.
fn transmittance_study(ctx: &Context, args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    use vkengine::volume::render::renderer::{McSettings, TransmittanceEstimator};
    const FRAMES: u64 = 32;
    let size = [args.conv_size; 2];
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    let tf = TransferFunction::preset("cloud")?;
    let mut csv = format!(
        "# device: {} ({}); {}^3 volumes, image {}^2, {FRAMES} independent frames per estimator, majorant grid\n\
         scene,density,estimator,pixels,mean_T,mean_pixel_variance,gpu_ms_per_frame,efficiency_vs_ratio\n",
        ctx.info.name, ctx.info.driver, args.n, args.conv_size
    );
    for (scene, vol) in
        [("cloud", procedural::cloud([args.n; 3], 0)?), ("sphere", procedural::smooth_sphere([args.n; 3], 0.45)?)]
    {
        let r = VolumeRenderer::new(ctx, &vol, &tf)?;
        for density in [1.0f32, 4.0, 16.0, 64.0] {
            let mut rows = Vec::new();
            // The pixel set is chosen once (from the ratio-tracking run) and reused, so all three
            // estimators are compared on the same rays.
            let (mut mask_keep, mut pixels): (Option<Vec<usize>>, usize) = (None, 0);
            for est in
                [TransmittanceEstimator::Ratio, TransmittanceEstimator::ResidualRatio, TransmittanceEstimator::Delta]
            {
                let mc = McSettings {
                    transmittance: est,
                    debug_transmittance: true,
                    density_scale: density,
                    ..Default::default()
                };
                let s = RenderSettings { renderer: RendererKind::Mcs, mc, ..Default::default() };
                let n = (size[0] * size[1]) as usize;
                let mask = mask_keep.clone();
                let (mut sum, mut sum2, mut ms) = (vec![0.0f64; n], vec![0.0f64; n], 0.0);
                for f in 0..FRAMES {
                    // Fresh targets: each frame is one independent estimate per pixel.
                    let mut t = Targets::new(ctx, size)?;
                    let run = render_frame(ctx, &r, &mut t, &cam, &s, f)?;
                    ms += run.gpu_ms();
                    for (i, px) in t.read_hdr(ctx)?.iter().enumerate() {
                        sum[i] += px[0] as f64;
                        sum2[i] += (px[0] as f64).powi(2);
                    }
                }
                let k = FRAMES as f64;
                // Only rays the medium partly attenuates: misses (T = 1) and opaque rays (T = 0)
                // are exact for every estimator and would dilute the comparison.
                let mask: Vec<usize> = match &mask {
                    Some(m) => m.clone(),
                    None => (0..n).filter(|&i| (0.02..0.98).contains(&(sum[i] / k))).collect(),
                };
                let m = mask.len().max(1) as f64;
                let var = mask.iter().map(|&i| (sum2[i] - sum[i] * sum[i] / k) / (k - 1.0)).sum::<f64>() / m;
                let mean = mask.iter().map(|&i| sum[i]).sum::<f64>() / (k * m);
                pixels = mask.len();
                mask_keep = Some(mask);
                rows.push((est, mean, var, ms / k));
            }
            let ratio_eff = 1.0 / (rows[0].2 * rows[0].3);
            for (est, mean, var, ms) in rows {
                let eff = 1.0 / (var * ms) / ratio_eff;
                println!("{scene:<6} x{density:<4} {est:<14?} {pixels} px, T̄ {mean:.4} var {var:.3e} {ms:7.2} ms  efficiency vs ratio {eff:.2}x");
                writeln!(csv, "{scene},{density},{est:?},{pixels},{mean:.5},{var:.4e},{ms:.3},{eff:.3}")?;
            }
        }
    }
    std::fs::create_dir_all(&args.out)?;
    std::fs::write(args.out.join("transmittance.csv"), csv)?;
    println!("wrote {}", args.out.join("transmittance.csv").display());
    Ok(())
}

/// GPU ms per frame of EAM, EAM + depth output, LAO, LAO + spherical light, DOS and DOS + depth
/// (default settings) per scene.
fn occlusion_timings(
    ctx: &Context,
    args: &Args,
    scenes: &[(&str, vkengine::volume::data::Volume, TransferFunction)],
    cam: &Camera,
) -> Result<(), Box<dyn std::error::Error>> {
    use vkengine::volume::render::occlusion::OcclusionSettings;
    let o = OcclusionSettings::default();
    let mut csv = format!(
        "# device: {} ({}); volume {}^3, image {}^2, median of {} frames; {o:?}\nscene,renderer,gpu_ms_median,gpu_ms_min,gpu_ms_max\n",
        ctx.info.name, ctx.info.driver, args.n, args.size, args.frames
    );
    for (name, vol, tf) in scenes {
        let r = VolumeRenderer::new(ctx, vol, tf)?;
        let mut t = Targets::new(ctx, [args.size; 2])?;
        let depth = OcclusionSettings { depth_threshold: Some(0.5), ..o };
        // The spherical light at its defaults (vpt's radius 0.19 and 10 shadow rays), plus ambient.
        let light = OcclusionSettings { lao_light: 1.0, ..o };
        for (label, kind, occ) in [
            ("eam", RendererKind::Eam, o),
            ("eam+depth", RendererKind::Eam, depth),
            ("lao", RendererKind::Lao, o),
            ("lao+light", RendererKind::Lao, light),
            ("dos", RendererKind::Dos, o),
            ("dos+depth", RendererKind::Dos, depth),
        ] {
            let s = RenderSettings { renderer: kind, occlusion: occ, ..Default::default() };
            let mut ms = Vec::new();
            for frame in 0..=args.frames {
                let run = render_frame(ctx, &r, &mut t, cam, &s, frame)?;
                if frame > 0 {
                    ms.push(run.timings.last().map(|t| t.gpu_end_ns as f64 * 1e-6).unwrap_or(0.0));
                }
            }
            ms.sort_by(f64::total_cmp);
            let (med, lo, hi) = (ms[ms.len() / 2], ms[0], ms[ms.len() - 1]);
            println!("{name:<8} {label:<10} {med:>9.2} ms");
            writeln!(csv, "{name},{label},{med:.3},{lo:.3},{hi:.3}")?;
        }
    }
    std::fs::create_dir_all(&args.out)?;
    let path = args.out.join("occlusion.csv");
    std::fs::write(&path, csv)?;
    println!("wrote {}", path.display());
    Ok(())
}
