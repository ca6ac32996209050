//! `lpv_bench --sweep thesis-config`: the LPV thesis' benchmark configuration on the built-in
//! scenes — 4 cascades × 32³, 8 propagation steps, 65,536 VPLs (a 256² RSM), at 640×360 and
//! 1280×720 — with the geometry volume off (the thesis' plain configuration) and on, and the LPV
//! off as the baseline; then how the cost grows with grid size (16³…128³) and cascades (1–4).
//! Timing only (no reference image): per-pass medians of GPU timestamps, written as
//! `thesis_config.csv` (one row per pass), `thesis_summary.csv` and `thesis-growth.png`.

use crate::stats::PassStats;
use glam::{Quat, Vec3};
use std::fmt::Write as _;
use std::path::Path;
use vkengine::graph::Commands;
use vkengine::lpv::settings::{LpvSettings, StepDispatch};
use vkengine::mesh::camera::View;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::plot::{loglog, Series};
use vkengine::vk::Context;

/// Warm-up and timed frames per configuration (the comparison: median of 10 after 3).
const WARMUP: u64 = 3;
const FRAMES: u64 = 10;
/// The thesis' RSM edge: 65,536 VPLs.
const RSM: u32 = 256;

/// One configuration's medians.
struct Row {
    scene: String,
    size: [u32; 2],
    /// `lpv off`, `plain` (no geometry volume), `occlusion`, or a growth label.
    label: String,
    grid: u32,
    cascades: u32,
    /// Cascades the frame actually built.
    built: usize,
    lpv: bool,
    occlusion: bool,
    passes: Vec<(String, f64)>,
    /// Median frame, or the mean over a walk.
    frame_ms: f64,
    /// A walk's slowest frame and the cascades it computed per frame on average.
    walk: Option<(f64, f64)>,
    /// Share of the machine's CPU time the hypervisor gave to others while the configuration
    /// ran (Linux `steal`), when known: on a shared VM a run with much of it is slow throughout.
    steal: Option<f64>,
    /// What the last measured frame recorded: the whole frame, and its propagation's dispatches.
    commands: Commands,
    propagate_dispatches: u32,
}

/// The passes [`Row::propagate_ms`] counts as propagation.
fn is_propagation(n: &str) -> bool {
    n.starts_with("lpv propagate")
        || n.starts_with("lpv accumulate")
        || n.starts_with("lpv clear step")
        || n.starts_with("lpv bricks")
}

/// The last frame's commands: the whole frame, and the propagation's dispatches.
fn frame_commands(stats: &PassStats) -> (Commands, u32) {
    let last = stats.timings.last().map_or(&[][..], |f| f.as_slice());
    let propagation = last.iter().filter(|t| is_propagation(&t.name)).map(|t| t.commands.dispatches).sum();
    (Commands::total(last.iter().map(|t| &t.commands)), propagation)
}

/// The `cpu` line of /proc/stat: (steal, total) jiffies, on Linux.
fn cpu_times() -> Option<(u64, u64)> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let fields: Vec<u64> = stat.lines().next()?.split_whitespace().skip(1).filter_map(|f| f.parse().ok()).collect();
    Some((*fields.get(7)?, fields.iter().take(8).sum()))
}

/// The steal share of CPU time since `before` (a [`cpu_times`] reading).
fn steal_since(before: Option<(u64, u64)>) -> Option<f64> {
    match (before, cpu_times()) {
        (Some((s0, t0)), Some((s1, t1))) if t1 > t0 => Some((s1 - s0) as f64 / (t1 - t0) as f64),
        _ => None,
    }
}

impl Row {
    fn sum(&self, f: impl Fn(&str) -> bool) -> f64 {
        self.passes.iter().filter(|(n, _)| f(n)).map(|(_, ms)| ms).sum()
    }
    fn inject_ms(&self) -> f64 {
        self.sum(|n| n.starts_with("lpv inject") || n == "lpv resolve")
    }
    fn propagate_ms(&self) -> f64 {
        self.sum(is_propagation)
    }
    fn lpv_ms(&self) -> f64 {
        self.sum(|n| n.starts_with("lpv"))
    }
    /// The lighting pass with its cascade blend (and the blend list's clear), where the LPV is on.
    fn lighting_ms(&self) -> f64 {
        self.sum(|n| n == "lighting" || n.starts_with("cascade blend"))
    }
}

/// The finest cascade is an eighth of the scene's largest side, so all four cascades are built
/// (with `lpv_extent=0` one grid holds a built-in scene and no coarser one is made), as they are
/// in the thesis' Sibenik view.
/// Every configuration but `reused` recomputes the LPV each frame, as a moving light needs;
/// `… dense` ones propagate every brick every step (`lpv_sparse=false`), one cascade per
/// dispatch; `… stacked` ones every cascade in one dense dispatch per step; the others let the
/// device's measurement choose (`lpv_dispatch=auto`).
fn settings(grid: u32, cascades: u32, lpv: bool, occlusion: bool, side: f32, label: &str) -> MeshSettings {
    let lpv = LpvSettings {
        enabled: lpv,
        size: grid,
        cascades,
        extent: side / 8.0,
        steps: 8,
        occlusion,
        reuse: label == "reused" || label.starts_with("walk"),
        sparse: !label.ends_with("dense"),
        dispatch: match label {
            l if l.ends_with("stacked") => StepDispatch::Stacked,
            l if l.ends_with("dense") => StepDispatch::Cascades,
            _ => StepDispatch::Auto,
        },
        ..Default::default()
    };
    MeshSettings { lpv, ..Default::default() }
}

#[allow(clippy::too_many_arguments)]
fn measure(
    ctx: &Context,
    renderer: &MeshRenderer,
    scene: (&str, &GpuScene, &View, f32),
    size: [u32; 2],
    label: &str,
    (grid, cascades): (u32, u32),
    lpv: bool,
    occlusion: bool,
) -> vkengine::Result<Row> {
    let (name, gpu, view, side) = scene;
    let s = settings(grid, cascades, lpv, occlusion, side, label);
    // No RSM without the LPV: the baseline frame is what a scene without it renders.
    let mut targets = MeshTargets::new(ctx, size, if lpv { RSM } else { 0 })?;
    let mut stats = PassStats::default();
    let before = cpu_times();
    for frame in 0..WARMUP + FRAMES {
        let run = render_frame(ctx, renderer, gpu, &mut targets, view, &s)?;
        if frame >= WARMUP {
            stats.add(&run.timings);
        }
    }
    let (commands, propagate_dispatches) = frame_commands(&stats);
    let row = Row {
        scene: name.to_string(),
        size,
        label: label.to_string(),
        grid,
        cascades,
        built: targets.lpv_cascades.len(),
        lpv,
        occlusion,
        passes: stats.pass_medians(),
        frame_ms: stats.frame_median(),
        walk: None,
        steal: steal_since(before),
        commands,
        propagate_dispatches,
    };
    println!(
        "{:<8} {}x{:<4} {:<13} {} built  inject {:>7.2}  propagate {:>7.2}  LPV {:>7.2}  lighting {:>7.2}  frame {:>7.2} ms{}",
        row.scene,
        size[0],
        size[1],
        row.label,
        row.built,
        row.inject_ms(),
        row.propagate_ms(),
        row.lpv_ms(),
        row.lighting_ms(),
        row.frame_ms,
        row.steal.map_or(String::new(), |s| format!("  (steal {:.0} %)", 100.0 * s))
    );
    Ok(row)
}

/// Frames of the walk, after [`WARMUP`] frames along the same path.
const WALK_FRAMES: u64 = 30;

/// The walk's view at `frame`: from the scene's view, 1.4 m/s forward (level) while turning
/// 10 °/s to the left, at 30 frames a second.
fn walk_view(start: &View, frame: u64) -> View {
    let t = frame as f32 / 30.0;
    let f = Vec3::from(start.forward);
    let level = Vec3::new(f.x, 0.0, f.z).normalize_or_zero();
    View {
        position: (Vec3::from(start.position) + level * 1.4 * t).into(),
        forward: (Quat::from_rotation_y((10.0 * t).to_radians()) * f).into(),
        ..*start
    }
}

/// A walk with a static light, LPV on (`walk`: each frame computes only the cascades the
/// camera moved, and keeps the RSM) or off: per-pass and frame means over the walk's frames,
/// so a pass some frames skip counts at its average share.
fn measure_walk(
    ctx: &Context,
    renderer: &MeshRenderer,
    scene: (&str, &GpuScene, &View, f32),
    size: [u32; 2],
    lpv: bool,
    follow_slack: f32,
) -> vkengine::Result<Row> {
    let (name, gpu, view, side) = scene;
    let label = match (lpv, follow_slack > 0.0) {
        (false, _) => "walk lpv off".to_string(),
        (true, false) => "walk".to_string(),
        (true, true) => format!("walk follow {follow_slack}"),
    };
    let mut s = settings(32, 4, lpv, false, side, &label);
    s.lpv.follow_slack = follow_slack;
    // One dispatch per cascade: the walk counts the cascades it computed by their first steps.
    s.lpv.dispatch = StepDispatch::Cascades;
    let mut targets = MeshTargets::new(ctx, size, if lpv { RSM } else { 0 })?;
    let mut stats = PassStats::default();
    let mut computed = 0usize;
    let before = cpu_times();
    for frame in 0..WARMUP + WALK_FRAMES {
        let run = render_frame(ctx, renderer, gpu, &mut targets, &walk_view(view, frame), &s)?;
        if frame >= WARMUP {
            stats.add(&run.timings);
            // One first step per cascade computed.
            computed += run.timings.iter().filter(|t| t.name.starts_with("lpv propagate 1 (")).count();
        }
    }
    let (mean, max) = stats.frame_mean_max();
    let (commands, propagate_dispatches) = frame_commands(&stats);
    let row = Row {
        scene: name.to_string(),
        size,
        label,
        grid: 32,
        cascades: 4,
        built: targets.lpv_cascades.len(),
        lpv,
        occlusion: false,
        passes: stats.pass_means(),
        frame_ms: mean,
        walk: Some((max, computed as f64 / WALK_FRAMES as f64)),
        steal: steal_since(before),
        commands,
        propagate_dispatches,
    };
    println!(
        "{:<8} {}x{:<4} {:<13} mean frame {:>7.2} ms, slowest {:>7.2}, LPV {:>6.2}, RSM {:>6.2}, lighting {:>6.2}, {:.2} cascades computed a frame{}",
        row.scene,
        size[0],
        size[1],
        row.label,
        mean,
        max,
        row.lpv_ms(),
        row.sum(|n| n == "rsm" || n == "rsm cull"),
        row.lighting_ms(),
        computed as f64 / WALK_FRAMES as f64,
        row.steal.map_or(String::new(), |s| format!("  (steal {:.0} %)", 100.0 * s))
    );
    Ok(row)
}

/// Runs the sweep on `scenes` (built-in names, or scene files: a `.toml` with its camera and
/// lights, or a bare model) and writes its CSVs and plot into `out`.
/// `quick`: only the four 640×360 configurations (for A/B runs of two builds).
pub fn run(ctx: &Context, out: &Path, scenes: &[String], quick: bool) -> Result<(), Box<dyn std::error::Error>> {
    let renderer = MeshRenderer::new(ctx)?;
    let mut rows = Vec::new();
    for name in scenes {
        let path = Path::new(name);
        let scene = match crate::mesh_scene::builtin_scene(name) {
            Ok(s) => s,
            Err(_) if path.exists() => vkengine::scene::load_scene(path)?,
            Err(_) => {
                let msg = format!("--scene {name}: neither a built-in scene (cornell, atrium) nor an existing file");
                return Err(Box::new(vkengine::Error::Input(msg)));
            }
        };
        let name = path.file_stem().map_or(name.clone(), |s| s.to_string_lossy().into_owned());
        let name = name.as_str();
        let view = crate::mesh_scene::view_at(&scene, 0, 1);
        let gpu = GpuScene::upload(ctx, &scene)?;
        let side = scene.bounds.size().into_iter().fold(0.0f32, f32::max);
        let sc = (name, &gpu, &view, side);
        let sizes: &[[u32; 2]] = if quick { &[[640, 360]] } else { &[[640, 360], [1280, 720]] };
        for &size in sizes {
            rows.push(measure(ctx, &renderer, sc, size, "lpv off", (32, 4), false, false)?);
            rows.push(measure(ctx, &renderer, sc, size, "plain", (32, 4), true, false)?);
            rows.push(measure(ctx, &renderer, sc, size, "plain dense", (32, 4), true, false)?);
            rows.push(measure(ctx, &renderer, sc, size, "plain stacked", (32, 4), true, false)?);
            rows.push(measure(ctx, &renderer, sc, size, "occlusion", (32, 4), true, true)?);
            rows.push(measure(ctx, &renderer, sc, size, "occl. dense", (32, 4), true, true)?);
            rows.push(measure(ctx, &renderer, sc, size, "occl. stacked", (32, 4), true, true)?);
            // Static light and geometry: the first frame's LPV serves the rest (only its read).
            rows.push(measure(ctx, &renderer, sc, size, "reused", (32, 4), true, false)?);
            // A moving camera, static light: the LPV computes the cascades that moved.
            rows.push(measure_walk(ctx, &renderer, sc, size, false, 0.0)?);
            rows.push(measure_walk(ctx, &renderer, sc, size, true, 0.0)?);
            // The same walk with cascades that lag up to 2 cells behind the camera.
            rows.push(measure_walk(ctx, &renderer, sc, size, true, 2.0)?);
        }
        if quick {
            continue;
        }
        let size = [640, 360];
        for grid in [16, 64, 128] {
            // A grid past the device's buffer limits is a clear error, and a skipped row.
            match measure(ctx, &renderer, sc, size, &format!("grid {grid}"), (grid, 4), true, false) {
                Ok(row) => rows.push(row),
                Err(vkengine::Error::Input(e)) => println!("{name} grid {grid}: skipped: {e}"),
                Err(e) => return Err(e.into()),
            }
        }
        for cascades in 1..=3 {
            rows.push(measure(ctx, &renderer, sc, size, &format!("cascades {cascades}"), (32, cascades), true, false)?);
        }
    }
    let header = format!(
        "# device: {} ({}); {WARMUP} warm-up + median of {FRAMES} frames; RSM {RSM}² ({} VPLs), 8 steps, finest cascade 1/8 of the scene, LPV recomputed every frame but in `reused` and `walk` (walks: means over {WALK_FRAMES} frames after {WARMUP}, 1.4 m/s while turning 10°/s at 30 fps, static light)\n",
        ctx.info.name,
        ctx.info.driver,
        RSM * RSM
    );
    let mut passes = header.clone() + "scene,width,height,config,grid,cascades,built,lpv,occlusion,pass,gpu_ms\n";
    let mut summary = header
        + "scene,width,height,config,grid,cascades,built,lpv,occlusion,inject_ms,propagate_ms,lpv_ms,lighting_ms,\
           lpv_read_ms,frame_ms,lpv_share,steal,frame_max_ms,cascades_per_frame,dispatches,barriers,transfer_mb,\
           propagate_dispatches\n";
    for r in &rows {
        let key = format!(
            "{},{},{},{},{},{},{},{},{}",
            r.scene, r.size[0], r.size[1], r.label, r.grid, r.cascades, r.built, r.lpv, r.occlusion
        );
        for (pass, ms) in &r.passes {
            // Pass names hold commas ("lpv propagate 1 (gather, cascade 0)"): quoted (RFC 4180).
            writeln!(passes, "{key},\"{}\",{ms:.4}", pass.replace('"', "\"\""))?;
        }
        // The LPV read: lighting with the LPV minus lighting without it, same scene and size
        // (a walk against the walk without it).
        let walk = |o: &Row| o.walk.is_some();
        let off = rows.iter().find(|o| o.scene == r.scene && o.size == r.size && !o.lpv && walk(o) == walk(r));
        let read = match (r.lpv, off) {
            (true, Some(o)) => format!("{:.3}", r.lighting_ms() - o.lighting_ms()),
            _ => String::new(),
        };
        writeln!(
            summary,
            "{key},{:.3},{:.3},{:.3},{:.3},{read},{:.3},{:.3},{},{},{},{},{:.3},{}",
            r.inject_ms(),
            r.propagate_ms(),
            r.lpv_ms(),
            r.lighting_ms(),
            r.frame_ms,
            r.lpv_ms() / r.frame_ms.max(1e-9),
            r.steal.map_or(String::new(), |s| format!("{s:.3}")),
            r.walk.map_or(",".to_string(), |(max, c)| format!("{max:.3},{c:.2}")),
            r.commands.dispatches,
            r.commands.barriers,
            r.commands.transfer_bytes as f64 / 1e6,
            r.propagate_dispatches
        )?;
    }
    std::fs::write(out.join("thesis_config.csv"), passes)?;
    std::fs::write(out.join("thesis_summary.csv"), summary)?;
    // Growth with grid size (4 cascades) and cascades (32³): all LPV passes and propagation.
    let mut series = Vec::new();
    // Rows that computed an LPV (not `reused`, whose LPV passes were skipped), sparse.
    let plotted = |r: &&Row| r.label != "reused" && r.walk.is_none() && !r.label.ends_with("dense");
    for r in rows.iter().filter(|r| r.lpv && !r.occlusion && r.size == [640, 360]).filter(plotted) {
        let grid_row = r.cascades == 4;
        let cells = f64::from(r.grid).powi(3) * f64::from(r.cascades);
        for (what, ms) in [("all LPV", r.lpv_ms()), ("propagation", r.propagate_ms())] {
            let name = format!("{} {what}, {}", r.scene, if grid_row { "16³…128³ × 4" } else { "32³ × 1…4" });
            match series.iter_mut().find(|s: &&mut Series| s.name == name) {
                Some(s) => s.points.push((cells, ms.max(1e-3))),
                None => series.push(Series { name, points: vec![(cells, ms.max(1e-3))] }),
            }
        }
    }
    for s in &mut series {
        s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    loglog(&out.join("thesis-growth.png"), "LPV cost vs cells (640×360, 8 steps)", "cells", "GPU ms", &series)?;
    println!("wrote {}", out.join("thesis_summary.csv").display());
    Ok(())
}
