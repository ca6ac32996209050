//! The mesh demos' shared program (`cornell`, `atrium`, `scene`): load a scene — built-in, a
//! scene description or a bare model — then render it headless (PNG/EXR, JSON report with
//! per-pass GPU times, Chrome trace) or in a window with a fly camera.

use super::cli::setting;
use super::output;
use super::stats::PassStats;
use super::DemoArgs;
use crate::lpv::settings::{FixedPoint, Injection, Propagation};
use crate::mesh::camera::View;
use crate::mesh::gpu_scene::GpuScene;
use crate::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use crate::post::ToneMap;
use crate::scene::{self, Scene};
use crate::vk::Context;
use crate::{Error, Result};
use std::collections::BTreeMap;
use std::time::Instant;

/// Settings keys the mesh renderer understands (scene file `[settings]` or `--set`).
pub const KEYS: &[&str] = &[
    "shadow_tile",
    "cascades",
    "cascade_lambda",
    "shadow_distance",
    "pcf",
    "ambient",
    "sky",
    "exposure",
    "tonemap",
    "rsm",
    "lpv",
    "lpv_size",
    "lpv_cascades",
    "lpv_extent",
    "lpv_steps",
    "lpv_injection",
    "lpv_propagation",
    "lpv_offset",
    "lpv_sample_offset",
    "lpv_occlusion",
    "lpv_fixed_point",
    "lpv_intensity",
    "lpv_preset",
    "lpv_reuse",
    "lpv_damping",
    "lpv_directional",
    "lpv_sky",
    "lpv_subsurface",
    "lpv_glossy",
    "soft_shadows",
    "sun_angle",
    "spot_radius",
    "sun_rays",
    "sun_rays_intensity",
    "sun_rays_decay",
    "sun_rays_samples",
    "fog",
    "fog_density",
    "fog_albedo",
    "fog_g",
    "fog_steps",
    "fog_bounds",
];

/// Renderer settings: defaults, then the scene file's `[settings]`, then `--set` (which wins).
pub fn mesh_settings(file: &BTreeMap<String, String>, sets: &[(String, String)]) -> Result<(MeshSettings, u32)> {
    let mut all: Vec<(String, String)> = file.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
    all.extend(sets.iter().cloned());
    if let Some((k, _)) = all.iter().find(|(k, _)| !KEYS.contains(&k.as_str())) {
        return Err(Error::Input(format!(
            "setting `{k}` is not known to the mesh renderer (known: {})",
            KEYS.join(", ")
        )));
    }
    // `setting` takes a key's last occurrence, and `--set` comes after the file, so it wins.
    let last = all;
    let mut s = MeshSettings::default();
    s.shadow_tile = setting(&last, "shadow_tile")?.unwrap_or(s.shadow_tile);
    s.cascades = setting(&last, "cascades")?.unwrap_or(s.cascades);
    s.cascade_lambda = setting(&last, "cascade_lambda")?.unwrap_or(s.cascade_lambda);
    s.shadow_distance = setting(&last, "shadow_distance")?.unwrap_or(s.shadow_distance);
    s.pcf_radius = setting(&last, "pcf")?.unwrap_or(s.pcf_radius);
    s.exposure = setting(&last, "exposure")?.unwrap_or(s.exposure);
    if let Some(a) = setting::<f32>(&last, "ambient")? {
        s.ambient = [a; 3];
    }
    if let Some(a) = setting::<f32>(&last, "sky")? {
        s.sky = [a; 3];
    }
    s.soft_shadows = setting::<u32>(&last, "soft_shadows")?.map_or(s.soft_shadows, |v| v != 0);
    s.sun_angle = setting(&last, "sun_angle")?.unwrap_or(s.sun_angle);
    s.spot_radius = setting(&last, "spot_radius")?.unwrap_or(s.spot_radius);
    s.sun_rays = setting::<u32>(&last, "sun_rays")?.map_or(s.sun_rays, |v| v != 0);
    s.sun_rays_intensity = setting(&last, "sun_rays_intensity")?.unwrap_or(s.sun_rays_intensity);
    s.sun_rays_decay = setting(&last, "sun_rays_decay")?.unwrap_or(s.sun_rays_decay);
    s.sun_rays_samples = setting(&last, "sun_rays_samples")?.unwrap_or(s.sun_rays_samples);
    s.lpv_glossy = setting::<u32>(&last, "lpv_glossy")?.map_or(s.lpv_glossy, |v| v != 0);
    if let Some(t) = setting::<String>(&last, "tonemap")? {
        s.tonemap =
            ToneMap::parse(&t).ok_or_else(|| Error::Input(format!("tonemap={t}: expected reinhard, aces or range")))?;
    }
    // A preset first, so individual lpv_* keys can still adjust it.
    match setting::<String>(&last, "lpv_preset")?.as_deref() {
        None | Some("engine") => {}
        Some("thesis") => s.lpv = s.lpv.thesis(),
        Some(v) => return Err(Error::Input(format!("lpv_preset={v}: expected engine or thesis"))),
    }
    let l = &mut s.lpv;
    l.enabled = setting::<u32>(&last, "lpv")?.unwrap_or(0) != 0;
    l.size = setting(&last, "lpv_size")?.unwrap_or(l.size);
    l.cascades = setting(&last, "lpv_cascades")?.unwrap_or(l.cascades);
    l.extent = setting(&last, "lpv_extent")?.unwrap_or(l.extent);
    l.steps = setting(&last, "lpv_steps")?.unwrap_or(l.steps);
    l.vpl_offset = setting(&last, "lpv_offset")?.unwrap_or(l.vpl_offset);
    l.sample_offset = setting(&last, "lpv_sample_offset")?.unwrap_or(l.sample_offset);
    l.intensity = setting(&last, "lpv_intensity")?.unwrap_or(l.intensity);
    l.occlusion = setting::<u32>(&last, "lpv_occlusion")?.map_or(l.occlusion, |v| v != 0);
    l.reuse = setting::<u32>(&last, "lpv_reuse")?.map_or(l.reuse, |v| v != 0);
    l.damping = setting::<u32>(&last, "lpv_damping")?.map_or(l.damping, |v| v != 0);
    l.directional = setting::<u32>(&last, "lpv_directional")?.map_or(l.directional, |v| v != 0);
    l.sky = setting(&last, "lpv_sky")?.unwrap_or(l.sky);
    l.subsurface = setting::<u32>(&last, "lpv_subsurface")?.map_or(l.subsurface, |v| v != 0);
    if let Some(v) = setting::<String>(&last, "lpv_injection")? {
        l.injection = Injection::parse(&v)
            .ok_or_else(|| Error::Input(format!("lpv_injection={v}: expected atomic, float, gather or raster")))?;
    }
    if let Some(v) = setting::<String>(&last, "lpv_propagation")? {
        l.propagation = match v.as_str() {
            "gather" => Propagation::Gather,
            "scatter" => Propagation::Scatter,
            _ => return Err(Error::Input(format!("lpv_propagation={v}: expected gather or scatter"))),
        };
    }
    if let Some(v) = setting::<String>(&last, "lpv_fixed_point")? {
        l.fixed_point = match v.as_str() {
            "auto" => FixedPoint::Auto,
            "thesis" => FixedPoint::Thesis,
            _ => return Err(Error::Input(format!("lpv_fixed_point={v}: expected auto or thesis"))),
        };
    }
    let f = &mut s.fog;
    f.enabled = setting::<u32>(&last, "fog")?.unwrap_or(0) != 0;
    f.density = setting(&last, "fog_density")?.unwrap_or(f.density);
    f.albedo = setting(&last, "fog_albedo")?.unwrap_or(f.albedo);
    f.g = setting(&last, "fog_g")?.unwrap_or(f.g);
    f.steps = setting(&last, "fog_steps")?.unwrap_or(f.steps);
    if let Some(v) = setting::<String>(&last, "fog_bounds")? {
        f.bounds = crate::mesh::fog::FogBounds::parse(&v)?;
    }
    // The LPV's light comes from the RSM: turning it on brings a default RSM along.
    let rsm = setting(&last, "rsm")?.unwrap_or(if s.lpv.enabled { 256u32 } else { 0 });
    s.validate()?;
    Ok((s, rsm))
}

/// Loads `--scene FILE` or the demo's built-in scene.
pub fn load(args: &DemoArgs, builtin: &str) -> Result<(Scene, f64)> {
    let start = Instant::now();
    let scene = match &args.scene {
        Some(path) => scene::load_scene(path)?,
        None => builtin_scene(builtin)?,
    };
    Ok((scene, start.elapsed().as_secs_f64() * 1e3))
}

/// Names of the built-in scenes.
pub const BUILTIN: &[&str] = &["cornell", "atrium"];

/// A built-in scene by name.
pub fn builtin_scene(name: &str) -> Result<Scene> {
    match name {
        "cornell" => Ok(scene::procedural::cornell_box()),
        "atrium" => Ok(scene::procedural::atrium()),
        _ => Err(Error::Input(format!("unknown built-in scene `{name}` (expected {})", BUILTIN.join(" or ")))),
    }
}

/// The view at `frame` of `frames`: along the scene's camera path if it has one.
pub fn view_at(scene: &Scene, frame: u64, frames: u64) -> View {
    let cam = match &scene.camera_path {
        Some(path) if frames > 1 => {
            let t0 = path.keys.first().map_or(0.0, |k| k.time);
            let t1 = path.keys.last().map_or(0.0, |k| k.time);
            path.at(t0 + (t1 - t0) * frame as f32 / (frames - 1) as f32, &scene.camera)
        }
        _ => scene.camera,
    };
    View::look_at(cam.position.into(), cam.target.into(), cam.up.into(), cam.fov_y_deg, cam.near, cam.far)
}

#[derive(serde::Serialize)]
struct SceneInfo {
    source: String,
    meshes: usize,
    triangles: usize,
    materials: usize,
    textures: usize,
    load_ms: f64,
    warnings: Vec<String>,
}

#[derive(serde::Serialize)]
struct Report {
    demo: String,
    device: output::DeviceReport,
    scene: SceneInfo,
    settings: MeshSettings,
    rsm_size: u32,
    size: [u32; 2],
    frames: u64,
    passes: Vec<(String, f64)>,
    frame_ms: f64,
    wall_ms: f64,
    error: Option<crate::metrics::ImageError>,
}

fn headless(args: &DemoArgs, demo: &str, builtin: &str) -> Result<()> {
    let ctx = Context::new(&args.context_options())?;
    eprintln!("device: {} ({})", ctx.info.name, ctx.info.driver);
    let (scene, load_ms) = load(args, builtin)?;
    let (settings, rsm) = mesh_settings(&scene.settings, &args.set)?;
    eprintln!(
        "scene: {} triangles, {} materials, loaded in {load_ms:.0} ms",
        scene.triangle_count(),
        scene.materials.len()
    );
    let gpu = GpuScene::upload(&ctx, &scene)?;
    let renderer = MeshRenderer::new(&ctx)?;
    let mut targets = MeshTargets::new(&ctx, args.size, rsm)?;
    let frames = args.frames.max(1);
    let mut stats = PassStats::default();
    let start = Instant::now();
    for frame in 0..args.warmup + frames {
        let at = frame.saturating_sub(args.warmup);
        let run = render_frame(&ctx, &renderer, &gpu, &mut targets, &view_at(&scene, at, frames), &settings)?;
        if frame >= args.warmup {
            stats.add(&run.timings);
        }
    }
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let [w, h] = args.size;
    let out = args.out.clone().unwrap_or_else(|| format!("out/{demo}.png").into());
    let hdr = targets.read_hdr(&ctx)?;
    let error = match &args.reference {
        Some(path) => Some(crate::metrics::compare(&hdr, &crate::metrics::load_reference(path, args.size)?)?),
        None => None,
    };
    if out.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        output::write_exr(&out, w, h, &hdr)?;
    } else {
        output::write_png(&out, w, h, &targets.read_ldr(&ctx)?)?;
    }
    let passes = stats.pass_medians();
    for (n, ms) in &passes {
        eprintln!("{n:<16} {ms:>8.3} ms");
    }
    let frame_ms = stats.frame_median();
    eprintln!("wrote {} — {demo} at {w}x{h}, {frame_ms:.2} ms/frame GPU (median of {frames})", out.display());
    stats.write_profile(args, demo, &ctx)?;
    if let Some(path) = &args.report {
        let report = Report {
            demo: demo.into(),
            device: (&ctx.info).into(),
            scene: SceneInfo {
                source: args.scene.as_ref().map_or_else(|| format!("builtin:{builtin}"), |p| p.display().to_string()),
                meshes: scene.meshes.len(),
                triangles: scene.triangle_count(),
                materials: scene.materials.len(),
                textures: scene.textures.len(),
                load_ms,
                warnings: scene.warnings.clone(),
            },
            settings,
            rsm_size: rsm,
            size: args.size,
            frames,
            passes,
            frame_ms,
            wall_ms,
            error,
        };
        output::write_json(path, &report)?;
    }
    super::check_validation(&ctx)
}

/// Runs a mesh demo with parsed arguments (`builtin`: the scene without `--scene`).
pub fn run(args: &DemoArgs, demo: &str, builtin: &str) -> Result<()> {
    if args.windowed() {
        super::mesh_window::run(args, demo, builtin)
    } else {
        headless(args, demo, builtin)
    }
}

/// Runs a mesh demo: parses the shared command line, renders, and exits with the conventional code.
pub fn main(demo: &str, builtin: &str) {
    use clap::Parser;
    let args = DemoArgs::parse();
    if let Err(e) = run(&args, demo, builtin) {
        eprintln!("error: {e}");
        std::process::exit(super::exit_code(&e));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_overrides_the_scene_file_which_overrides_the_default() {
        let file: BTreeMap<String, String> = [("lpv_steps", "6"), ("pcf", "3"), ("lpv", "1")]
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        let sets = vec![("lpv_steps".to_string(), "2".to_string()), ("lpv".to_string(), "0".to_string())];
        let (from_file, _) = mesh_settings(&file, &[]).expect("file");
        assert_eq!((from_file.lpv.steps, from_file.pcf_radius, from_file.lpv.enabled), (6, 3, true));
        let (overridden, _) = mesh_settings(&file, &sets).expect("file + --set");
        assert_eq!((overridden.lpv.steps, overridden.pcf_radius, overridden.lpv.enabled), (2, 3, false));
        // Repeated --set: the last one wins.
        let twice = vec![("pcf".to_string(), "1".to_string()), ("pcf".to_string(), "2".to_string())];
        assert_eq!(mesh_settings(&file, &twice).expect("twice").0.pcf_radius, 2);
    }
}
