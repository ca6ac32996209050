//! The volume demo program: MIP / ISO / EAM of a procedural scene (default: a 128³ cloud) or any supported
//! file (`--volume`). Headless: PNG (tone-mapped) or EXR (linear HDR) + JSON report; windowed:
//! drag to orbit, scroll to zoom, 1/2/3 = MIP/ISO/EAM, T = next tone mapper, E = toggle
//! empty-space skipping; the title shows GPU ms per frame.

use crate::demo::cli::setting;
use crate::demo::{output, DemoArgs};
use crate::vk::Context;
use crate::volume::camera::{Camera, Projection};
use crate::volume::data::{self, procedural, Endian, LoadOptions, Volume, VoxelType};
use crate::volume::envmap::EnvMap;
use crate::volume::phase::PhaseFunction;
use crate::volume::renderer::{
    render_frame, RenderSettings, RendererKind, Targets, ToneMap, TransmittanceEstimator, VolumeRenderer,
};
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
pub(crate) fn load_scene(args: &DemoArgs, max_dimension: u32) -> Result<(Volume, TransferFunction)> {
    let n: u32 = setting(&args.set, "n")?.unwrap_or(128);
    if !(2..=1024).contains(&n) {
        return Err(Error::Input(format!("--set n={n}: procedural size must be in 2..=1024")));
    }
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
        let scene: String = setting(&args.set, "scene")?.unwrap_or_else(|| "cloud".into());
        let d = [n; 3];
        match scene.as_str() {
            "cloud" => (procedural::cloud(d, args.seed as u32).map_err(input)?, TransferFunction::preset("cloud")?),
            "sparse" => {
                (procedural::sparse_clouds(d, args.seed as u32).map_err(input)?, TransferFunction::preset("cloud")?)
            }
            "sphere" => (procedural::smooth_sphere(d, 0.45).map_err(input)?, TransferFunction::preset("default")?),
            "furnace" => {
                (procedural::homogeneous_box(d, 1.0).map_err(input)?, TransferFunction::constant([1.0; 3], 2.0))
            }
            "box" => {
                (procedural::homogeneous_box(d, 1.0).map_err(input)?, TransferFunction::constant([0.9, 0.6, 0.3], 3.0))
            }
            "checker" => (procedural::checker_shell(d, 8).map_err(input)?, TransferFunction::preset("default")?),
            s => {
                return Err(Error::Input(format!(
                    "--set scene={s}: expected cloud, sparse, sphere, box, checker or furnace"
                )))
            }
        }
    };
    for w in &volume.warnings {
        eprintln!("warning: {w}");
    }
    let tf = match setting::<String>(&args.set, "tf")? {
        Some(name) => TransferFunction::from_arg(&name)?,
        None => tf,
    };
    Ok((volume, tf))
}

/// Phase function name, g (g1), g2 and w when `--set` gives none.
pub(crate) const PHASE_DEFAULT: (&str, f32, f32, f32) = ("hg", 0.3, -0.3, 0.7);

pub(crate) fn render_settings(args: &DemoArgs) -> Result<RenderSettings> {
    let mut s = RenderSettings::default();
    if let Some(r) = &args.renderer {
        s.renderer = RendererKind::parse(r)?;
    }
    s.exposure = setting(&args.set, "exposure")?.unwrap_or(1.0);
    s.tonemap = match setting::<String>(&args.set, "tonemap")?.as_deref() {
        None | Some("reinhard") => ToneMap::Reinhard,
        Some("range") => ToneMap::Range { lo: 0.0, hi: 1.0 },
        Some("aces") => ToneMap::Aces,
        Some(t) => return Err(Error::Input(format!("--set tonemap={t}: expected reinhard, range or aces"))),
    };
    s.iso = setting(&args.set, "iso")?.unwrap_or(0.5);
    s.step = setting(&args.set, "step")?;
    s.empty_space_skipping = setting::<u32>(&args.set, "ess")?.unwrap_or(1) != 0;
    s.termination = setting(&args.set, "termination")?.unwrap_or(1e-3);
    s.background = [setting(&args.set, "background")?.unwrap_or(0.02f32); 3];
    let finite = |v: f32, name: &str, lo: f32, hi: f32| {
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(Error::Input(format!("--set {name}={v}: must be in [{lo}, {hi}]")))
        }
    };
    finite(s.exposure, "exposure", 1e-4, 1e4)?;
    finite(s.iso, "iso", 0.0, 1.0)?;
    finite(s.termination, "termination", 0.0, 1.0)?;
    if let Some(step) = s.step {
        finite(step, "step", 1e-4, 0.5)?;
    }
    let o = &mut s.occlusion;
    o.lao_radius = setting(&args.set, "lao_radius")?.unwrap_or(o.lao_radius);
    o.lao_samples = setting(&args.set, "lao_samples")?.unwrap_or(o.lao_samples);
    o.lao_steps = setting(&args.set, "lao_steps")?.unwrap_or(o.lao_steps);
    o.dos_angle = setting(&args.set, "dos_angle")?.unwrap_or(o.dos_angle);
    o.dos_slices = setting(&args.set, "dos_slices")?.unwrap_or(o.dos_slices);
    o.depth_threshold = setting(&args.set, "depth_threshold")?;
    o.lao_light = setting(&args.set, "lao_light")?.unwrap_or(o.lao_light);
    if let Some(v) = setting::<String>(&args.set, "lao_light_pos")? {
        let parts: Vec<&str> = v.split(',').collect();
        let xyz: Vec<f32> = parts.iter().filter_map(|p| p.trim().parse().ok()).collect();
        o.lao_light_pos = match xyz[..] {
            [x, y, z] if parts.len() == 3 => [x, y, z],
            _ => return Err(Error::Input(format!("--set lao_light_pos={v}: expected three numbers X,Y,Z"))),
        };
    }
    o.lao_light_radius = setting(&args.set, "lao_light_radius")?.unwrap_or(o.lao_light_radius);
    o.lao_light_samples = setting(&args.set, "lao_light_samples")?.unwrap_or(o.lao_light_samples);
    o.lao_ambient = setting(&args.set, "lao_ambient")?.unwrap_or(o.lao_ambient);
    o.validate()?;
    let mc = &mut s.mc;
    mc.density_scale = setting(&args.set, "density")?.unwrap_or(1.0);
    finite(mc.density_scale, "density", 1e-6, 1e6)?;
    let g: f32 = setting(&args.set, "g")?.unwrap_or(PHASE_DEFAULT.1);
    finite(g, "g", -1.0, 1.0)?;
    let g2: f32 = setting(&args.set, "g2")?.unwrap_or(PHASE_DEFAULT.2);
    finite(g2, "g2", -1.0, 1.0)?;
    let w: f32 = setting(&args.set, "w")?.unwrap_or(PHASE_DEFAULT.3);
    finite(w, "w", 0.0, 1.0)?;
    let phase = match setting::<String>(&args.set, "phase")?.as_deref().unwrap_or(PHASE_DEFAULT.0) {
        "iso" => PhaseFunction::Isotropic,
        "hg" => PhaseFunction::HenyeyGreenstein { g },
        "schlick" => PhaseFunction::Schlick { g },
        "rayleigh" => PhaseFunction::Rayleigh,
        "hg-mix" => PhaseFunction::HgMixture { g1: g, g2, w },
        "schlick-mix" => PhaseFunction::SchlickMixture { g1: g, g2, w },
        p => {
            return Err(Error::Input(format!(
                "--set phase={p}: expected iso, hg, schlick, rayleigh, hg-mix or schlick-mix"
            )))
        }
    };
    mc.phase = phase.to_gpu();
    if setting::<u32>(&args.set, "sun")? == Some(0) {
        mc.sun_dir = None;
    }
    if let Some(i) = setting::<f32>(&args.set, "point")? {
        finite(i, "point", 0.0, 1e9)?;
        // A point light above and in front of the volume; its intensity is the flag's value.
        mc.point_light = Some(([0.6, 0.9, 0.8], [i; 3]));
    }
    if let Some(e) = setting::<f32>(&args.set, "env")? {
        finite(e, "env", 0.0, 1e6)?;
        mc.env_radiance = [e; 3];
    }
    mc.env_map = setting::<String>(&args.set, "env_map")?.is_some();
    mc.env_intensity = setting(&args.set, "env_intensity")?.unwrap_or(1.0);
    finite(mc.env_intensity, "env_intensity", 0.0, 1e6)?;
    mc.env_rotation_deg = setting(&args.set, "env_rotation")?.unwrap_or(0.0);
    finite(mc.env_rotation_deg, "env_rotation", -360.0, 360.0)?;
    mc.hybrid = setting(&args.set, "hybrid")?.unwrap_or(0.0);
    finite(mc.hybrid, "hybrid", 0.0, 1.0)?;
    mc.max_events = setting(&args.set, "bounces")?.unwrap_or(mc.max_events);
    if !(1..=4096).contains(&mc.max_events) {
        return Err(Error::Input(format!("--set bounces={}: must be in 1..=4096", mc.max_events)));
    }
    mc.majorant_grid = match setting::<String>(&args.set, "majorant")?.as_deref() {
        None | Some("grid") => true,
        Some("global") => false,
        Some(m) => return Err(Error::Input(format!("--set majorant={m}: expected grid or global"))),
    };
    mc.transmittance = match setting::<String>(&args.set, "transmittance")?.as_deref() {
        None | Some("ratio") => TransmittanceEstimator::Ratio,
        Some("residual") => TransmittanceEstimator::ResidualRatio,
        Some("delta") => TransmittanceEstimator::Delta,
        Some(t) => return Err(Error::Input(format!("--set transmittance={t}: expected ratio, residual or delta"))),
    };
    Ok(s)
}

/// The environment map of `--set env_map=PATH` (`.exr`/`.hdr`), or `env_map=sky` for the
/// procedural sky (sun towards the MC sun direction); `None` without the setting.
pub(crate) fn env_map(args: &DemoArgs) -> Result<Option<EnvMap>> {
    match setting::<String>(&args.set, "env_map")?.as_deref() {
        None => Ok(None),
        Some("sky") => Ok(Some(EnvMap::procedural_sky(512, 256, [0.4, 0.8, 0.45])?)),
        Some(path) => EnvMap::load(std::path::Path::new(path)).map(Some),
    }
}

pub(crate) fn camera(args: &DemoArgs) -> Result<Camera> {
    let projection = match setting::<String>(&args.set, "camera")?.as_deref() {
        None | Some("persp") => Projection::Perspective { fov_y: 0.8 },
        Some("ortho") => Projection::Orthographic { height: 1.6 },
        Some(c) => return Err(Error::Input(format!("--set camera={c}: expected persp or ortho"))),
    };
    let yaw = setting(&args.set, "yaw")?.unwrap_or(0.6f32);
    let pitch = setting(&args.set, "pitch")?.unwrap_or(0.35f32);
    let distance = setting(&args.set, "distance")?.unwrap_or(2.0f32);
    Ok(Camera::orbit(distance, yaw, pitch, projection))
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
    let (volume, tf) = load_scene(args, ctx.info.limits.max_image_dimension3_d)?;
    let mut settings = render_settings(args)?;
    // Several frames of an unchanged view average jittered sub-pixel samples (antialiasing).
    settings.jitter = args.frames > 1;
    let cam = camera(args)?;
    let mut renderer = VolumeRenderer::new(&ctx, &volume, &tf)?;
    renderer.set_environment(&ctx, env_map(args)?.as_ref())?;
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
