//! `volume_bench --peer-scene vpt`: vpt's default MCM scene (terier/vpt, the original WebGL path
//! tracer), mapped setting by setting as `../shared/peers/vpt/README.md` gives it — its 128³ fBm
//! cloud (`make_volume.py`), σ_t = 100·α(v) with α(v) = clamp((v − 0.25)/0.5, 0, 1), albedo
//! (1, 0, 0), isotropic phase, a white environment, at most 8 scattering events, camera at
//! distance 2 looking down −Z — rendered by each Monte Carlo variant of this engine, with the
//! relative RMSE of the foreground against a long independent reference after 1, 2, 4, … frames
//! against wall time. Writes `peer_vpt.csv`, `peer_vpt_error_vs_time.png` (with vpt's own curve as
//! measured on this machine for issue 21) and prints the time each variant needs to reach
//! relative RMSE 0.05 and 0.02 (log-log interpolation, or the t^−½ extrapolation past the last
//! point).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;
use vkengine::plot::{loglog, Series};
use vkengine::settings::{Origin, Setting};
use vkengine::vk::Context;
use vkengine::volume::data::{load, LoadOptions, Volume, VoxelType};
use vkengine::volume::optics::tf::{TfPoint, TransferFunction};
use vkengine::volume::render::renderer::{render_frame, Targets, VolumeRenderer};
use vkengine::volume::render::settings::VolumeSetup;

/// vpt's MCM on vpt's scene at 512², this machine's lavapipe, headless Chromium (issue 21's table:
/// wall seconds, relative RMSE of the foreground against the same kind of reference).
const VPT_512: [(f64, f64); 5] = [(14.0, 0.118), (27.0, 0.084), (53.0, 0.060), (113.0, 0.043), (240.0, 0.032)];

/// Our transfer function over the normalized value v' = (x − lo)/(hi − lo) equal to vpt's
/// σ_t = 100·α(x/255) (its 2-texel table sampled linearly has texel centres at 0.25 and 0.75 and
/// clamps outside), red albedo: the harness' `vpt_tf_for_range`.
pub fn vpt_transfer_function(lo: f32, hi: f32) -> TransferFunction {
    let sigma = |vp: f32| {
        let x = lo + vp * (hi - lo);
        100.0 * ((x / 255.0 - 0.25) / 0.5).clamp(0.0, 1.0)
    };
    let mut knots = vec![0.0f32, 1.0];
    for v in [0.25f32, 0.75] {
        let vp = (255.0 * v - lo) / (hi - lo);
        if vp > 0.0 && vp < 1.0 {
            knots.push(vp);
        }
    }
    knots.sort_by(f32::total_cmp);
    let points =
        knots.into_iter().map(|v| TfPoint { value: v, color: [1.0, 0.0, 0.0], extinction: sigma(v) }).collect();
    TransferFunction::OneD { points }
}

/// A variant: its label, its settings over the scene's, and its frame multiplier.
type Variant = (&'static str, &'static [(&'static str, &'static str)], u64);
/// (wall seconds, relative RMSE) points.
type Curve = Vec<(f64, f64)>;

/// Relative RMSE over the foreground (pixels where the reference is not the bare environment `env`).
fn rel_rmse(img: &[[f32; 4]], reference: &[[f32; 4]], env: [f32; 3]) -> f64 {
    let (mut err, mut norm) = (0.0f64, 0.0f64);
    for (a, r) in img.iter().zip(reference) {
        if r[..3].iter().zip(env).all(|(&c, e)| (c - e).abs() < 1e-6) {
            continue;
        }
        for c in 0..3 {
            err += (f64::from(a[c]) - f64::from(r[c])).powi(2);
            norm += f64::from(r[c]).powi(2);
        }
    }
    (err / norm.max(1e-30)).sqrt()
}

/// Seconds to reach `target` on a (seconds, error) curve: log-log interpolation between the
/// points around it, or the t^−½ law from the last point when the curve ends above it.
pub fn time_to(points: &[(f64, f64)], target: f64) -> Option<f64> {
    for w in points.windows(2) {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        if e0 >= target && e1 <= target && e0 > e1 {
            let f = (e0.ln() - target.ln()) / (e0.ln() - e1.ln());
            return Some((t0.ln() + f * (t1.ln() - t0.ln())).exp());
        }
    }
    let &(t, e) = points.last()?;
    (e > target).then(|| t * (e / target).powi(2))
}

/// terier/vpt's MCM defaults as this engine's settings (`../shared/peers/vpt/README.md`).
pub const VPT_SETTINGS: &[(&str, &str)] = &[
    ("renderer", "mcm"),
    ("env", "1"),
    ("sun", "0"),
    ("phase", "iso"),
    ("bounces", "8"),
    ("yaw", "0"),
    ("pitch", "0"),
    ("distance", "2"),
    ("target", "0,0,0"),
    ("camera", "persp"),
];

/// vpt's 128³ u8 cloud from `path` and its transfer function, or why not.
pub fn vpt_scene(path: &Path) -> Result<(Volume, TransferFunction), Box<dyn std::error::Error>> {
    if !path.is_file() {
        return Err(Box::new(vkengine::Error::Input(format!(
            "{}: no such file; make vpt's cloud with `python3 ../shared/peers/vpt/harness/make_volume.py {}`",
            path.display(),
            path.display()
        ))));
    }
    let opts = LoadOptions { dims: Some([128; 3]), voxel: Some(VoxelType::U8), ..Default::default() };
    let vol = load(path, &opts)?;
    let [lo, hi] = vol.value_range;
    Ok((vol, vpt_transfer_function(lo, hi)))
}

/// Runs the comparison at `size`² with `frames` frames per variant and a `reference_frames`
/// reference, on `scene`: `vpt` (the raw 128³ u8 cloud at `volume`) or `cloud` (this engine's
/// default volume scene: the built-in 128³ cloud lit by the sun and the sky colour, HG 0.3, up to
/// 64 events); writes `peer_<scene>.csv` and its plot into `out`. `only`: the variants whose label
/// contains one of these (all if empty).
#[allow(clippy::too_many_arguments)]
pub fn run(
    ctx: &Context,
    out: &Path,
    scene: &str,
    volume: &Path,
    size: u32,
    frames: u64,
    reference_frames: u64,
    only: &[String],
) -> Result<(), Box<dyn std::error::Error>> {
    let vpt = scene == "vpt";
    let (vol, tf) = match vpt {
        true => vpt_scene(volume)?,
        false => (vkengine::volume::data::procedural::cloud([128; 3], 0)?, TransferFunction::preset("cloud")?),
    };
    let renderer = VolumeRenderer::new(ctx, &vol, &tf)?;
    let base: &[(&str, &str)] = if vpt { VPT_SETTINGS } else { &[("renderer", "mcm"), ("n", "128")] };
    let setup = |extra: &[(&str, &str)]| -> vkengine::Result<VolumeSetup> {
        let all: Vec<Setting> =
            base.iter().chain(extra).map(|(k, v)| Setting::new(*k, v.to_string(), Origin::Cli)).collect();
        VolumeSetup::parse(&all)
    };
    let reference_setup = setup(&[("view_ray", "estimate"), ("mc_budget", "0")])?;
    let cam = crate::volume_scene::camera(&reference_setup, &vol, renderer.box_half(), 1.0);
    let dims = [size; 2];
    let mut t = Targets::new(ctx, dims)?;
    for f in 0..reference_frames {
        // Frame numbers far from the runs': independent random streams.
        render_frame(ctx, &renderer, &mut t, &cam, &reference_setup.render, 1_000_000 + f)?;
    }
    let reference = t.read_hdr(ctx)?;
    let env = reference_setup.render.mc.env_radiance;
    println!("reference: {reference_frames} frames of one path per pixel at {size}²");
    // The first is the reference's own estimator (the noise correction below relies on it). Each
    // runs `frames` frames times its multiplier (small frames get more, for a comparable time).
    let variants: [Variant; 13] = [
        ("one path per frame, view ray estimated", &[("view_ray", "estimate"), ("mc_budget", "0")], 1),
        ("one path per frame (view ray by escape)", &[("view_ray", "escape"), ("mc_budget", "0")], 1),
        ("one path per frame, next-flight environment", &[("env_light", "flight"), ("mc_budget", "0")], 1),
        // What a user gets without asking: one whole path or bounded work, chosen per device.
        ("mc_budget=auto (the default)", &[], 1),
        ("bounded work 512/4 (view ray by escape)", &[("mc_budget", "512"), ("mc_paths", "4")], 1),
        (
            "bounded work 512/4, next-flight environment",
            &[("mc_budget", "512"), ("mc_paths", "4"), ("env_light", "flight")],
            1,
        ),
        (
            "bounded work 512/4, next-flight, no regrouping",
            &[("mc_budget", "512"), ("mc_paths", "4"), ("env_light", "flight"), ("mc_regroup", "100")],
            1,
        ),
        // Interactive frames (vpt's iteration is 8 tracking steps): about 66 ms at 512² here.
        ("bounded work 8/4", &[("mc_budget", "8"), ("mc_paths", "4")], 8),
        // The same frame time by interleaving: a sixteenth of the tiles a frame, 512/4 each.
        ("bounded work 512/4, interleave 16", &[("mc_budget", "512"), ("mc_paths", "4"), ("mc_interleave", "16")], 16),
        (
            "bounded work 32/1, next-flight environment",
            &[("mc_budget", "32"), ("mc_paths", "1"), ("env_light", "flight")],
            16,
        ),
        // Adaptive sampling: tiles stop at their target (the image's error then falls faster
        // toward it, not past it).
        ("mc_budget=auto + adaptive 0.05", &[("adaptive", "on"), ("adaptive_error", "0.05")], 1),
        ("mc_budget=auto + adaptive 0.02", &[("adaptive", "on"), ("adaptive_error", "0.02")], 1),
        (
            "bounded work 512/4 + adaptive 0.02",
            &[("mc_budget", "512"), ("mc_paths", "4"), ("adaptive", "on"), ("adaptive_error", "0.02")],
            1,
        ),
    ];
    let what = if vpt {
        "vpt's scene (cloud128, sigma_t = 100 alpha, albedo (1,0,0), iso, env 1, 8 events)"
    } else {
        "the default cloud (procedural 128^3, preset cloud, sun 3 + sky colour, HG 0.3, 64 events)"
    };
    let header = format!(
        "# device: {} ({}); {what}, {size}^2; reference {reference_frames} frames; rel_rmse over the foreground; wall seconds: frame submission and wait, checkpoint readbacks excluded",
        ctx.info.name, ctx.info.driver
    );
    let mut rows = Vec::new();
    // Label, frames run, (wall seconds, relative RMSE) at each checkpoint.
    let mut curves: Vec<(&str, u64, Curve)> = Vec::new();
    for (label, extra, times) in variants {
        let frames = frames * times;
        if !only.is_empty() && !only.iter().any(|o| label.contains(o.as_str())) {
            continue;
        }
        let s = setup(extra)?;
        let mut t = Targets::new(ctx, dims)?;
        let (mut wall, mut gpu) = (0.0f64, 0.0f64);
        let mut points = Vec::new();
        for f in 0..frames {
            let start = Instant::now();
            let run = render_frame(ctx, &renderer, &mut t, &cam, &s.render, f)?;
            wall += start.elapsed().as_secs_f64();
            gpu += run.gpu_ms() * 1e-3;
            let n = f + 1;
            if n.is_power_of_two() || n == frames {
                let e = rel_rmse(&t.read_hdr(ctx)?, &reference, env);
                let estimated = t.error_estimate().and_then(|x| x.relative).unwrap_or(f64::NAN);
                rows.push((label, n, wall, gpu, e, estimated));
                points.push((wall, e));
            }
        }
        curves.push((label, frames, points));
    }
    // The reference's own noise: the first variant is the reference's estimator, so its last
    // point's squared error is a·(1/N + 1/N_ref) and the reference contributes a/N_ref to every
    // point's squared error (of any variant: the reference is common).
    let ref_mse = rows.iter().rev().find(|r| r.0 == variants[0].0).map_or(0.0, |r| {
        let (n, e) = (r.1 as f64, r.4);
        e * e / (1.0 / n + 1.0 / reference_frames as f64) / reference_frames as f64
    });
    let corrected = |e: f64| (e * e - ref_mse).max(0.0).sqrt();
    let mut csv = format!(
        "{header}; rel_rmse_corrected removes the reference's noise (relative MSE {ref_mse:.3e}); estimated: the image's own estimate from its pixels' second moments; image: the unbiased mean (a denoised image would be another value)\nvariant,image,frames,wall_s,gpu_s,rel_rmse,rel_rmse_corrected,estimated\n"
    );
    for (label, n, wall, gpu, e, est) in &rows {
        writeln!(csv, "{label},mean,{n},{wall:.3},{gpu:.3},{e:.6},{:.6},{est:.6}", corrected(*e))?;
    }
    let fmt = |x: Option<f64>| x.map_or("-".to_string(), |s| format!("{s:.1} s"));
    let mut series = Vec::new();
    for (label, frames, points) in curves {
        let points: Vec<(f64, f64)> = points.into_iter().map(|(t, e)| (t, corrected(e))).collect();
        println!(
            "{label:<44} after {frames} frames ({:.1} s): rel. RMSE {:.4} (reference noise removed); to 0.05: {}, to 0.02: {}",
            points.last().map_or(0.0, |p| p.0),
            points.last().map_or(0.0, |p| p.1),
            fmt(time_to(&points, 0.05)),
            fmt(time_to(&points, 0.02))
        );
        series.push(Series { name: label.to_string(), points });
    }
    if vpt && size == 512 {
        let vpt: Vec<(f64, f64)> = VPT_512.to_vec();
        println!(
            "vpt (issue 21's table, this machine, 512², against an 8,494-iteration reference): to 0.05: {:.1} s, to 0.02: {:.1} s",
            time_to(&vpt, 0.05).unwrap_or(0.0),
            time_to(&vpt, 0.02).unwrap_or(0.0)
        );
        series.push(Series { name: "vpt MCM (WebGL2, issue 21's run)".into(), points: vpt });
    }
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join(format!("peer_{scene}.csv")), csv)?;
    let plot = out.join(format!("peer_{scene}_error_vs_time.png"));
    let title =
        if vpt { "vpt's scene: relative RMSE vs wall time" } else { "default cloud: relative RMSE vs wall time" };
    loglog(&plot, title, "wall time (s)", "relative RMSE (foreground)", &series)?;
    println!("wrote {} and peer_{scene}.csv", plot.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_to_interpolates_in_log_log_and_extrapolates_as_t_to_the_minus_half() {
        // e = t^-1/2 through (1, 1) and (4, 0.5): 0.7071 is reached at t = 2.
        let pts = [(1.0, 1.0), (4.0, 0.5)];
        assert!((time_to(&pts, 0.5f64.sqrt()).unwrap_or(0.0) - 2.0).abs() < 1e-9);
        // Past the last point: (0.5 / 0.25)² × 4 = 16.
        assert!((time_to(&pts, 0.25).unwrap_or(0.0) - 16.0).abs() < 1e-9);
    }

    #[test]
    fn the_transfer_function_is_vpts_ramp() {
        // Values 0…255 unnormalized: α is 0 below 0.25·255, 1 above 0.75·255.
        let tf = vpt_transfer_function(0.0, 255.0);
        let at = |x: f32| tf.eval(x / 255.0, 0.0);
        assert_eq!(at(30.0)[3], 0.0);
        assert!((at(127.5)[3] - 50.0).abs() < 0.5, "{:?}", at(127.5));
        assert!((at(250.0)[3] - 100.0).abs() < 1e-3);
        assert_eq!(at(200.0)[..3], [1.0, 0.0, 0.0]);
    }
}
