//! The mesh demos' shared program (`cornell`, `atrium`, `scene`): load a scene — built-in, a
//! scene description or a bare model — then render it headless (PNG/EXR, JSON report with
//! per-pass GPU times, Chrome trace) or in a window with a fly camera.

use super::output;
use super::stats::PassStats;
use super::DemoArgs;
use crate::mesh::camera::View;
use crate::mesh::gpu_scene::GpuScene;
use crate::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use crate::mesh::settings::{MeshSetup, SCHEMA};
use crate::scene::{self, Scene};
use crate::settings::{self, Origin, Setting};
use crate::vk::Context;
use crate::{Error, Result};
use std::collections::BTreeMap;
use std::time::Instant;

/// Settings keys the mesh renderer understands (scene file `[settings]` or `--set`), from its schema.
pub fn keys() -> Vec<&'static str> {
    SCHEMA.names()
}

/// Renderer settings: defaults, then the scene file's `[settings]` (`origin` names the file in
/// errors), then `--set` (which wins).
pub fn mesh_setup(origin: &str, file: &BTreeMap<String, String>, sets: &[(String, String)]) -> Result<MeshSetup> {
    let mut all = settings::tagged(file, &Origin::File(origin.to_string()));
    all.extend(sets.iter().map(|(k, v)| Setting::new(k.clone(), v.clone(), Origin::Cli)));
    MeshSetup::parse(&all)
}

/// [`mesh_setup`] for a file named only "scene file": the settings and the RSM edge.
pub fn mesh_settings(file: &BTreeMap<String, String>, sets: &[(String, String)]) -> Result<(MeshSettings, u32)> {
    let s = mesh_setup("scene file", file, sets)?;
    Ok((s.settings, s.rsm_size()))
}

/// How errors name the scene's `[settings]`: its file, or the built-in scene.
pub fn settings_origin(args: &DemoArgs, builtin: &str) -> String {
    args.scene.as_ref().map_or_else(|| format!("built-in scene {builtin}"), |p| p.display().to_string())
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
    let setup = mesh_setup(&settings_origin(args, builtin), &scene.settings, &args.set)?;
    let (settings, rsm) = (setup.settings, setup.rsm_size());
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
