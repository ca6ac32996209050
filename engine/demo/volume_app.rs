//! The volume demo program: MIP / ISO / EAM of a procedural scene (default: a 128³ cloud) or any supported
//! file (`--volume`). Headless: PNG (tone-mapped) or EXR (linear HDR) + JSON report; windowed:
//! drag to orbit, scroll to zoom, 1/2/3 = MIP/ISO/EAM, T = next tone mapper, E = toggle
//! empty-space skipping; the title shows GPU ms per frame.

use crate::demo::{output, DemoArgs};
use crate::settings::{Origin, Setting};
use crate::vk::Context;
use crate::volume::camera::{Camera, Projection};
use crate::volume::data::{self, procedural, Endian, LoadOptions, Volume, VoxelType};
use crate::volume::envmap::EnvMap;
use crate::volume::renderer::{render_frame, RenderSettings, Targets, VolumeRenderer};
use crate::volume::settings::VolumeSetup;
use crate::volume::tf::TransferFunction;
use crate::{Error, Result};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;

fn input(e: impl std::fmt::Display) -> Error {
    Error::Input(e.to_string())
}

/// The volume and its default transfer function, from `--volume` or `--set scene=`.
pub(crate) fn load_scene(
    args: &DemoArgs,
    setup: &VolumeSetup,
    max_dimension: u32,
) -> Result<(Volume, TransferFunction)> {
    let (volume, tf) = if let Some(path) = &args.volume {
        let voxel = match &args.voxel_type {
            Some(t) => {
                Some(VoxelType::from_name(t).ok_or_else(|| Error::Input(format!("--type `{t}`: unknown voxel type")))?)
            }
            None => None,
        };
        let endian = match args.endian.as_deref() {
            None => None,
            Some("little") => Some(Endian::Little),
            Some("big") => Some(Endian::Big),
            Some(e) => return Err(Error::Input(format!("--endian `{e}`: expected little or big"))),
        };
        let opts = LoadOptions {
            dims: args.dims,
            voxel,
            endian,
            spacing: args.spacing,
            allow_negative: args.allow_negative,
            max_dimension,
        };
        (data::load(path, &opts).map_err(input)?, TransferFunction::preset("bone")?)
    } else {
        let d = [setup.n; 3];
        let seed = args.seed as u32;
        match setup.scene {
            "sparse" => (procedural::sparse_clouds(d, seed).map_err(input)?, TransferFunction::preset("cloud")?),
            "sphere" => (procedural::smooth_sphere(d, 0.45).map_err(input)?, TransferFunction::preset("default")?),
            "furnace" => {
                (procedural::homogeneous_box(d, 1.0).map_err(input)?, TransferFunction::constant([1.0; 3], 2.0))
            }
            "box" => {
                (procedural::homogeneous_box(d, 1.0).map_err(input)?, TransferFunction::constant([0.9, 0.6, 0.3], 3.0))
            }
            "checker" => (procedural::checker_shell(d, 8).map_err(input)?, TransferFunction::preset("default")?),
            _ => (procedural::cloud(d, seed).map_err(input)?, TransferFunction::preset("cloud")?),
        }
    };
    for w in &volume.warnings {
        eprintln!("warning: {w}");
    }
    let tf = match &setup.tf {
        Some(name) => TransferFunction::from_arg(name)?,
        None => tf,
    };
    Ok((volume, tf))
}

/// The settings of `--renderer` and `--set` (session files are merged into `--set` by
/// [`VolumeSession::apply`](super::volume_session::VolumeSession::apply), which checks them first).
pub(crate) fn volume_setup(args: &DemoArgs) -> Result<VolumeSetup> {
    let mut all: Vec<Setting> =
        args.renderer.iter().map(|r| Setting::new("renderer", r.clone(), Origin::Flag("--renderer"))).collect();
    all.extend(args.set.iter().map(|(k, v)| Setting::new(k.clone(), v.clone(), Origin::Cli)));
    VolumeSetup::parse(&all)
}

/// The environment map of `env_map=PATH` (`.exr`/`.hdr`), or `env_map=sky` for the
/// procedural sky (sun towards the MC sun direction); `None` without the setting.
pub(crate) fn env_map(setup: &VolumeSetup) -> Result<Option<EnvMap>> {
    match setup.env_map.as_deref() {
        None => Ok(None),
        Some("sky") => Ok(Some(EnvMap::procedural_sky(512, 256, [0.4, 0.8, 0.45])?)),
        Some(path) => EnvMap::load(std::path::Path::new(path)).map(Some),
    }
}

pub(crate) fn camera(setup: &VolumeSetup) -> Camera {
    let projection = match setup.camera {
        "ortho" => Projection::Orthographic { height: 1.6 },
        _ => Projection::Perspective { fov_y: 0.8 },
    };
    Camera::orbit(setup.distance, setup.yaw, setup.pitch, projection)
}

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
    error: Option<crate::metrics::ImageError>,
    majorant_violations: u32,
}

#[derive(serde::Serialize)]
struct VolumeInfo {
    source: String,
    dims: [u32; 3],
    spacing: [f32; 3],
    value_range: [f32; 2],
}

fn headless(args: &DemoArgs) -> Result<()> {
    let ctx = Context::new(&args.context_options())?;
    eprintln!("device: {} ({})", ctx.info.name, ctx.info.driver);
    let setup = volume_setup(args)?;
    let (volume, tf) = load_scene(args, &setup, ctx.info.limits.max_image_dimension3_d)?;
    let mut settings = setup.render;
    // Several frames of an unchanged view average jittered sub-pixel samples (antialiasing).
    settings.jitter = args.frames > 1;
    let cam = camera(&setup);
    let mut renderer = VolumeRenderer::new(&ctx, &volume, &tf)?;
    renderer.set_environment(&ctx, env_map(&setup)?.as_ref())?;
    let mut targets = Targets::new(&ctx, args.size)?;
    let frames = args.frames.max(1);
    let bar = ProgressBar::new(frames);
    if !std::io::stderr().is_terminal() || frames < 8 {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed}").map_err(input)?);
    let start = Instant::now();
    let mut stats = crate::demo::stats::PassStats::default();
    for frame in 0..args.warmup + frames {
        let run = render_frame(&ctx, &renderer, &mut targets, &cam, &settings, frame)?;
        if frame >= args.warmup {
            stats.add(&run.timings);
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let out = args.out.clone().unwrap_or_else(|| format!("out/volume-{}.png", settings.renderer.name()).into());
    let [w, h] = args.size;
    let hdr = targets.read_hdr(&ctx)?;
    let error = match &args.reference {
        Some(path) => {
            let e = crate::metrics::compare(&hdr, &crate::metrics::load_reference(path, args.size)?)?;
            eprintln!("vs {}: RMSE {:.5}, relMSE {:.5}, PSNR {:.2} dB", path.display(), e.rmse, e.rel_mse, e.psnr_db);
            Some(e)
        }
        None => None,
    };
    if let Some(w) = renderer.loop_limit_warning(&ctx.info.name, &settings) {
        eprintln!("warning: {w}");
    }
    let violations = renderer.majorant_violations();
    if violations > 0 {
        eprintln!("warning: {violations} majorant violations (extinction above its majorant): the estimate is biased");
    }
    if out.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        output::write_exr(&out, w, h, &hdr)?;
    } else {
        output::write_png(&out, w, h, &targets.read_ldr(&ctx)?)?;
    }
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
            },
            settings,
            size: args.size,
            frames,
            passes,
            frame_ms,
            empty_block_fraction: renderer.empty_fraction,
            wall_ms,
            error,
            majorant_violations: violations,
        };
        output::write_json(path, &report)?;
    }
    stats.write_profile(args, "volume", &ctx)?;
    crate::demo::check_validation(&ctx)
}

/// Runs the volume demo with parsed arguments: a window if there is a display, else headless.
/// `--scene` names a session file (what the window's "Save scene" writes).
pub fn run(args: &DemoArgs) -> Result<()> {
    let args = &super::volume_session::VolumeSession::apply(args)?;
    if args.windowed() {
        super::volume_window::run(args)
    } else {
        headless(args)
    }
}

/// Runs the volume demo: parses the shared command line, renders, exits with the conventional code.
pub fn main() {
    let args = DemoArgs::parse();
    if let Err(e) = run(&args) {
        eprintln!("error: {e}");
        std::process::exit(crate::demo::exit_code(&e));
    }
}
