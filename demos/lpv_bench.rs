//! LPV benchmark: GPU ms per pass group and error against the CPU one-bounce reference, for each
//! injection and propagation variant over grid size, propagation steps, VPL count (RSM size),
//! cascades, and the thesis preset. Writes CSV + plots under `results/lpv_bench/`.
//!
//! Error is measured on the indirect light alone: the LPV frame minus the same frame without
//! LPV (ambient off), against the reference's one-bounce indirect image, over pixels that see a
//! surface: relative RMSE, the energy ratio Σ LPV / Σ reference, and — in the atrium — leakage:
//! the mean indirect radiance the LPV puts into the closed east room (the reference's is exactly
//! 0: no light can enter it) seen from inside, relative to the reference's mean indirect radiance
//! in the main view.

use clap::Parser;
use std::fmt::Write as _;
use std::path::PathBuf;
use vkengine::lpv::settings::{Injection, LpvSettings, Propagation};
use vkengine::mesh::camera::View;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::reference::{ReferenceSettings, Tracer};
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::plot::{loglog, Series};
use vkengine::scene::Scene;
use vkengine::vk::{Context, ContextOptions};
use vkengine_demos::mesh_scene::{builtin_scene, view_at};
use vkengine_demos::stats::PassStats;

#[derive(Parser)]
#[command(about = "LPV benchmark: time and error of every variant against a path-traced reference")]
struct Args {
    /// Output folder.
    #[arg(long, default_value = "results/lpv_bench")]
    out: PathBuf,
    /// Image size (the reference is path-traced at this size on the CPU).
    #[arg(long, default_value = "160x120", value_parser = vkengine_demos::cli::parse_size)]
    size: [u32; 2],
    /// Reference samples per pixel.
    #[arg(long, default_value_t = 256)]
    samples: u32,
    /// Timed frames per configuration (after one warm-up frame).
    #[arg(long, default_value_t = 3)]
    frames: u64,
    /// Skip the largest configurations (64³ grids, 1024² RSM, 64 steps; `thesis-config`: only
    /// the 640×360 rows).
    #[arg(long)]
    quick: bool,
    /// Scenes to run (repeatable); default: cornell and atrium (`thesis-config`: atrium). The
    /// `thesis-config` sweep also takes a scene file (`.toml` with camera and lights, or a model).
    #[arg(long = "scene")]
    scenes: Vec<String>,
    /// `variants`: every injection/propagation variant over its sizes (the timing tables);
    /// `accuracy`: error over grid size × steps and shading knobs, every indirect image saved;
    /// `transport`: the propagation scheme alone in free space (CPU twin, no GPU), irradiance
    /// from a point source against the exact 1/(4πr²).
    /// `extensions`: each LPV extension on and off (`extensions.csv`: the passes it adds and
    /// their ms, and the error change).
    /// `thesis-config`: the thesis' benchmark configuration (4 × 32³, 8 steps, 65,536 VPLs) at
    /// 640×360 and 1280×720, per-pass timing only, and its growth with grid size and cascades.
    #[arg(long, default_value = "variants", value_parser = ["variants", "accuracy", "transport", "extensions", "thesis-config"])]
    sweep: String,
}

/// One measured configuration.
struct Row {
    scene: &'static str,
    label: String,
    lpv: LpvSettings,
    rsm: u32,
    inject_ms: f64,
    propagate_ms: f64,
    lpv_ms: f64,
    rel_rmse: f64,
    energy: f64,
    leak: Option<f64>,
    /// Every pass's median GPU ms (the extensions sweep compares pass lists).
    passes: Vec<(String, f64)>,
    /// Sky light rows: (relative RMSE, energy ratio) of the sky term against the reference's.
    sky: Option<(f64, f64)>,
}

/// A rendered HDR frame and its per-pass median GPU ms.
type Frame = (Vec<[f32; 4]>, Vec<(String, f64)>);

struct Bench<'a> {
    ctx: &'a Context,
    renderer: MeshRenderer,
    args: &'a Args,
}

struct SceneData {
    name: &'static str,
    gpu: GpuScene,
    view: View,
    reference: Vec<[f32; 4]>,
    /// The reference's sky term (sky radiance: the renderer's default background).
    sky_reference: Vec<[f32; 4]>,
    hit: Vec<bool>,
    direct: Vec<[f32; 4]>,
    /// The atrium's closed east room seen from inside, and its direct-only frame.
    leak_view: Option<(View, Vec<[f32; 4]>)>,
    /// Mean reference indirect radiance over hit pixels (leakage is relative to it).
    ref_mean: f64,
    /// Display scale for the indirect-light images (so the reference's mean maps to mid-grey).
    exposure: f32,
}

/// Writes indirect radiance as a PNG, `x·k / (1 + x·k)` per channel, for side-by-side viewing.
fn save_indirect(path: &std::path::Path, [w, h]: [u32; 2], img: &[[f32; 4]], k: f32) -> vkengine::Result<()> {
    let bytes: Vec<u8> = img
        .iter()
        .flat_map(|p| {
            let t = |v: f32| {
                let x = (v.max(0.0) * k) / (1.0 + v.max(0.0) * k);
                (x.powf(1.0 / 2.2) * 255.0).round() as u8
            };
            [t(p[0]), t(p[1]), t(p[2]), 255]
        })
        .collect();
    vkengine_demos::output::write_png(path, w, h, &bytes)
}

impl Bench<'_> {
    fn render_with(
        &self,
        sd: &SceneData,
        view: &View,
        settings: &MeshSettings,
        rsm: u32,
        frames: u64,
    ) -> vkengine::Result<Frame> {
        let settings = *settings;
        let mut targets = MeshTargets::new(self.ctx, self.args.size, rsm)?;
        let mut stats = PassStats::default();
        for frame in 0..=frames {
            let run = render_frame(self.ctx, &self.renderer, &sd.gpu, &mut targets, view, &settings)?;
            if frame > 0 {
                stats.add(&run.timings);
            }
        }
        Ok((targets.read_hdr(self.ctx)?, stats.pass_medians()))
    }

    fn measure(&self, sd: &SceneData, label: String, lpv: LpvSettings, rsm: u32) -> vkengine::Result<Row> {
        let settings = MeshSettings { ambient: [0.0; 3], shadow_tile: 512, lpv, ..Default::default() };
        self.measure_with(sd, label, &settings, rsm)
    }

    /// Renders `settings` (whose LPV part is the measured configuration) and scores its indirect light.
    fn measure_with(&self, sd: &SceneData, label: String, settings: &MeshSettings, rsm: u32) -> vkengine::Result<Row> {
        let lpv = settings.lpv;
        let (img, passes) = self.render_with(sd, &sd.view, settings, rsm, self.args.frames)?;
        let save = match self.args.sweep.as_str() {
            "accuracy" | "extensions" => true,
            _ => label == "propagate Gather steps 8" || label == "propagate Gather steps 4",
        };
        if save {
            let ind: Vec<[f32; 4]> =
                img.iter().zip(&sd.direct).map(|(a, d)| [a[0] - d[0], a[1] - d[1], a[2] - d[2], 1.0]).collect();
            let name = if self.args.sweep != "variants" {
                format!("{}-indirect-{}.png", sd.name, label.replace([' ', '^'], "-"))
            } else {
                format!("{}-lpv-indirect-{}steps.png", sd.name, lpv.steps)
            };
            save_indirect(&self.args.out.join(name), self.args.size, &ind, sd.exposure)?;
        }
        let sum = |f: &dyn Fn(&str) -> bool| passes.iter().filter(|(n, _)| f(n)).map(|(_, ms)| ms).sum::<f64>();
        let inject_ms = sum(&|n| n.starts_with("lpv inject") || n == "lpv resolve");
        let propagate_ms = sum(&|n| {
            n.starts_with("lpv propagate") || n.starts_with("lpv accumulate") || n.starts_with("lpv clear step")
        });
        let lpv_ms = sum(&|n| n.starts_with("lpv"));
        // Indirect = LPV frame - direct-only frame (identical direct terms).
        let (mut se, mut ref2, mut sum_lpv, mut sum_ref) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (i, px) in img.iter().enumerate() {
            if !sd.hit[i] {
                continue;
            }
            for (ch, &v) in px.iter().take(3).enumerate() {
                let ind = (v - sd.direct[i][ch]) as f64;
                let r = sd.reference[i][ch] as f64;
                se += (ind - r).powi(2);
                ref2 += r * r;
                sum_lpv += ind;
                sum_ref += r;
            }
        }
        let leak = match &sd.leak_view {
            Some((view, direct)) => {
                let (inside, _) = self.render_with(sd, view, settings, rsm, 0)?;
                let total: f64 =
                    inside.iter().zip(direct).map(|(a, d)| (0..3).map(|c| (a[c] - d[c]) as f64).sum::<f64>()).sum();
                Some(total / (3.0 * inside.len() as f64) / sd.ref_mean.max(1e-30))
            }
            None => None,
        };
        let row = Row {
            scene: sd.name,
            label,
            lpv,
            rsm,
            inject_ms,
            propagate_ms,
            lpv_ms,
            rel_rmse: (se / ref2.max(1e-30)).sqrt(),
            energy: sum_lpv / sum_ref.max(1e-30),
            leak,
            passes,
            sky: None,
        };
        println!(
            "{:<8} {:<34} inject {:>8.2} ms  propagate {:>8.2} ms  LPV {:>8.2} ms  relRMSE {:.3}  energy {:.3}{}",
            row.scene,
            row.label,
            row.inject_ms,
            row.propagate_ms,
            row.lpv_ms,
            row.rel_rmse,
            row.energy,
            row.leak.map_or(String::new(), |l| format!("  leak ×{l:.2}"))
        );
        Ok(row)
    }
}

fn scene_data(
    ctx: &Context,
    renderer: &MeshRenderer,
    args: &Args,
    name: &'static str,
    scene: Scene,
) -> Result<SceneData, Box<dyn std::error::Error>> {
    let view = view_at(&scene, 0, 1);
    let t0 = std::time::Instant::now();
    let tracer = Tracer::new(&scene)?;
    let rs = ReferenceSettings { samples: args.samples, sky: MeshSettings::default().sky, ..Default::default() };
    let reference = tracer.render(&view, args.size, &rs)?;
    println!(
        "{name}: reference {}×{} at {} spp in {:.1} s",
        args.size[0],
        args.size[1],
        args.samples,
        t0.elapsed().as_secs_f64()
    );
    let gpu = GpuScene::upload(ctx, &scene)?;
    // Direct-only GPU frame (LPV off, ambient off) for subtracting.
    let mut targets = MeshTargets::new(ctx, args.size, 0)?;
    let settings = MeshSettings { ambient: [0.0; 3], shadow_tile: 512, ..Default::default() };
    render_frame(ctx, renderer, &gpu, &mut targets, &view, &settings)?;
    let direct = targets.read_hdr(ctx)?;
    // The atrium's east room is closed on every side (thin wall, outer walls, roof): seen from
    // inside, any indirect light there is leakage through the 8 cm wall.
    let leak_view = if name == "atrium" {
        let v = View::look_at(
            glam::Vec3::new(19.0, 2.0, 10.0),
            glam::Vec3::new(14.0, 2.0, 10.0),
            glam::Vec3::Y,
            70.0,
            0.05,
            100.0,
        );
        render_frame(ctx, renderer, &gpu, &mut targets, &v, &settings)?;
        Some((v, targets.read_hdr(ctx)?))
    } else {
        None
    };
    let hits = reference.hit.iter().filter(|&&h| h).count().max(1) as f64;
    let ref_mean = reference
        .indirect
        .iter()
        .zip(&reference.hit)
        .filter(|(_, &h)| h)
        .map(|(p, _)| (p[0] + p[1] + p[2]) as f64 / 3.0)
        .sum::<f64>()
        / hits;
    let exposure = (1.0 / ref_mean.max(1e-12)) as f32;
    save_indirect(&args.out.join(format!("{name}-reference-indirect.png")), args.size, &reference.indirect, exposure)?;
    Ok(SceneData {
        name,
        gpu,
        view,
        reference: reference.indirect,
        sky_reference: reference.sky,
        hit: reference.hit,
        direct,
        leak_view,
        ref_mean,
        exposure,
    })
}

fn main() {
    vkengine_demos::runner::exit_on_bench_error(run());
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if let Some(bad) =
        args.scenes.iter().find(|s| args.sweep != "thesis-config" && !["cornell", "atrium"].contains(&s.as_str()))
    {
        let msg = format!("--scene {bad}: the {} sweep runs the built-in cornell or atrium", args.sweep);
        return Err(Box::new(vkengine::Error::Input(msg)));
    }
    std::fs::create_dir_all(&args.out)?;
    if args.sweep == "transport" {
        return transport_sweep(&args);
    }
    let ctx = Context::new(&ContextOptions::from_env())?;
    if args.sweep == "thesis-config" {
        // The atrium: an interior the camera stands in, like the thesis' Sibenik view (the
        // Cornell box's camera is outside the box, so camera-centred fine cascades miss it).
        let all = ["atrium".to_string()];
        let scenes = if args.scenes.is_empty() { &all[..] } else { &args.scenes[..] };
        return vkengine_demos::lpv_thesis::run(&ctx, &args.out, scenes, args.quick);
    }
    let renderer = MeshRenderer::new(&ctx)?;
    let bench = Bench { ctx: &ctx, renderer, args: &args };
    // Every frame recomputes the LPV (no reuse), so the timings measure the passes.
    let base = LpvSettings { enabled: true, reuse: false, ..Default::default() };
    let mut rows = Vec::new();
    for name in ["cornell", "atrium"] {
        if !args.scenes.is_empty() && !args.scenes.iter().any(|s| s == name) {
            continue;
        }
        let sd = scene_data(&ctx, &bench.renderer, &args, name, builtin_scene(name)?)?;
        if args.sweep == "extensions" {
            rows.extend(extensions(&bench, &sd, base)?);
            if name == "cornell" {
                rows.extend(subsurface(&ctx, &bench, &args, base)?);
            }
            continue;
        }
        if args.sweep == "accuracy" {
            for n in [16u32, 32] {
                for st in [n / 4, n / 2, n, 2 * n] {
                    let l = LpvSettings { size: n, steps: st, ..base };
                    rows.push(bench.measure(&sd, format!("grid {n} steps {st}"), l, 256)?);
                }
                // Shading and injection knobs at full transport (steps = grid size).
                let full = LpvSettings { size: n, steps: n, ..base };
                let knobs = [
                    ("damping", LpvSettings { damping: true, ..full }),
                    ("vpl offset 1", LpvSettings { vpl_offset: 1.0, ..full }),
                    ("vpl offset 0", LpvSettings { vpl_offset: 0.0, ..full }),
                    ("sample offset 1", LpvSettings { sample_offset: 1.0, ..full }),
                    ("sample offset 0", LpvSettings { sample_offset: 0.0, ..full }),
                    ("no occlusion", LpvSettings { occlusion: false, ..full }),
                ];
                for (k, l) in knobs {
                    rows.push(bench.measure(&sd, format!("knob {n} {k}"), l, 256)?);
                }
            }
            continue;
        }
        // Injection variants × VPL count.
        let rsms: &[u32] = if args.quick { &[64, 128, 256, 512] } else { &[64, 128, 256, 512, 1024] };
        for inj in [Injection::AtomicInt, Injection::AtomicFloat, Injection::Gather, Injection::Raster] {
            for &rsm in rsms {
                let l = LpvSettings { injection: inj, ..base };
                rows.push(bench.measure(&sd, format!("inject {inj:?} rsm {rsm}"), l, rsm)?);
            }
        }
        // Propagation variants × steps.
        let steps: &[u32] = if args.quick { &[1, 2, 4, 8, 16, 32] } else { &[1, 2, 4, 8, 16, 32, 64] };
        for prop in [Propagation::Gather, Propagation::Scatter] {
            for &st in steps {
                let l = LpvSettings { propagation: prop, steps: st, ..base };
                rows.push(bench.measure(&sd, format!("propagate {prop:?} steps {st}"), l, 256)?);
            }
        }
        // Grid size, cascades, occlusion, thesis preset.
        let sizes: &[u32] = if args.quick { &[16, 32] } else { &[16, 32, 64] };
        for &n in sizes {
            let l = LpvSettings { size: n, steps: n / 4, ..base };
            rows.push(bench.measure(&sd, format!("grid {n}^3 steps {}", n / 4), l, 256)?);
        }
        for c in 1..=3 {
            let l = LpvSettings { cascades: c, extent: if name == "atrium" { 8.0 } else { 0.0 }, ..base };
            rows.push(bench.measure(&sd, format!("cascades {c}"), l, 256)?);
        }
        rows.push(bench.measure(&sd, "no occlusion".into(), LpvSettings { occlusion: false, ..base }, 256)?);
        rows.push(bench.measure(&sd, "damping".into(), LpvSettings { damping: true, ..base }, 256)?);
        rows.push(bench.measure(
            &sd,
            "steps 4 + damping".into(),
            LpvSettings { steps: 4, damping: true, ..base },
            256,
        )?);
        rows.push(bench.measure(&sd, "thesis preset".into(), base.thesis(), 256)?);
    }
    let mut csv = format!(
        "# device: {} ({}); image {}x{}, reference {} spp, median of {} frames\nscene,config,injection,propagation,grid,steps,cascades,rsm,occlusion,thesis,inject_ms,propagate_ms,lpv_ms,rel_rmse,energy_ratio,leak_ratio\n",
        ctx.info.name, ctx.info.driver, args.size[0], args.size[1], args.samples, args.frames
    );
    for r in &rows {
        writeln!(
            csv,
            "{},{},{:?},{:?},{},{},{},{},{},{},{:.3},{:.3},{:.3},{:.4},{:.4},{}",
            r.scene,
            r.label,
            r.lpv.injection,
            r.lpv.propagation,
            r.lpv.size,
            r.lpv.steps,
            r.lpv.cascades,
            r.rsm,
            r.lpv.occlusion,
            r.lpv.swap_face_weights,
            r.inject_ms,
            r.propagate_ms,
            r.lpv_ms,
            r.rel_rmse,
            r.energy,
            r.leak.map_or(String::new(), |l| format!("{l:.4}"))
        )?;
    }
    if args.sweep == "extensions" {
        return write_extensions(&args, &ctx, &rows);
    }
    let csv_name = if args.sweep == "accuracy" { "accuracy.csv" } else { "lpv.csv" };
    std::fs::write(args.out.join(csv_name), csv)?;
    // Plots: propagation ms vs steps, injection ms vs VPLs, error vs LPV time.
    for scene in ["cornell", "atrium"] {
        if !rows.iter().any(|r| r.scene == scene) {
            continue;
        }
        let pick = |prefix: &str, x: &dyn Fn(&Row) -> f64, y: &dyn Fn(&Row) -> f64| -> Vec<Series> {
            let mut out: Vec<Series> = Vec::new();
            for r in rows.iter().filter(|r| r.scene == scene && r.label.starts_with(prefix)) {
                let key = r.label.split(' ').take(2).collect::<Vec<_>>().join(" ");
                match out.iter_mut().find(|s| s.name == key) {
                    Some(s) => s.points.push((x(r), y(r))),
                    None => out.push(Series { name: key, points: vec![(x(r), y(r))] }),
                }
            }
            out
        };
        if args.sweep == "accuracy" {
            let err = pick("grid", &|r| r.lpv.steps as f64, &|r| r.rel_rmse.max(1e-4));
            loglog(
                &args.out.join(format!("{scene}-error-vs-steps.png")),
                &format!("{scene}: error vs propagation steps"),
                "steps",
                "relative RMSE of indirect",
                &err,
            )?;
            continue;
        }
        let prop = pick("propagate", &|r| r.lpv.steps as f64, &|r| r.propagate_ms.max(1e-3));
        loglog(
            &args.out.join(format!("{scene}-propagation.png")),
            &format!("{scene}: propagation"),
            "steps",
            "GPU ms",
            &prop,
        )?;
        let inj = pick("inject", &|r| (r.rsm as f64).powi(2), &|r| r.inject_ms.max(1e-3));
        loglog(
            &args.out.join(format!("{scene}-injection.png")),
            &format!("{scene}: injection"),
            "VPLs (RSM texels)",
            "GPU ms",
            &inj,
        )?;
        let err = pick("propagate", &|r| r.lpv_ms.max(1e-3), &|r| r.rel_rmse.max(1e-4));
        loglog(
            &args.out.join(format!("{scene}-error-vs-time.png")),
            &format!("{scene}: error vs LPV time"),
            "LPV GPU ms",
            "relative RMSE of indirect",
            &err,
        )?;
    }
    println!("wrote {}", args.out.join(csv_name).display());
    Ok(())
}

/// Free-space transport of the propagation scheme (CPU twin): accumulated irradiance at
/// distance r from an isotropic point source over the exact value, for several step counts.
fn transport_sweep(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    use vkengine::lpv::transport::point_source_irradiance;
    let n = 67;
    let mut csv = String::from("# CPU twin of the propagation step, isotropic unit point source in the centre of a 67³ grid of unit cells, no occlusion\nsteps,direction,r_cells,irradiance_over_exact\n");
    let mut series = Vec::new();
    for steps in [8u32, 16, 32, 64] {
        let rows = point_source_irradiance(n, steps);
        for (dir, r, ratio) in &rows {
            writeln!(csv, "{steps},{dir},{r:.4},{ratio:.6}")?;
        }
        for dir in ["axis", "body diagonal"] {
            // Below 1e-3 of the exact value the light has simply not arrived: leave it off the plot.
            let points = rows.iter().filter(|&&(d, _, q)| d == dir && q >= 1e-3).map(|&(_, r, q)| (r, q)).collect();
            series.push(Series { name: format!("{steps} steps, {dir}"), points });
        }
        let at = |dir: &str, r: f64| {
            rows.iter().find(|(d, rr, _)| *d == dir && (rr - r).abs() < 0.5).map_or(f64::NAN, |t| t.2)
        };
        println!(
            "{steps:>3} steps: E/exact on the axis at r = 1, 2, 4, 8, 16 cells: {:.3} {:.3} {:.3} {:.3} {:.3}",
            at("axis", 1.0),
            at("axis", 2.0),
            at("axis", 4.0),
            at("axis", 8.0),
            at("axis", 16.0)
        );
    }
    std::fs::write(args.out.join("transport.csv"), csv)?;
    loglog(
        &args.out.join("transport.png"),
        "LPV propagation in free space: irradiance / exact 1/(4πr²)",
        "distance from the source (cells)",
        "accumulated irradiance / exact",
        &series,
    )?;
    println!("wrote {}", args.out.join("transport.csv").display());
    Ok(())
}

/// Each LPV extension against the same configuration without it: label, and the settings.
fn extension_configs(base: LpvSettings) -> Vec<(String, String, MeshSettings)> {
    let plain = |lpv| MeshSettings { ambient: [0.0; 3], shadow_tile: 512, lpv, ..Default::default() };
    let mut out = Vec::new();
    for steps in [0u32, 4, 8, 16] {
        let lpv = LpvSettings { steps, ..base };
        out.push((format!("base steps {steps}"), String::new(), plain(lpv)));
        let directional = LpvSettings { directional: true, ..lpv };
        out.push((format!("directional steps {steps}"), format!("base steps {steps}"), plain(directional)));
        let sky = LpvSettings { sky: 1.0, ..lpv };
        out.push((format!("sky steps {steps}"), format!("base steps {steps}"), plain(sky)));
        if steps == 8 {
            let sub = LpvSettings { subsurface: true, ..lpv };
            out.push(("subsurface steps 8".into(), "base steps 8".into(), plain(sub)));
        }
    }
    out
}

fn extensions(bench: &Bench<'_>, sd: &SceneData, base: LpvSettings) -> vkengine::Result<Vec<Row>> {
    let mut rows: Vec<Row> = Vec::new();
    // The subsurface row needs a translucent material: `subsurface` measures it.
    for (label, _, settings) in extension_configs(base).into_iter().filter(|(_, _, s)| !s.lpv.subsurface) {
        let mut row = bench.measure_with(sd, label.clone(), &settings, 256)?;
        if settings.lpv.sky > 0.0 {
            // The sky term alone: this frame minus the same frame without sky light.
            let plain = MeshSettings { lpv: LpvSettings { sky: 0.0, ..settings.lpv }, ..settings };
            let (with, _) = bench.render_with(sd, &sd.view, &settings, 256, 0)?;
            let (without, _) = bench.render_with(sd, &sd.view, &plain, 256, 0)?;
            let (mut se, mut ref2, mut sum, mut sum_ref) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            let mut term = Vec::with_capacity(with.len());
            for (i, (a, b)) in with.iter().zip(&without).enumerate() {
                let t = [a[0] - b[0], a[1] - b[1], a[2] - b[2], 1.0];
                term.push(t);
                if !sd.hit[i] {
                    continue;
                }
                for (&v, &r) in t.iter().zip(&sd.sky_reference[i]).take(3) {
                    let (v, r) = (v as f64, r as f64);
                    se += (v - r).powi(2);
                    ref2 += r * r;
                    sum += v;
                    sum_ref += r;
                }
            }
            row.sky = Some(((se / ref2.max(1e-30)).sqrt(), sum / sum_ref.max(1e-30)));
            println!(
                "{:<8} {label:<34} sky term: relRMSE {:.3}  energy {:.3}",
                sd.name,
                row.sky.map_or(0.0, |s| s.0),
                row.sky.map_or(0.0, |s| s.1)
            );
            let k = sd.exposure;
            save_indirect(
                &bench.args.out.join(format!("{}-sky-term-{}.png", sd.name, label.replace(' ', "-"))),
                bench.args.size,
                &term,
                k,
            )?;
            if !std::path::Path::new(&bench.args.out.join(format!("{}-sky-reference.png", sd.name))).exists() {
                save_indirect(
                    &bench.args.out.join(format!("{}-sky-reference.png", sd.name)),
                    bench.args.size,
                    &sd.sky_reference,
                    k,
                )?;
            }
        }
        rows.push(row);
    }
    Ok(rows)
}

/// The subsurface LPV on a Cornell box whose tall block lets half its light in (the reference
/// has no subsurface transport, so only its cost and its image are reported).
fn subsurface(
    ctx: &Context,
    bench: &Bench<'_>,
    args: &Args,
    base: LpvSettings,
) -> Result<Vec<Row>, Box<dyn std::error::Error>> {
    let mut scene = builtin_scene("cornell")?;
    let white = scene.meshes.iter().find(|m| m.name == "tall_block").map_or(0, |m| m.material);
    let mut translucent = scene.materials[white].clone();
    translucent.name = "translucent white".into();
    translucent.translucency = 0.5;
    scene.materials.push(translucent);
    let index = scene.materials.len() - 1;
    for m in scene.meshes.iter_mut().filter(|m| m.name == "tall_block") {
        m.material = index;
    }
    let sd = scene_data(ctx, &bench.renderer, args, "cornell-translucent", scene)?;
    let lpv = LpvSettings { steps: 8, ..base };
    let plain = MeshSettings { ambient: [0.0; 3], shadow_tile: 512, lpv, ..Default::default() };
    let with = MeshSettings { lpv: LpvSettings { subsurface: true, ..lpv }, ..plain };
    let rows = vec![
        bench.measure_with(&sd, "base steps 8".into(), &plain, 256)?,
        bench.measure_with(&sd, "subsurface steps 8".into(), &with, 256)?,
    ];
    // Whole frames (direct + indirect), for looking at the block's shadowed faces.
    for (label, settings) in [("base", &plain), ("subsurface", &with)] {
        let (img, _) = bench.render_with(&sd, &sd.view, settings, 256, 0)?;
        let path = args.out.join(format!("cornell-translucent-frame-{label}.png"));
        save_indirect(&path, args.size, &img, sd.exposure)?;
    }
    Ok(rows)
}

/// `extensions.csv`: per extension, the passes it adds (ms), the frame-time change and the error
/// change against its baseline row.
fn write_extensions(args: &Args, ctx: &Context, rows: &[Row]) -> Result<(), Box<dyn std::error::Error>> {
    let baselines: Vec<(String, String)> =
        extension_configs(LpvSettings::default()).into_iter().map(|(l, b, _)| (l, b)).collect();
    let mut csv = format!(
        "# device: {} ({}); image {}x{}, reference {} spp, median of {} frames\nscene,config,baseline,added_passes,added_ms,frame_ms,baseline_frame_ms,metric,rel_rmse,baseline_rel_rmse,energy_ratio,leak_ratio,baseline_leak_ratio\n",
        ctx.info.name, ctx.info.driver, args.size[0], args.size[1], args.samples, args.frames
    );
    let frame = |r: &Row| r.passes.iter().map(|(_, ms)| ms).sum::<f64>();
    for r in rows {
        let Some((_, base_label)) = baselines.iter().find(|(l, _)| *l == r.label) else { continue };
        let Some(b) = rows.iter().find(|b| b.scene == r.scene && b.label == *base_label) else { continue };
        let added: Vec<&(String, f64)> =
            r.passes.iter().filter(|(n, _)| !b.passes.iter().any(|(m, _)| m == n)).collect();
        let names = added.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(" + ");
        let leak = |x: Option<f64>| x.map_or(String::new(), |l| format!("{l:.4}"));
        // Sky rows score the sky term against the reference's; without sky light that error is 1.
        let (metric, err, base_err, energy) = match r.sky {
            Some((e, en)) => ("sky term", e, 1.0, en),
            None => ("indirect", r.rel_rmse, b.rel_rmse, r.energy),
        };
        writeln!(
            csv,
            "{},{},{},{},{:.3},{:.3},{:.3},{},{:.4},{:.4},{:.4},{},{}",
            r.scene,
            r.label,
            b.label,
            names,
            added.iter().map(|(_, ms)| ms).sum::<f64>(),
            frame(r),
            frame(b),
            metric,
            err,
            base_err,
            energy,
            leak(r.leak),
            leak(b.leak)
        )?;
    }
    std::fs::write(args.out.join("extensions.csv"), csv)?;
    println!("wrote {}", args.out.join("extensions.csv").display());
    Ok(())
}
