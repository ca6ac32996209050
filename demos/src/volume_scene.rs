//! What the volume demo's headless run and window share: the volume (procedural or a file) and
//! its default transfer function, the settings of `--renderer` and `--set`, the environment
//! map and the orbit camera.

use crate::cli::DemoArgs;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::time::{Duration, Instant};
use vkengine::settings::{Origin, Setting};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection, Rig};
use vkengine::volume::data::labels::LabelVolume;
use vkengine::volume::data::{self, procedural, DeviceBudget, Endian, IntoBricks, LoadOptions, Volume, VoxelType};
use vkengine::volume::device::layout::VolumeLayout;
use vkengine::volume::optics::envmap::EnvMap;
use vkengine::volume::optics::label_table::LabelTable;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::optics::tf_choice;
use vkengine::volume::render::renderer::VolumeRenderer;
use vkengine::volume::render::settings::VolumeSetup;
use vkengine::{Error, Result};

pub(crate) fn input(e: impl std::fmt::Display) -> Error {
    Error::Input(e.to_string())
}

/// The device memory a volume may take on `ctx`'s device (the engine's measure).
pub fn device_budget(ctx: &Context) -> DeviceBudget {
    vkengine::volume::device::layout::device_budget(ctx)
}

/// The renderer for `volume` as `setup` asks: in its `volume_layout`, or kept resident by the view
/// (`residency=view`) within `gpu_memory` (default: the device-local heap) and `upload_budget`.
pub fn renderer(ctx: &Context, volume: &Volume, tf: &TransferFunction, setup: &VolumeSetup) -> Result<VolumeRenderer> {
    match setup.residency {
        true => {
            let budget = setup.gpu_memory.unwrap_or(device_budget(ctx).heap_bytes);
            VolumeRenderer::with_residency(ctx, volume, tf, budget, setup.upload_budget)
        }
        false => VolumeRenderer::with_layout(ctx, volume, tf, setup.layout),
    }
}

/// A progress bar for a load, drawn only once the load has taken more than a second.
fn load_progress() -> (ProgressBar, impl FnMut(u64, u64)) {
    let bar = ProgressBar::hidden();
    if let Ok(style) = ProgressStyle::with_template("loading {bar:40} {bytes}/{total_bytes} {elapsed}") {
        bar.set_style(style);
    }
    let (start, b) = (Instant::now(), bar.clone());
    let mut shown = false;
    let update = move |done: u64, total: u64| {
        if !shown && start.elapsed() > Duration::from_secs(1) {
            b.set_draw_target(ProgressDrawTarget::stderr());
            shown = true;
        }
        b.set_length(total);
        b.set_position(done);
    };
    (bar, update)
}

/// Whether a load builds bricks as it reads: where `layout` may store the volume sparse.
fn into_bricks(layout: VolumeLayout, max_image_3d: u32) -> Option<IntoBricks> {
    match layout {
        VolumeLayout::Dense => None,
        VolumeLayout::Sparse => Some(IntoBricks { always: true, max_image_3d }),
        VolumeLayout::Auto => Some(IntoBricks { always: false, max_image_3d }),
    }
}

/// The volume and its default transfer function, from `--volume` or `--set scene=`, refused
/// before loading when `ctx`'s device cannot hold it.
pub fn load_scene(args: &DemoArgs, setup: &VolumeSetup, ctx: &Context) -> Result<(Volume, TransferFunction)> {
    // Past the 3D-image limit a volume is stored in bricks, whose page directory (one word per
    // 8³ bricks, a 3D image) has the limit.
    let max_dimension = ctx
        .info
        .limits
        .max_image_dimension3_d
        .saturating_mul(vkengine::volume::data::bricks::BRICK * vkengine::volume::data::bricks::page_table::PAGE);
    let (volume, tf): (Volume, Option<TransferFunction>) = if let Some(path) = &args.volume {
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
        // `gpu_memory` stands for the heap: a volume past it is refused or shown coarser.
        let mut budget = device_budget(ctx);
        budget.heap_bytes = budget.heap_bytes.min(setup.gpu_memory.unwrap_or(u64::MAX));
        let opts = LoadOptions {
            dims: args.dims,
            voxel,
            endian,
            spacing: args.spacing,
            allow_negative: args.allow_negative,
            max_dimension,
            series: args.series.clone(),
            frame: args.frame,
            grid: args.grid.clone(),
            // Residency keeps the whole volume on the host and chooses levels per view itself.
            device: (!setup.residency).then_some(budget),
            bricks: into_bricks(setup.layout, ctx.info.limits.max_image_dimension3_d).filter(|_| !setup.residency),
            lod: setup.lod.filter(|_| !setup.residency),
            gpu_memory: setup.gpu_memory.filter(|_| !setup.residency),
            ..LoadOptions::default()
        };
        let (bar, mut progress) = load_progress();
        let loaded = data::load_with_progress(path, &opts, &mut progress);
        bar.finish_and_clear();
        // A file's function comes from its data (units, modality, histogram).
        (loaded.map_err(input)?, None)
    } else {
        let d = [setup.n; 3];
        // Refused before generating: a 1024³ scene is 4 GiB of f32 on the host alone.
        let source = format!("procedural {} {}x{}x{}", setup.scene, d[0], d[1], d[2]);
        device_budget(ctx).check(&source, d.map(u64::from)).map_err(input)?;
        let seed = args.seed as u32;
        match setup.scene {
            "sparse" => (procedural::sparse_clouds(d, seed).map_err(input)?, Some(TransferFunction::preset("cloud")?)),
            "sphere" => {
                (procedural::smooth_sphere(d, 0.45).map_err(input)?, Some(TransferFunction::preset("default")?))
            }
            "furnace" => {
                (procedural::homogeneous_box(d, 1.0).map_err(input)?, Some(TransferFunction::constant([1.0; 3], 2.0)))
            }
            "box" => (
                procedural::homogeneous_box(d, 1.0).map_err(input)?,
                Some(TransferFunction::constant([0.9, 0.6, 0.3], 3.0)),
            ),
            "checker" => (procedural::checker_shell(d, 8).map_err(input)?, Some(TransferFunction::preset("default")?)),
            _ => (procedural::cloud(d, seed).map_err(input)?, Some(TransferFunction::preset("cloud")?)),
        }
    };
    for w in &volume.warnings {
        eprintln!("warning: {w}");
    }
    let tf = match (&setup.tf, tf) {
        (Some(name), _) => tf_choice::named(name, &volume)?,
        (None, Some(scene)) => scene,
        (None, None) => {
            let (tf, line) = tf_choice::for_volume(None, &volume)?;
            // The choice is printed so it can be kept (or changed) with --set tf=.
            if let Some(line) = line {
                eprintln!("{line}");
            }
            tf
        }
    };
    Ok((volume, tf))
}

/// The label map of `--labels` / `labels=` with its colour table (palette, the file's segment
/// colours, then `label_colors=`), refused when its grid differs from `volume`'s.
pub fn load_labels(args: &DemoArgs, setup: &VolumeSetup, volume: &Volume) -> Result<Option<(LabelVolume, LabelTable)>> {
    let Some(path) = setup.labels.labels.as_deref() else {
        if setup.labels.colors.is_some() {
            return Err(Error::Input("label_colors: no label map is loaded (--labels FILE)".into()));
        }
        if setup.render.labels.opacity.iter().any(|&a| a >= 0.0) {
            return Err(Error::Input("label_opacity: no label map is loaded (--labels FILE)".into()));
        }
        return Ok(None);
    };
    let path = std::path::Path::new(path);
    let opts = LoadOptions { spacing: args.spacing, max_dimension: u32::MAX, ..LoadOptions::default() };
    let labels = vkengine::volume::data::labels::load_labels(path, &opts).map_err(input)?;
    let scan_dirs = args.volume.as_deref().and_then(vkengine::volume::data::labels::nrrd_directions);
    labels.check_grid(volume, scan_dirs).map_err(input)?;
    let table = LabelTable::with_colors(&labels, setup.labels.colors.as_deref().map(std::path::Path::new))?;
    Ok(Some((labels, table)))
}

/// The settings of `--renderer` and `--set` (session files are merged into `--set` by
/// [`VolumeSession::apply`](crate::volume_session::VolumeSession::apply), which checks them first).
pub fn volume_setup(args: &DemoArgs) -> Result<VolumeSetup> {
    let mut all: Vec<Setting> =
        args.renderer.iter().map(|r| Setting::new("renderer", r.clone(), Origin::Flag("--renderer"))).collect();
    all.extend(args.until_error.iter().map(|e| Setting::new("until_error", e.clone(), Origin::Flag("--until-error"))));
    all.extend(args.labels.iter().map(|l| Setting::new("labels", l.clone(), Origin::Flag("--labels"))));
    all.extend(args.set.iter().map(|(k, v)| Setting::new(k.clone(), v.clone(), Origin::Cli)));
    VolumeSetup::parse(&all)
}

/// The environment map of `env_map=PATH` (`.exr`/`.hdr`), or `env_map=sky` for the
/// procedural sky (sun towards the MC sun direction); `None` without the setting.
pub fn env_map(setup: &VolumeSetup) -> Result<Option<EnvMap>> {
    match setup.env_map.as_deref() {
        None => Ok(None),
        Some("sky") => Ok(Some(EnvMap::procedural_sky(512, 256, [0.4, 0.8, 0.45])?)),
        Some(path) => EnvMap::load(std::path::Path::new(path)).map(Some),
    }
}

/// Sets `renderer`'s temperature grid from `temperature_grid=NAME`: that grid of the `--volume`
/// OpenVDB file, which must share the density grid's box and voxel size (`volume`: the density
/// as loaded); removes it without the setting.
pub fn set_temperature(
    ctx: &Context,
    renderer: &mut vkengine::volume::render::renderer::VolumeRenderer,
    setup: &VolumeSetup,
    args: &DemoArgs,
    volume: &Volume,
) -> Result<()> {
    let Some(name) = &setup.temperature_grid else {
        return renderer.set_temperature(ctx, None);
    };
    let Some(path) = args.volume.as_ref().filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("vdb")))
    else {
        return Err(Error::Input(format!("temperature_grid={name}: needs an OpenVDB file as --volume")));
    };
    let opts = LoadOptions { grid: Some(name.clone()), device: Some(device_budget(ctx)), ..LoadOptions::default() };
    let t = data::load(path, &opts).map_err(input)?;
    let what = format!("{} (temperature_grid={name})", path.display());
    vkengine::volume::render::temperature::check_same_box(&what, volume, &t)?;
    renderer.set_temperature(ctx, Some((&t, setup.temperature_range)))
}

/// The orbit camera of the `camera`, `distance`, `yaw` and `pitch` settings. Without a
/// `distance` it frames the object in `volume` (in its box `±box_half`) in a view of `aspect`;
/// a scan in patient axes is shown superior up, seen from the front.
pub fn camera(setup: &VolumeSetup, volume: &Volume, box_half: glam::Vec3, aspect: f32) -> Camera {
    let ortho = setup.camera == "ortho";
    let projection = match ortho {
        true => Projection::Orthographic { height: setup.height.unwrap_or(1.0) },
        false => Projection::Perspective { fov_y: 0.8 },
    };
    let mut cam = Camera::orbit(1.0, setup.yaw, setup.pitch, projection);
    if volume.patient_axes {
        cam.basis = Camera::PATIENT;
    }
    // Framed first, unless the settings state everything framing would set (it scans every
    // voxel); what they state replaces the framed values, so a saved session, which states them
    // all, replays whatever the data or the transfer function.
    if setup.distance.is_none() || setup.target.is_none() || (ortho && setup.height.is_none()) {
        let (centre, half) = vkengine::volume::camera::framing::object_box(volume, box_half);
        cam = cam.framed(centre, half, aspect, FILL);
    }
    if let Rig::Orbit { target, distance, .. } = &mut cam.rig {
        *target = setup.target.map_or(*target, glam::Vec3::from);
        *distance = setup.distance.unwrap_or(*distance);
    }
    if let (Projection::Orthographic { height }, Some(h)) = (&mut cam.projection, setup.height) {
        *height = h;
    }
    cam
}

/// Fraction of the view's width or height the framed volume fills (the tighter of the two).
const FILL: f32 = 0.9;
