//! The volume demo's headless run: render `--frames` frames (jittered accumulation), write
//! PNG/EXR (and the depth EXR), a JSON report and `--profile` folders.

use crate::cli::DemoArgs;
use crate::output;
use crate::runner::check_validation;
use crate::stats::PassStats;
use crate::volume_scene::{camera, env_map, input, load_labels, load_scene, volume_setup};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;
use vkengine::vk::Context;
use vkengine::volume::render::denoise::DenoiseSettings;
use vkengine::volume::render::mc_mode::DispatchBound;
use vkengine::volume::render::renderer::{render_frame, RenderSettings, RendererKind, Targets};
use vkengine::volume::render::settings::BUDGET_AUTO;
use vkengine::volume::render::variance::ErrorEstimate;
use vkengine::Result;

#[derive(serde::Serialize)]
struct Report {
    demo: &'static str,
    device: output::DeviceReport,
    volume: VolumeInfo,
    settings: RenderSettings,
    size: [u32; 2],
    frames: u64,
    /// Median GPU ms per pass over all frames.
    passes: Vec<(String, f64)>,
    /// Median GPU ms of the whole frame.
    frame_ms: f64,
    empty_block_fraction: f32,
    wall_ms: f64,
    /// Against `--reference`, on linear HDR values.
    error: Option<vkengine::metrics::ImageError>,
    /// Monte Carlo: the image's own estimate of its relative error (foreground), from each
    /// pixel's second moment; whether the run stopped at `until_error`.
    estimated_error: Option<ErrorEstimate>,
    reached_until_error: Option<bool>,
    /// The image written to `--out`: "denoised" (`denoise=on`, Monte Carlo) or "mean" (the
    /// unbiased progressive mean), and where the mean went beside a denoised image.
    written_image: &'static str,
    mean_written_to: Option<String>,
    majorant_violations: u32,
    /// `mc_budget=auto`'s measurement on this device (whole paths against bounded work), when
    /// one was made, and the budget it resolved to (0: one whole path per frame).
    mc_auto: Option<McAuto>,
    /// Monte Carlo: the shadow rays' transmittance estimator (`transmittance=auto` resolved).
    transmittance: Option<&'static str>,
}

/// `mc_budget=auto`'s choice (`engine/volume/render/mc_calibrate.rs`).
#[derive(serde::Serialize)]
struct McAuto {
    measured: vkengine::volume::render::mc_calibrate::Measured,
    bounded: bool,
    budget: Option<u32>,
}

#[derive(serde::Serialize)]
struct VolumeInfo {
    source: String,
    dims: [u32; 3],
    spacing: [f32; 3],
    value_range: [f32; 2],
    /// The dense grid: dims' product.
    dense_voxels: u64,
    /// Its bytes as the normalized u16 the renderer takes.
    dense_bytes: u64,
    /// Bytes of the volume's images on the GPU as allocated (the volume and its gradient
    /// magnitudes, dense or in brick atlases, and the page table).
    gpu_bytes: u64,
    /// The layout, its bricks (stored, shared uniform slots) and the fraction skipped.
    layout: vkengine::volume::device::layout::LayoutReport,
    /// The brick pyramid level rendered (0: the volume itself; `dims` and `spacing` are the
    /// level's).
    lod_level: u32,
    /// The voxel size rendered: `spacing`, the source's scaled by the level.
    voxel_size: [f32; 3],
    /// `residency=view`: what each frame uploaded and the levels shown at the end.
    residency: Option<ResidencyRun>,
}

/// View-dependent residency over the run (`residency=view`).
#[derive(serde::Serialize, Default)]
struct ResidencyRun {
    /// The per-frame upload budget.
    upload_budget: u64,
    /// Bytes uploaded in each frame (warm-up included), bricks and page-table words, as budgeted.
    bytes_per_frame: Vec<u64>,
    /// Bytes written to the device in each frame (brick slots and changed page words).
    written_per_frame: Vec<u64>,
    /// Frames in which what is shown changed (each restarts the progressive mean).
    changed_frames: Vec<u64>,
    /// Bricks still to upload after the last frame.
    pending: u32,
    /// Level-0 bricks showing each level after the last frame, finest first.
    shown_levels: Vec<u64>,
    /// Resident bricks of each level after the last frame, finest first.
    resident_levels: Vec<u64>,
}

/// Renders the volume demo headless.
pub fn run(args: &DemoArgs) -> Result<()> {
    let ctx = Context::new(&args.context_options())?;
    eprintln!("device: {} ({})", ctx.info.name, ctx.info.driver);
    let setup = volume_setup(args)?;
    let (volume, tf) = load_scene(args, &setup, &ctx)?;
    let labels = load_labels(args, &setup, &volume)?;
    let mut settings = setup.render;
    settings.mc.seed = args.seed as u32;
    // Several frames of an unchanged view average jittered sub-pixel samples (antialiasing).
    // An error target runs until the estimate reaches it, at most `--frames` frames.
    let until = settings.mc.convergence;
    if until.until_error > 0.0 && !matches!(settings.renderer, RendererKind::Mcs | RendererKind::Mcm) {
        return Err(vkengine::Error::Input(format!(
            "--until-error / until_error: only the Monte Carlo renderers (mcs, mcm) estimate their error, not {}",
            settings.renderer.name()
        )));
    }
    let frames = match args.frames {
        Some(f) => f.max(1),
        None if until.until_error > 0.0 => crate::cli::UNTIL_ERROR_FRAMES,
        None => 1,
    };
    settings.jitter = frames > 1;
    let mut renderer = crate::volume_scene::renderer(&ctx, &volume, &tf, &setup)?;
    let mut residency =
        setup.residency.then(|| ResidencyRun { upload_budget: setup.upload_budget, ..Default::default() });
    renderer.set_labels(&ctx, labels.as_ref().map(|(l, t)| (l, t)))?;
    let cam = camera(&setup, &volume, renderer.box_half(), args.size[0] as f32 / args.size[1] as f32);
    renderer.set_environment(&ctx, env_map(&setup)?.as_ref())?;
    crate::volume_scene::set_temperature(&ctx, &mut renderer, &setup, args, &volume)?;
    let mut targets = Targets::new(&ctx, args.size)?;
    let bar = ProgressBar::new(frames);
    if !std::io::stderr().is_terminal() || frames < 8 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed}").map_err(input)?);
    // mc_budget=auto's measurement of this device (mc_calibrate) and pipeline creation are setup,
    // made before the clock starts, not inside the first timed frame: pipelines are created on
    // first use, and llvmpipe compiles a Monte Carlo pipeline for about a second (1.2–1.3 s of a
    // 64² run's first frame, against 18 ms of GPU work). Two throwaway 8×8 frames (a first and
    // an accumulating one) create them, as vpt's harness times its iterations after a warm-up.
    // A residency run is left out: its atlas fills by streaming before each frame, and a render
    // before the first stream would draw from an empty one (its pipelines are created in the
    // first timed frame). The warm-up's majorant violations are not the run's: taken off below.
    let first = renderer.resolve_auto(&ctx, &settings, args.size)?;
    if residency.is_none() {
        let mut scratch = Targets::new(&ctx, [8, 8])?;
        for frame in 0..2 {
            render_frame(&ctx, &renderer, &mut scratch, &cam, &first, frame)?;
        }
    }
    let warmup_violations = renderer.majorant_violations();
    // The view can restart during the run (the mean starts again, and the denoiser reprojects
    // what it showed as a prior) where residency changes the bricks shown, or where auto may
    // switch a GPU from bounded work to whole paths once its rate is measured. Elsewhere the view
    // is still from the first frame to the last.
    let still = residency.is_none()
        && !(settings.mc.budget == BUDGET_AUTO && DispatchBound::of_device(&ctx.info.name) != DispatchBound::LoopLimit);
    let start = Instant::now();
    let mut stats = PassStats::default();
    // mc_budget=auto is decided frame by frame (a GPU's measured step rate may let whole paths
    // replace its cautious first choice; the warm-up frames are where that happens); a numeric
    // budget with `mc_frame_ms` follows the measured frame time.
    let mut steered = settings;
    let mut chosen = None;
    let mut rendered = 0;
    let mut reached = false;
    for frame in 0..args.warmup + frames {
        ctx.set_frame(frame);
        let now = renderer.resolve_auto(&ctx, &steered, args.size)?;
        if settings.mc.budget == BUDGET_AUTO && chosen != Some(now.mc.budget) {
            chosen = Some(now.mc.budget);
            if now.mc_bounded() {
                eprintln!(
                    "mc_budget=auto: bounded work, {} steps per pixel and frame (one whole path could take about {:.0} tracking steps; {})",
                    now.mc.budget,
                    renderer.path_steps(&settings),
                    match renderer.resolve_mc(renderer.dispatch_bound(&ctx.info.name), &steered, args.size) {
                        Ok(whole) if !whole.mc_bounded() => "measured to reach an error sooner on this device",
                        _ => "past what one dispatch may take here",
                    }
                );
            } else if frame > 0 {
                eprintln!("mc_budget=auto: one whole path per frame from frame {frame} (this device's measured rate allows it)");
            }
        }
        if let (Some(rep), Some(run)) =
            (renderer.stream(&ctx, &cam, args.size[0] as f32 / args.size[1] as f32)?, residency.as_mut())
        {
            run.bytes_per_frame.push(rep.upload.bytes);
            run.written_per_frame.push(rep.written_bytes);
            if rep.upload.changed {
                run.changed_frames.push(frame);
            }
            run.pending = rep.upload.pending;
            run.shown_levels = rep.shown_levels;
            run.resident_levels = rep.resident_levels;
        }
        // A run that writes one image of a still view denoises only its last frame: the denoised
        // image then depends only on that frame's mean, moments and features (nothing is
        // reprojected), so the image is the same and the filter runs once, not once per frame.
        // An error target, whose last frame is not known in advance, denoises every frame.
        let last = frame + 1 == args.warmup + frames;
        let denoise_now = last || !still || until.until_error > 0.0;
        let this = RenderSettings {
            denoise: DenoiseSettings { on: steered.denoise.on && denoise_now, ..steered.denoise },
            ..steered
        };
        let run = render_frame(&ctx, &renderer, &mut targets, &cam, &this, frame)?;
        let last_ms = run.gpu_ms();
        steered.mc.budget = steered.mc.steer_budget(steered.mc.budget, last_ms);
        if frame >= args.warmup {
            stats.add(&run.timings);
            bar.inc(1);
            rendered += 1;
            reached = targets.error_estimate().is_some_and(|e| e.reached(&until));
            if reached {
                break;
            }
        }
    }
    bar.finish_and_clear();
    if let Some(r) = residency.as_ref().filter(|r| r.pending > 0) {
        eprintln!(
            "warning: residency=view: {} bricks still to upload after the last frame (more --frames, or a larger upload_budget, lets it settle)",
            r.pending
        );
    }
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let out = args.out.clone().unwrap_or_else(|| format!("out/volume-{}.png", settings.renderer.name()).into());
    let [w, h] = args.size;
    // The image shown is the one written and compared: the denoised one with `denoise=on`.
    let denoised = targets.shows_denoised();
    let hdr = targets.read_shown(&ctx)?;
    let error = match &args.reference {
        Some(path) => {
            let e = vkengine::metrics::compare(&hdr, &vkengine::metrics::load_reference(path, args.size)?)?;
            eprintln!("vs {}: RMSE {:.5}, relMSE {:.5}, PSNR {:.2} dB", path.display(), e.rmse, e.rel_mse, e.psnr_db);
            Some(e)
        }
        None => None,
    };
    let estimated_error = targets.error_estimate();
    if let Some(e) = &estimated_error {
        let rel = e.relative.map_or("not yet known".to_string(), |r| format!("{r:.4}"));
        eprintln!(
            "estimated relative error {rel} (foreground: {} pixels; at least {} paths per pixel{})",
            e.foreground_pixels,
            e.min_paths,
            match e.stopped_tiles {
                0 => String::new(),
                k => format!("; adaptive sampling stopped {k} of {} tiles", e.tiles),
            }
        );
    }
    let reached_until_error = (until.until_error > 0.0).then_some(reached);
    if reached_until_error == Some(false) {
        eprintln!("until_error={}: not reached in {rendered} frames", until.until_error);
    }
    let frames = rendered;
    let violations = renderer.majorant_violations().saturating_sub(warmup_violations);
    if violations > 0 {
        eprintln!("warning: {violations} majorant violations (extinction above its majorant): the estimate is biased");
    }
    if out.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        output::write_exr(&out, w, h, &hdr)?;
    } else {
        output::write_png(&out, w, h, &targets.read_ldr(&ctx)?)?;
    }
    // The unbiased mean beside a denoised image, as linear EXR.
    let mean_written_to = match denoised {
        true => {
            let stem = out.file_stem().map(|s| s.to_string_lossy()).unwrap_or_default();
            let path = out.with_file_name(format!("{stem}-mean.exr"));
            output::write_exr(&path, w, h, &targets.read_hdr(&ctx)?)?;
            eprintln!("wrote {} (the unbiased mean; {} shows the denoised image)", path.display(), out.display());
            Some(path.display().to_string())
        }
        false => None,
    };
    if settings.occlusion.depth_threshold.is_some() {
        // Linear EXR beside the image: R = ray distance, G = NDC depth, B = 1 where the ray hit.
        let path = out
            .with_file_name(format!("{}-depth.exr", out.file_stem().map(|s| s.to_string_lossy()).unwrap_or_default()));
        output::write_exr(&path, w, h, &targets.read_depth(&ctx)?)?;
        eprintln!("wrote {}", path.display());
    }
    let passes = stats.pass_medians();
    let frame_ms = stats.frame_median();
    for (n, ms) in &passes {
        eprintln!("{n:<16} {ms:>8.3} ms");
    }
    eprintln!(
        "wrote {} — {} at {w}x{h}, {frame_ms:.2} ms/frame GPU (median of {frames})",
        out.display(),
        settings.renderer.name()
    );
    if let Some(path) = &args.report {
        let report = Report {
            demo: "volume",
            device: (&ctx.info).into(),
            volume: VolumeInfo {
                source: volume.source.clone(),
                dims: volume.dims,
                spacing: volume.spacing,
                value_range: volume.value_range,
                dense_voxels: volume.dims.iter().map(|&d| u64::from(d)).product(),
                dense_bytes: vkengine::volume::data::image_bytes(volume.dims),
                gpu_bytes: renderer.layout.gpu_bytes,
                layout: renderer.layout,
                lod_level: volume.lod.map_or(0, |l| l.level),
                voxel_size: volume.spacing,
                residency,
            },
            settings,
            size: args.size,
            frames,
            passes,
            frame_ms,
            empty_block_fraction: renderer.empty_fraction,
            wall_ms,
            error,
            estimated_error,
            reached_until_error,
            written_image: if denoised { "denoised" } else { "mean" },
            mean_written_to,
            majorant_violations: violations,
            mc_auto: vkengine::volume::render::mc_calibrate::measured()
                .into_iter()
                .find(|(name, _)| *name == ctx.info.name)
                .map(|(_, measured)| McAuto { measured, bounded: measured.bounded(), budget: chosen }),
            transmittance: matches!(settings.renderer, RendererKind::Mcs | RendererKind::Mcm)
                .then(|| settings.transmittance_estimator().name()),
        };
        output::write_json(path, &report)?;
    }
    stats.write_profile(args, "volume", &ctx)?;
    check_validation(&ctx)
}
