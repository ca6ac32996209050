//! `volume_bench --clean`: clean images fast, as error against time. On each scene (vpt's, a
//! CT-like volume, the MNI MR template, a sparse OpenVDB cloud) each way of producing the shown
//! image (the raw mean of one whole path a frame, issue 49's baseline; the raw mean with the
//! default `mc_budget=auto`, which measured bounded work faster on llvmpipe; adaptive sampling,
//! the denoiser, both, and bounded work with both) runs progressively; at 1, 2, 4, … frames the
//! relative RMSE of the foreground of the shown image (and of the unbiased mean beside it) is
//! taken against an independent long reference, over wall and GPU time (the filter's passes
//! counted). Writes `clean_<scene>.csv`, `clean_<scene>_error_vs_time.png`, and
//! `clean_summary.csv` with each variant's time to relative RMSE 0.05 and 0.02 and its speed-up
//! over the first variant run (the whole-path baseline unless `--clean-variants` leaves it out).
//! `--clean-path`: a camera path of 60 views 3° apart at 4 paths a view, raw against denoised
//! with temporal reuse: per-view error against per-view references and the flicker
//! (`clean_path.csv`).

use crate::vpt_peer::{time_to, vpt_scene, VPT_SETTINGS};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;
use vkengine::plot::{loglog, Series};
use vkengine::settings::{Origin, Setting};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{load, LoadOptions, Volume};
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{render_frame, Targets, VolumeRenderer};
use vkengine::volume::render::settings::VolumeSetup;

type BenchResult<T> = Result<T, Box<dyn std::error::Error>>;
type Image = Vec<[f32; 4]>;

/// Where the scenes' files are.
pub struct Inputs {
    /// vpt's raw 128³ u8 cloud.
    pub vpt: PathBuf,
    /// The MNI152 T1 template (NIfTI; `tools/make_gallery.sh` fetches it).
    pub mr: PathBuf,
    /// A sparse OpenVDB cloud (`tools/make_vdb_sparse_cloud.py --bench`).
    pub vdb: PathBuf,
}

/// A scene: volume, table and the settings every variant starts from.
struct Scene {
    volume: Volume,
    tf: TransferFunction,
    base: Vec<(&'static str, &'static str)>,
}

fn missing(path: &Path, how: &str) -> Box<dyn std::error::Error> {
    Box::new(vkengine::Error::Input(format!("{}: no such file; {how}", path.display())))
}

fn scene(name: &str, inputs: &Inputs) -> BenchResult<Scene> {
    let lit: Vec<(&str, &str)> = vec![("renderer", "mcm"), ("bounces", "8"), ("env", "0.3"), ("sun", "1")];
    Ok(match name {
        "vpt" => {
            let (volume, tf) = vpt_scene(&inputs.vpt)?;
            Scene { volume, tf, base: VPT_SETTINGS.to_vec() }
        }
        "ct" => {
            let volume = crate::layout_bench::ct_like(128)?;
            Scene { volume, tf: TransferFunction::preset("bone")?, base: lit }
        }
        "mr" | "vdb" => {
            let (path, how) = match name {
                "mr" => (&inputs.mr, "tools/make_gallery.sh fetches the MNI template"),
                _ => (&inputs.vdb, "write one with /usr/bin/python3 tools/make_vdb_sparse_cloud.py --bench PATH"),
            };
            if !path.is_file() {
                return Err(missing(path, how));
            }
            let volume = load(path, &LoadOptions::default())?;
            let (tf, _) = vkengine::volume::optics::tf_choice::for_volume(None, &volume)?;
            Scene { volume, tf, base: lit }
        }
        other => {
            return Err(Box::new(vkengine::Error::Input(format!("--clean `{other}`: expected vpt, ct, mr or vdb"))))
        }
    })
}

/// Relative RMSE over the foreground (pixels where the reference differs from `background`).
fn rel_rmse(img: &[[f32; 4]], reference: &[[f32; 4]], background: &[[f32; 4]]) -> f64 {
    let (mut err, mut norm) = (0.0f64, 0.0f64);
    for ((a, r), b) in img.iter().zip(reference).zip(background) {
        if (0..3).all(|c| (r[c] - b[c]).abs() < 1e-6) {
            continue;
        }
        for c in 0..3 {
            err += (f64::from(a[c]) - f64::from(r[c])).powi(2);
            norm += f64::from(r[c]).powi(2);
        }
    }
    (err / norm.max(1e-30)).sqrt()
}

/// A reference: the mean of two independent halves, and its own relative MSE (a quarter of the
/// halves' squared relative difference), which every error measured against it is corrected by.
struct Reference {
    mean: Image,
    rel_mse: f64,
}

/// `frames` frames of `s` (bounded work, unbiased) in two halves from independent seeds.
fn reference(
    ctx: &Context,
    r: &VolumeRenderer,
    cam: &Camera,
    s: &VolumeSetup,
    size: [u32; 2],
    frames: u64,
    background: &[[f32; 4]],
) -> BenchResult<Reference> {
    let mut halves = Vec::new();
    for h in 0..2u64 {
        let mut t = Targets::new(ctx, size)?;
        for f in 0..frames.div_ceil(2) {
            render_frame(ctx, r, &mut t, cam, &s.render, 1_000_000 * (h + 1) + f)?;
        }
        halves.push(t.read_hdr(ctx)?);
    }
    let mean: Image = halves[0]
        .iter()
        .zip(&halves[1])
        .map(|(a, b)| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]), 1.0])
        .collect();
    let d = rel_rmse(&halves[0], &halves[1], background);
    Ok(Reference { rel_mse: d * d / 4.0, mean })
}

/// A variant: short name (`--clean-variants`), label and settings over the scene's.
type Variant = (&'static str, &'static str, &'static [(&'static str, &'static str)]);

const VARIANTS: [Variant; 7] = [
    ("whole", "raw (one whole path a frame)", &[("mc_budget", "0")]),
    ("raw", "raw (default)", &[]),
    ("adaptive", "adaptive", &[("adaptive", "on"), ("adaptive_error", "0.01")]),
    ("denoised", "denoised", &[("denoise", "on")]),
    ("adaptive+denoised", "adaptive + denoised", &[("adaptive", "on"), ("adaptive_error", "0.01"), ("denoise", "on")]),
    ("bounded", "bounded 512/4", &[("mc_budget", "512"), ("mc_paths", "4")]),
    (
        "bounded+adaptive+denoised",
        "bounded 512/4 + adaptive + denoised",
        &[("mc_budget", "512"), ("mc_paths", "4"), ("adaptive", "on"), ("adaptive_error", "0.01"), ("denoise", "on")],
    ),
];

/// When a curve reached an error.
#[derive(Clone, Copy)]
enum Reached {
    /// At this time (interpolated, or extrapolated past the last point).
    At(f64),
    /// Already at its first point: by this time at the latest.
    By(f64),
    /// Not at all (no points).
    No,
}

impl Reached {
    fn of(points: &[(f64, f64)], target: f64) -> Self {
        match (time_to(points, target), points.first()) {
            (Some(t), _) => Reached::At(t),
            (None, Some(&(t, e))) if e <= target => Reached::By(t),
            _ => Reached::No,
        }
    }
}

/// How `run` measures.
pub struct Options {
    /// Wall seconds per variant.
    pub seconds: f64,
    /// Frames of bounded work 512/4 in each reference.
    pub reference_frames: u64,
    /// Short names of the variants to run; all when empty.
    pub variants: Vec<String>,
    /// Keep each reference in the output folder and reuse it.
    pub reference_cache: bool,
}

/// The reference from `path` if it holds one of `pixels` pixels, else `None`.
fn read_cached(path: &Path, pixels: usize) -> Option<Reference> {
    let bytes = std::fs::read(path).ok()?;
    if bytes.len() != 8 + pixels * 16 {
        return None;
    }
    let rel_mse = f64::from_le_bytes(bytes[..8].try_into().ok()?);
    let floats: Vec<f32> = bytes[8..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let mean = floats.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
    Some(Reference { mean, rel_mse })
}

fn write_cached(path: &Path, r: &Reference) -> std::io::Result<()> {
    let mut bytes = r.rel_mse.to_le_bytes().to_vec();
    bytes.extend(r.mean.iter().flatten().flat_map(|v| v.to_le_bytes()));
    std::fs::write(path, bytes)
}

fn setup_of(base: &[(&str, &str)], extra: &[(&str, &str)]) -> vkengine::Result<VolumeSetup> {
    let all: Vec<Setting> =
        base.iter().chain(extra).map(|(k, v)| Setting::new(*k, v.to_string(), Origin::Cli)).collect();
    VolumeSetup::parse(&all)
}

/// Runs every scene in `scenes` at `size`², each variant for up to `seconds` of wall time (the
/// last checkpoint may pass it), against a reference of `reference_frames` bounded frames.
pub fn run(
    ctx: &Context,
    out: &Path,
    scenes: &[String],
    inputs: &Inputs,
    size: u32,
    opts: &Options,
) -> BenchResult<()> {
    let (seconds, reference_frames) = (opts.seconds, opts.reference_frames);
    let variants: Vec<Variant> =
        VARIANTS.into_iter().filter(|v| opts.variants.is_empty() || opts.variants.iter().any(|n| n == v.0)).collect();
    if let Some(bad) = opts.variants.iter().find(|n| !VARIANTS.iter().any(|v| v.0 == n.as_str())) {
        let names: Vec<&str> = VARIANTS.iter().map(|v| v.0).collect();
        return Err(Box::new(vkengine::Error::Input(format!(
            "--clean-variants `{bad}`: expected some of {}",
            names.join(", ")
        ))));
    }
    std::fs::create_dir_all(out)?;
    let device = format!("{} ({})", ctx.info.name, ctx.info.driver);
    let mut summary = format!(
        "# device: {device}; {size}^2; time to relative RMSE (foreground, reference noise removed) of the shown image; speed-ups over the first variant run, {}; extrapolated: past the last point by t^-1/2\nscene,variant,to_0.05_s,to_0.02_s,speedup_0.05,speedup_0.02,extrapolated_0.02\n",
        variants.first().map_or("none", |v| v.1)
    );
    for name in scenes {
        let sc = scene(name, inputs)?;
        let r = VolumeRenderer::new(ctx, &sc.volume, &sc.tf)?;
        let base = setup_of(&sc.base, &[])?;
        let cam = crate::volume_scene::camera(&base, &sc.volume, r.box_half(), 1.0);
        let dims = [size; 2];
        // The background: what a ray that misses the volume sees (an empty table's image).
        let background = {
            let empty = VolumeRenderer::new(ctx, &sc.volume, &TransferFunction::ramp(0.0, 1.0, [1.0; 3], 0.0))?;
            let mut t = Targets::new(ctx, dims)?;
            render_frame(ctx, &empty, &mut t, &cam, &setup_of(&sc.base, &[("mc_budget", "8")])?.render, 0)?;
            t.read_hdr(ctx)?
        };
        let ref_setup = setup_of(&sc.base, &[("mc_budget", "512"), ("mc_paths", "4")])?;
        let start = Instant::now();
        let cache = out.join(format!("clean_{name}_{size}_{reference_frames}.ref"));
        let cached = if opts.reference_cache { read_cached(&cache, (size * size) as usize) } else { None };
        let reference = match cached {
            Some(r) => r,
            None => {
                let r = reference(ctx, &r, &cam, &ref_setup, dims, reference_frames, &background)?;
                if opts.reference_cache {
                    write_cached(&cache, &r)?;
                }
                r
            }
        };
        println!(
            "{name}: reference {reference_frames} frames of bounded work 512/4 in {:.0} s, its own relative RMSE {:.4}",
            start.elapsed().as_secs_f64(),
            reference.rel_mse.sqrt()
        );
        let corrected = |e: f64| (e * e - reference.rel_mse).max(0.0).sqrt();
        let mut csv = format!(
            "# device: {device}; scene {name}, {size}^2; reference: {reference_frames} frames of bounded work 512/4, relative RMSE {:.5} (removed from each error in the corrected columns); wall: submission and wait, readbacks excluded; gpu: every pass including features and filter\nvariant,frames,wall_s,gpu_s,rel_rmse_shown,rel_rmse_mean,shown_corrected,mean_corrected,estimated\n",
            reference.rel_mse.sqrt()
        );
        let mut series = Vec::new();
        let mut baseline_times = (Reached::No, Reached::No);
        // Warm-up, not timed: each variant's pipelines (adaptive sampling's from its second frame
        // on, once every pixel has the paths a variance needs), and mc_budget=auto's measurement.
        for (_, _, extra) in &variants {
            let mut t = Targets::new(ctx, dims)?;
            for f in 0..4 {
                render_frame(ctx, &r, &mut t, &cam, &setup_of(&sc.base, extra)?.render, 3_000_000 + f)?;
            }
        }
        for &(_, label, extra) in &variants {
            let s = setup_of(&sc.base, extra)?;
            let mut t = Targets::new(ctx, dims)?;
            let (mut wall, mut gpu, mut points) = (0.0f64, 0.0f64, Vec::new());
            let mut f = 0u64;
            loop {
                let t0 = Instant::now();
                let run = render_frame(ctx, &r, &mut t, &cam, &s.render, f)?;
                wall += t0.elapsed().as_secs_f64();
                gpu += run.gpu_ms() * 1e-3;
                f += 1;
                let last = wall >= seconds || f >= 1 << 16;
                if f.is_power_of_two() || last {
                    let shown = rel_rmse(&t.read_shown(ctx)?, &reference.mean, &background);
                    let mean = rel_rmse(&t.read_hdr(ctx)?, &reference.mean, &background);
                    let est = t.error_estimate().and_then(|e| e.relative).unwrap_or(f64::NAN);
                    writeln!(
                        csv,
                        "{label},{f},{wall:.3},{gpu:.3},{shown:.6},{mean:.6},{:.6},{:.6},{est:.6}",
                        corrected(shown),
                        corrected(mean)
                    )?;
                    points.push((wall, corrected(shown)));
                }
                if last {
                    break;
                }
            }
            let (t05, t02) = (Reached::of(&points, 0.05), Reached::of(&points, 0.02));
            if series.is_empty() {
                baseline_times = (t05, t02);
            }
            let ratio = |baseline: Reached, t: Reached| match (baseline, t) {
                (Reached::At(a), Reached::At(b)) if b > 0.0 => format!("{:.2}", a / b),
                (Reached::At(a), Reached::By(b)) if b > 0.0 => format!(">={:.2}", a / b),
                _ => "-".into(),
            };
            let extrapolated = points.last().is_some_and(|p| p.1 > 0.02);
            let fmt = |x: Reached| match x {
                Reached::At(v) => format!("{v:.2}"),
                Reached::By(v) => format!("<={v:.2}"),
                Reached::No => "-".into(),
            };
            writeln!(
                summary,
                "{name},{label},{},{},{},{},{extrapolated}",
                fmt(t05),
                fmt(t02),
                ratio(baseline_times.0, t05),
                ratio(baseline_times.1, t02)
            )?;
            println!(
                "{name:>4} {label:<36} {f:>5} frames {wall:6.1} s: shown {:.4}; to 0.05 {} s, to 0.02 {} s{}",
                points.last().map_or(f64::NAN, |p| p.1),
                fmt(t05),
                fmt(t02),
                if extrapolated { " (extrapolated)" } else { "" }
            );
            series.push(Series { name: label.to_string(), points });
        }
        std::fs::write(out.join(format!("clean_{name}.csv")), csv)?;
        let title = format!("{name}: shown image's relative RMSE vs wall time, {size}^2");
        loglog(
            &out.join(format!("clean_{name}_error_vs_time.png")),
            &title,
            "wall time (s)",
            "relative RMSE",
            &series,
        )?;
    }
    std::fs::write(out.join("clean_summary.csv"), summary)?;
    println!("wrote {}", out.join("clean_summary.csv").display());
    Ok(())
}

fn luminance(p: &[f32; 4]) -> f64 {
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// Mean absolute frame-to-frame change of the shown luminance that the references' change does
/// not explain, relative to the references' mean luminance.
fn flicker(images: &[Image], refs: &[Image]) -> f64 {
    let mut sum = 0.0;
    let mut norm = 0.0;
    for t in 1..images.len() {
        for i in 0..images[t].len() {
            let change = luminance(&images[t][i]) - luminance(&images[t - 1][i]);
            sum += (change - (luminance(&refs[t][i]) - luminance(&refs[t - 1][i]))).abs();
            norm += luminance(&refs[t][i]);
        }
    }
    sum / norm.max(1e-30)
}

/// The camera path on vpt's scene: 60 views 3° apart, `paths` frames of one path per pixel each,
/// raw against denoised with temporal reuse, per-view references of `reference_frames` bounded
/// frames; writes `clean_path.csv` (per view) and prints the means and flicker ratios.
pub fn run_path(
    ctx: &Context,
    out: &Path,
    inputs: &Inputs,
    size: u32,
    paths: u64,
    reference_frames: u64,
) -> BenchResult<()> {
    std::fs::create_dir_all(out)?;
    let sc = scene("vpt", inputs)?;
    let r = VolumeRenderer::new(ctx, &sc.volume, &sc.tf)?;
    let dims = [size; 2];
    let view = |k: u32| Camera::orbit(2.0, k as f32 * 3f32.to_radians(), 0.3, Projection::Perspective { fov_y: 0.8 });
    let raw_s = setup_of(&sc.base, &[("mc_budget", "0")])?;
    let den_s = setup_of(&sc.base, &[("mc_budget", "0"), ("denoise", "on")])?;
    let ref_s = setup_of(&sc.base, &[("mc_budget", "512"), ("mc_paths", "4")])?;
    let empty = VolumeRenderer::new(ctx, &sc.volume, &TransferFunction::ramp(0.0, 1.0, [1.0; 3], 0.0))?;
    let mut raw_t = Targets::new(ctx, dims)?;
    let mut den_t = Targets::new(ctx, dims)?;
    let (mut raw, mut den, mut refs) = (Vec::new(), Vec::new(), Vec::new());
    let mut csv = format!(
        "# device: {} ({}); vpt's scene, {size}^2, 60 views 3 degrees apart, {paths} paths a view; per-view reference {reference_frames} frames of bounded work 512/4 (its noise removed)\nview,raw_rel_rmse,denoised_rel_rmse,denoise_gpu_ms\n",
        ctx.info.name, ctx.info.driver
    );
    let (mut e_raw, mut e_den) = (0.0, 0.0);
    for k in 0..60u32 {
        let cam = view(k);
        let mut bt = Targets::new(ctx, dims)?;
        render_frame(ctx, &empty, &mut bt, &cam, &ref_s.render, 0)?;
        let background = bt.read_hdr(ctx)?;
        let reference = reference(ctx, &r, &cam, &ref_s, dims, reference_frames, &background)?;
        let mut filter_ms = 0.0;
        for f in 0..paths {
            let frame = u64::from(k) * paths + f;
            render_frame(ctx, &r, &mut raw_t, &cam, &raw_s.render, frame)?;
            let run = render_frame(ctx, &r, &mut den_t, &cam, &den_s.render, frame)?;
            filter_ms += run
                .timings
                .iter()
                .filter(|p| p.name.starts_with("denoise") || p.name == "features" || p.name == "reproject")
                .map(|p| p.gpu_ms())
                .sum::<f64>();
        }
        let corrected = |e: f64| (e * e - reference.rel_mse).max(0.0).sqrt();
        let (a, b) = (raw_t.read_hdr(ctx)?, den_t.read_shown(ctx)?);
        let (ea, eb) = (
            corrected(rel_rmse(&a, &reference.mean, &background)),
            corrected(rel_rmse(&b, &reference.mean, &background)),
        );
        writeln!(csv, "{k},{ea:.6},{eb:.6},{filter_ms:.2}")?;
        e_raw += ea / 60.0;
        e_den += eb / 60.0;
        raw.push(a);
        den.push(b);
        refs.push(reference.mean);
    }
    let (f_raw, f_den) = (flicker(&raw, &refs), flicker(&den, &refs));
    writeln!(csv, "# mean relative RMSE raw {e_raw:.5}, denoised {e_den:.5} (ratio {:.3}); flicker raw {f_raw:.5}, denoised {f_den:.5} (ratio {:.3})", e_den / e_raw, f_den / f_raw)?;
    std::fs::write(out.join("clean_path.csv"), &csv)?;
    println!(
        "camera path, {size}^2, {paths} paths a view: mean relative RMSE raw {e_raw:.4}, shown {e_den:.4} ({:.2}x); flicker raw {f_raw:.5}, shown {f_den:.5} ({:.2}x)",
        e_den / e_raw,
        f_den / f_raw
    );
    Ok(())
}
