//! The mesh renderer's fog pass against the engine's volume path tracer, and its cost.
//!
//! One homogeneous box of fog ([-0.5, 0.5]³, the volume renderer's unit box) lit by the sun, no
//! environment, no occluders, seen by the same perspective camera in both renderers:
//! - **fog pass** (`engine/mesh/fog.rs`): single scattering, exact per-segment transmittance,
//!   the sun attenuated analytically by the box, at several segment counts;
//! - **MCS** (`engine/volume`): delta tracking + next-event estimation of the sun with ratio
//!   tracking, accumulated over many frames as the reference, and an independent MCS run for its
//!   error-vs-time curve.
//!
//! Also renders the Cornell box with fog (+ LPV) and times its fog pass. Writes `fog.csv`,
//! `error_vs_time.png`, side-by-side images and `cornell-fog.png` to `results/fog/`.

use clap::Parser;
use glam::Vec3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use vkengine::mesh::camera::View;
use vkengine::mesh::fog::{FogBounds, FogSettings};
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame as render_mesh, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::plot::{loglog, Series};
use vkengine::scene::{Camera as SceneCamera, Light, Material, Mesh, Scene};
use vkengine::vk::{Context, ContextOptions};
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::procedural;
use vkengine::volume::optics::phase::PhaseFunction;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{
    render_frame as render_volume, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};
use vkengine_demos::mesh_scene::{builtin_scene, mesh_settings};

#[derive(Parser)]
#[command(about = "Fog pass vs the volume path tracer (MCS) on a homogeneous box, and fog pass cost")]
struct Args {
    /// Output folder.
    #[arg(long, default_value = "results/fog")]
    out: PathBuf,
    /// Image edge length of the comparison.
    #[arg(long, default_value_t = 128)]
    size: u32,
    /// Extinction σt of the box (1/m; the box is 1 m wide).
    #[arg(long, default_value_t = 3.0)]
    density: f32,
    /// Single-scattering albedo.
    #[arg(long, default_value_t = 0.8)]
    albedo: f32,
    /// Henyey–Greenstein g.
    #[arg(long, default_value_t = 0.3)]
    g: f32,
    /// MCS frames in the reference.
    #[arg(long, default_value_t = 2048)]
    reference_frames: u64,
    /// MCS frames of the independent error-vs-time run (a power of two).
    #[arg(long, default_value_t = 256)]
    mc_frames: u64,
    /// Timed frames per fog configuration (median reported).
    #[arg(long, default_value_t = 5)]
    frames: usize,
    /// Cornell box image edge length.
    #[arg(long, default_value_t = 320)]
    cornell_size: u32,
}

fn pass_ms(run: &vkengine::graph::execute::GraphRun, name: &str) -> f64 {
    run.timings.iter().filter(|t| t.name == name).map(|t| t.gpu_ms()).sum()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// Relative RMSE over the pixels either image lights (the box's footprint): RMSE of all three
/// channels divided by the reference's mean there.
fn rel_rmse(img: &[[f32; 4]], reference: &[[f32; 4]]) -> f64 {
    let (mut se, mut sum, mut n) = (0.0f64, 0.0f64, 0usize);
    for (a, r) in img.iter().zip(reference) {
        if a[..3].iter().chain(&r[..3]).all(|&c| c <= 0.0) {
            continue;
        }
        for c in 0..3 {
            let d = f64::from(a[c]) - f64::from(r[c]);
            se += d * d;
            sum += f64::from(r[c]);
            n += 1;
        }
    }
    if n == 0 || sum <= 0.0 {
        return f64::NAN;
    }
    (se / n as f64).sqrt() / (sum / n as f64)
}

/// Linear HDR → sRGB bytes with exposure, Reinhard: the same display transform for both renderers.
fn to_rgba8(img: &[[f32; 4]], exposure: f32) -> Vec<u8> {
    let enc = |x: f32| {
        let v = x * exposure / (1.0 + x * exposure);
        let s = if v <= 0.0031308 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
        (s.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
    };
    img.iter().flat_map(|p| [enc(p[0]), enc(p[1]), enc(p[2]), 255]).collect()
}

/// Images side by side (same height) into one PNG.
fn side_by_side(path: &Path, w: u32, h: u32, images: &[Vec<u8>]) -> Result<(), Box<dyn std::error::Error>> {
    let total = w * images.len() as u32;
    let mut out = vec![0u8; (total * h * 4) as usize];
    for (i, img) in images.iter().enumerate() {
        for y in 0..h {
            let src = &img[(y * w * 4) as usize..((y + 1) * w * 4) as usize];
            let at = ((y * total + i as u32 * w) * 4) as usize;
            out[at..at + src.len()].copy_from_slice(src);
        }
    }
    vkengine_demos::output::write_png(path, total, h, &out)?;
    Ok(())
}

/// Single scattering of the sun along pixel `px`'s ray through the fog box, `n` midpoint steps
/// in f64, the sun attenuated by the box: ∫ σs e^{-σt s} p(μ) E e^{-σt ℓ(x)} ds.
fn quadrature(view: &View, size: [u32; 2], px: [u32; 2], to_sun: Vec3, e: f32, fog: &FogSettings, n: u32) -> f64 {
    let FogBounds::Box { min, max } = fog.bounds else { return f64::NAN };
    let (lo, hi) = (Vec3::from(min).as_dvec3(), Vec3::from(max).as_dvec3());
    let vp = view.view_proj(size[0] as f32 / size[1] as f32);
    let ndc = Vec3::new(
        (px[0] as f32 + 0.5) / size[0] as f32 * 2.0 - 1.0,
        (px[1] as f32 + 0.5) / size[1] as f32 * 2.0 - 1.0,
        1.0,
    );
    let eye = Vec3::from(view.position).as_dvec3();
    let d = (vp.inverse().project_point3(ndc).as_dvec3() - eye).normalize();
    let slab = |o: glam::DVec3, d: glam::DVec3| {
        let (a, b) = ((lo - o) / d, (hi - o) / d);
        (a.min(b).max_element().max(0.0), a.max(b).min_element())
    };
    let (t0, t1) = slab(eye, d);
    if t1 <= t0 {
        return 0.0;
    }
    let (sigma, g) = (f64::from(fog.density), f64::from(fog.g));
    let l = to_sun.as_dvec3().normalize();
    let mu = d.dot(l);
    let p = (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5));
    let dt = (t1 - t0) / f64::from(n);
    (0..n)
        .map(|i| {
            let s = (f64::from(i) + 0.5) * dt;
            let exit = slab(eye + d * (t0 + s), l).1.max(0.0);
            f64::from(fog.albedo) * sigma * (-sigma * s).exp() * p * f64::from(e) * (-sigma * exit).exp() * dt
        })
        .sum()
}

/// The whole image by [`quadrature`] (grey: the medium and the sun are white), rows split
/// over the available threads.
fn exact_image(view: &View, size: [u32; 2], to_sun: Vec3, e: f32, fog: &FogSettings) -> Vec<[f32; 4]> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) as u32;
    let rows: Vec<Vec<[f32; 4]>> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..threads)
            .map(|k| {
                sc.spawn(move || {
                    (k..size[1])
                        .step_by(threads as usize)
                        .map(|y| {
                            (0..size[0])
                                .flat_map(|x| {
                                    let v = quadrature(view, size, [x, y], to_sun, e, fog, 4000) as f32;
                                    [[v, v, v, 1.0]]
                                })
                                .collect::<Vec<_>>()
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let parts: Vec<Vec<Vec<[f32; 4]>>> = handles.into_iter().map(|h| h.join().unwrap_or_default()).collect();
        (0..size[1])
            .map(|y| parts[(y % threads) as usize].get((y / threads) as usize).cloned().unwrap_or_default())
            .collect()
    });
    rows.into_iter().flatten().collect()
}

fn main() {
    vkengine_demos::runner::exit_on_bench_error(run());
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    std::fs::create_dir_all(&args.out)?;
    let ctx = Context::new(&ContextOptions::from_env())?;
    let size = [args.size; 2];
    let to_sun = Vec3::new(0.4, 0.8, 0.45).normalize();
    let irradiance = 3.0f32;
    let fog = FogSettings {
        enabled: true,
        density: args.density,
        albedo: args.albedo,
        g: args.g,
        steps: 64,
        bounds: FogBounds::Box { min: [-0.5; 3], max: [0.5; 3] },
    };
    fog.validate()?;

    // The volume renderer's camera; the mesh view is built from the same eye, direction, field
    // of view and clip planes (both put +Y at the top of the image).
    let fov_y = 0.8f32;
    let cam = Camera::orbit(2.2, 0.6, 0.35, Projection::Perspective { fov_y });
    let (eye, fwd) = cam.eye_forward();
    let view = View::look_at(eye, eye + fwd, Vec3::Y, fov_y.to_degrees(), 0.01, 100.0);

    // --- Volume path tracer: a constant 32³ volume filling its unit box.
    let vol = procedural::homogeneous_box([32; 3], 1.0)?;
    let tf = TransferFunction::constant([args.albedo; 3], args.density);
    let vr = VolumeRenderer::new(&ctx, &vol, &tf)?;
    let mc = McSettings {
        sun_dir: Some(to_sun.into()),
        sun_radiance: [irradiance; 3],
        env_radiance: [0.0; 3],
        phase: PhaseFunction::HenyeyGreenstein { g: args.g }.to_gpu(),
        ..Default::default()
    };
    let vs = RenderSettings { renderer: RendererKind::Mcs, background: [0.0; 3], mc, ..Default::default() };
    eprintln!("MCS reference: {} frames at {}²…", args.reference_frames, args.size);
    let mut t = Targets::new(&ctx, size)?;
    let mut mcs_ms = Vec::new();
    for f in 0..args.reference_frames {
        // Frame numbers key the random streams: the reference's are far from the run below.
        let run = render_volume(&ctx, &vr, &mut t, &cam, &vs, 1_000_000 + f)?;
        mcs_ms.push(pass_ms(&run, "mcs"));
    }
    let reference = t.read_hdr(&ctx)?;
    let mcs_frame_ms = median(mcs_ms);
    vkengine_demos::output::write_exr(&args.out.join("reference-mcs.exr"), size[0], size[1], &reference)?;

    eprintln!("f64 quadrature of every pixel…");
    let exact = exact_image(&view, size, to_sun, irradiance, &fog);
    let ref_err = rel_rmse(&reference, &exact);

    let mut csv = format!(
        "# device: {} ({}); box [-0.5,0.5]^3 sigma_t={} albedo={} g={} sun E={irradiance} dir={:?}; {}x{}; \
         MCS reference {} frames; exact = f64 quadrature (4000 steps per pixel); rel_rmse = RMSE / mean of \
         the reference over the box's pixels; mcs_equal_error_ms = MCS time to the same error vs exact \
         (fitted c/sqrt(n))\n\
         renderer,steps_or_frames,gpu_ms,rel_rmse_vs_mcs_reference,rel_rmse_vs_exact,mcs_equal_error_ms,speedup\n",
        ctx.info.name,
        ctx.info.driver,
        args.density,
        args.albedo,
        args.g,
        to_sun.to_array(),
        size[0],
        size[1],
        args.reference_frames
    );

    // Independent MCS run: error vs cumulative GPU time of the MCS pass.
    let mut t = Targets::new(&ctx, size)?;
    let (mut cum, mut mc_points, mut mc_first, mut c_fit) = (0.0, Vec::new(), Vec::new(), Vec::new());
    for f in 0..args.mc_frames {
        let run = render_volume(&ctx, &vr, &mut t, &cam, &vs, f)?;
        cum += pass_ms(&run, "mcs");
        let n = f + 1;
        if n.is_power_of_two() {
            let img = t.read_hdr(&ctx)?;
            let (e, x) = (rel_rmse(&img, &reference), rel_rmse(&img, &exact));
            writeln!(csv, "mcs,{n},{cum:.3},{e:.6},{x:.6},,")?;
            mc_points.push((cum, x));
            c_fit.push(x * (n as f64).sqrt());
            if n == 1 {
                mc_first = img;
            }
        }
    }
    // MCS error against the exact image falls as c/√n (unbiased, independent pixels).
    let c = c_fit.iter().sum::<f64>() / c_fit.len().max(1) as f64;
    writeln!(
        csv,
        "mcs_reference,{},{:.3},0,{ref_err:.6},,",
        args.reference_frames,
        mcs_frame_ms * args.reference_frames as f64
    )?;

    // --- Fog pass: the same box as mesh-scene fog. The only mesh is a small quad behind the camera.
    let back = eye - fwd * 5.0;
    let (u, v) = (fwd.cross(Vec3::Y).normalize() * 0.05, Vec3::Y * 0.05);
    let n = u.cross(v).normalize();
    let corners = [back - u - v, back + u - v, back + u + v, back - u + v];
    let quad = Mesh {
        name: "quad".into(),
        positions: corners.iter().map(|c| c.to_array()).collect(),
        normals: vec![n.to_array(); 4],
        uvs: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        tangents: vec![[1.0, 0.0, 0.0, 1.0]; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    };
    let mut scene = Scene::from_parts(vec![quad], vec![Material::default()], Vec::new());
    scene.lights = vec![Light::Directional { direction: (-to_sun).into(), color: [1.0; 3], intensity: irradiance }];
    scene.camera = SceneCamera {
        position: eye.into(),
        target: (eye + fwd).into(),
        up: [0.0, 1.0, 0.0],
        fov_y_deg: fov_y.to_degrees(),
        near: 0.01,
        far: 100.0,
    };
    let gpu = GpuScene::upload(&ctx, &scene)?;
    let mr = MeshRenderer::new(&ctx)?;
    let mut mt = MeshTargets::new(&ctx, size, 0)?;
    let mut fog_points = Vec::new();
    let mut fog_default = Vec::new();
    let mut summary = format!(
        "MCS: {mcs_frame_ms:.2} ms/frame; error vs exact {c:.3}/sqrt(frames); reference ({} frames) vs exact {ref_err:.4}\n",
        args.reference_frames
    );
    let default_steps = FogSettings::default().steps;
    for steps in [2u32, 4, 8, 16, 32, 64, 128] {
        let s =
            MeshSettings { ambient: [0.0; 3], sky: [0.0; 3], fog: FogSettings { steps, ..fog }, ..Default::default() };
        let mut ms = Vec::new();
        for i in 0..=args.frames {
            let run = render_mesh(&ctx, &mr, &gpu, &mut mt, &view, &s)?;
            if i > 0 {
                ms.push(pass_ms(&run, "fog"));
            }
        }
        let img = mt.read_hdr(&ctx)?;
        let (e, x) = (rel_rmse(&img, &reference), rel_rmse(&img, &exact));
        let m = median(ms);
        // MCS frames for the same error against the exact image, at its measured ms per frame.
        let mc_ms = (c / x).powi(2).max(1.0) * mcs_frame_ms;
        writeln!(csv, "fog,{steps},{m:.3},{e:.6},{x:.6},{mc_ms:.1},{:.1}", mc_ms / m)?;
        let line = format!(
            "fog {steps:>3} segments: {m:7.2} ms, rel. RMSE vs MCS reference {e:.4}, vs exact {x:.2e}; MCS needs \
             {:.3e} ms for that error ({:.0}x)\n",
            mc_ms,
            mc_ms / m
        );
        eprint!("{line}");
        summary.push_str(&line);
        fog_points.push((m, x));
        if steps == default_steps {
            fog_default = img;
        }
    }
    let (cx, cy) = (size[0] / 2, size[1] / 2);
    let centre = (cy * size[0] + cx) as usize;
    summary.push_str(&format!(
        "centre pixel: fog ({default_steps} segments) {:.5}, MCS reference {:.5}, exact {:.5}",
        fog_default[centre][0], reference[centre][0], exact[centre][0]
    ));
    println!("{summary}");
    writeln!(csv, "# {}", summary.replace('\n', "\n# "))?;
    // The measurements are on disk before anything is drawn (a plot that fails loses nothing);
    // the Cornell rows are appended below.
    std::fs::write(args.out.join("fog.csv"), &csv)?;

    // Images: fog, MCS reference, one MCS frame, |fog - reference| ×4.
    let exposure = 4.0;
    let diff: Vec<[f32; 4]> = fog_default
        .iter()
        .zip(&reference)
        .map(|(a, r)| [0, 1, 2, 3].map(|c| if c == 3 { 1.0 } else { 4.0 * (a[c] - r[c]).abs() }))
        .collect();
    side_by_side(
        &args.out.join("fog-vs-mcs.png"),
        size[0],
        size[1],
        &[
            to_rgba8(&fog_default, exposure),
            to_rgba8(&reference, exposure),
            to_rgba8(&mc_first, exposure),
            to_rgba8(&diff, exposure),
        ],
    )?;
    loglog(
        &args.out.join("error_vs_time.png"),
        "homogeneous box, sun: error vs GPU time",
        "GPU ms",
        "rel. RMSE vs exact (f64 quadrature)",
        &[
            Series { name: "MCS (1, 2, 4, … frames)".into(), points: mc_points },
            Series { name: "fog pass (2…128 segments)".into(), points: fog_points },
        ],
    )?;

    // --- Cornell box with fog: timing of the fog pass with and without the LPV, and the image.
    let cornell = builtin_scene("cornell")?;
    let cgpu = GpuScene::upload(&ctx, &cornell)?;
    let cview = vkengine_demos::mesh_scene::view_at(&cornell, 0, 1);
    writeln!(csv, "# Cornell box {0}x{0}: fog pass ms (median of {1})", args.cornell_size, args.frames)?;
    for (label, lpv) in [("cornell_fog", "0"), ("cornell_fog_lpv", "1")] {
        let sets: Vec<(String, String)> =
            [("fog", "1"), ("fog_density", "1.5"), ("fog_g", "0.2"), ("lpv", lpv), ("lpv_steps", "8"), ("rsm", "256")]
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
        let (s, rsm) = mesh_settings(&cornell.settings, &sets)?;
        let mut ct = MeshTargets::new(&ctx, [args.cornell_size; 2], rsm)?;
        let (mut ms, mut frame) = (Vec::new(), Vec::new());
        for i in 0..=args.frames {
            let run = render_mesh(&ctx, &mr, &cgpu, &mut ct, &cview, &s)?;
            if i > 0 {
                ms.push(pass_ms(&run, "fog"));
                frame.push(run.timings.last().map_or(0.0, |t| t.gpu_end_ns as f64 * 1e-6));
            }
        }
        let (m, f) = (median(ms), median(frame));
        writeln!(csv, "{label},{},{m:.3},,,,", s.fog.steps)?;
        println!("{label}: fog pass {m:.2} ms ({} segments), frame {f:.1} ms", s.fog.steps);
        if lpv == "1" {
            let c = args.cornell_size;
            vkengine_demos::output::write_png(&args.out.join("cornell-fog.png"), c, c, &ct.read_ldr(&ctx)?)?;
        }
    }
    std::fs::write(args.out.join("fog.csv"), csv)?;
    println!("wrote {}", args.out.display());
    vkengine_demos::check_validation(&ctx)?;
    Ok(())
}
