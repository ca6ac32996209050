//! The mesh demos' headless run: render the scene (along its camera path), write PNG/EXR, a
//! JSON report with per-pass GPU times, and `--profile` folders.

use crate::cli::DemoArgs;
use crate::mesh_scene::{load, mesh_setup, settings_origin, view_at};
use crate::output;
use crate::runner::check_validation;
use crate::stats::PassStats;
use std::time::Instant;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::vk::Context;
use vkengine::Result;

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
    /// Triangles each view drew after culling (`cull_triangles`), last frame.
    triangles_kept: Vec<(String, u32)>,
    frame_ms: f64,
    wall_ms: f64,
    error: Option<vkengine::metrics::ImageError>,
    /// Dispatches, barriers and transfer bytes of the last frame.
    commands: vkengine::graph::Commands,
    /// The LPV dispatch layouts measured on this device (`lpv_dispatch=auto`): shape and times.
    lpv_layouts: Vec<LpvLayout>,
}

/// One measured LPV propagation shape (`engine/lpv/passes/calibrate.rs`).
#[derive(serde::Serialize)]
struct LpvLayout {
    shape: vkengine::lpv::passes::calibrate::Shape,
    measured: vkengine::lpv::passes::calibrate::Measured,
    stacked: bool,
}

/// Renders `demo` headless (`builtin`: the scene without `--scene`).
pub fn run(args: &DemoArgs, demo: &str, builtin: &str) -> Result<()> {
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
    let frames = args.frames().max(1);
    let mut stats = PassStats::default();
    let start = Instant::now();
    for frame in 0..args.warmup + frames {
        ctx.set_frame(frame);
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
        Some(path) => Some(vkengine::metrics::compare(&hdr, &vkengine::metrics::load_reference(path, args.size)?)?),
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
    let triangles_kept = if settings.cull_triangles { targets.cull_stats.kept_per_view() } else { Vec::new() };
    if !triangles_kept.is_empty() {
        let total = scene.triangle_count().max(1) as f64;
        let views: Vec<String> =
            triangles_kept.iter().map(|(v, k)| format!("{v} {:.0}%", 100.0 * f64::from(*k) / total)).collect();
        eprintln!("culling kept, of {total} triangles: {}", views.join(", "));
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
            triangles_kept,
            frame_ms,
            wall_ms,
            error,
            commands: stats.frame_commands(),
            lpv_layouts: vkengine::lpv::passes::calibrate::measured()
                .into_iter()
                .map(|(_, shape, measured)| LpvLayout { shape, measured, stacked: measured.stacked() })
                .collect(),
        };
        output::write_json(path, &report)?;
    }
    check_validation(&ctx)
}
