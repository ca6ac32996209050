//! The denoised Monte Carlo image (`denoise=on`) against the unbiased mean and long independent
//! references (lavapipe, validation + sync validation): never worse than the raw mean and
//! converging to it, not blurring across albedo or depth edges, and temporal reuse on a moving
//! camera. Each test also runs the filter or the reprojection with a deliberate defect
//! (`DenoiseSettings::debug_flags`) and checks that its criterion then fails. The references are
//! this engine's own unbiased mean from more paths with another seed: the tests check the
//! denoiser, not the path tracer.

mod common;

use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{procedural, Volume};
use vkengine::volume::optics::tf::{TfPoint, TransferFunction};
use vkengine::volume::render::denoise::DenoiseSettings;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};

const SIZE: [u32; 2] = [40, 40];

/// Orthographic view down −Z: the unit cube covers pixels 10..30 on both axes.
fn ortho() -> Camera {
    Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 2.0 })
}

/// MCS, jittered; `budget` 0: one path per pixel and frame, else bounded work of up to `paths`.
fn settings(budget: u32, paths: u32, seed: u32, denoise: bool) -> RenderSettings {
    RenderSettings {
        renderer: RendererKind::Mcs,
        jitter: true,
        mc: McSettings { budget, paths_per_frame: paths, seed, ..Default::default() },
        denoise: DenoiseSettings { on: denoise, debug_flags: 0 },
        ..Default::default()
    }
}

/// Environment light only: both sides of an edge see the same light.
fn env_only(s: RenderSettings) -> RenderSettings {
    RenderSettings { mc: McSettings { sun_dir: None, env_radiance: [1.0; 3], ..s.mc }, ..s }
}

/// A reference: the mean of more paths with another seed, and its per-pixel variance.
struct Reference {
    mean: Vec<[f32; 4]>,
    var: Vec<[f64; 3]>,
    /// The variance of one path per pixel and channel.
    path_var: Vec<[f64; 3]>,
}

/// Relative RMSE against the exact image, estimated against `r`: E[(a − r)²] is a's squared
/// error plus the reference's variance, which its moments give and which is taken off.
fn rel_rmse(a: &[[f32; 4]], r: &Reference) -> f64 {
    let (mut e, mut s) = (0.0f64, 0.0f64);
    for ((x, y), v) in a.iter().zip(&r.mean).zip(&r.var) {
        for c in 0..3 {
            e += (f64::from(x[c]) - f64::from(y[c])).powi(2) - v[c];
            s += f64::from(y[c]).powi(2);
        }
    }
    (e.max(0.0) / s).sqrt()
}

/// How much `den`'s squared relative error exceeds `raw`'s, estimated against `r`, and the
/// standard deviation that the reference's own noise gives that difference. With e_a² as
/// [`rel_rmse`] estimates it, e_den² − e_raw² = Σ (den − raw)(den + raw − 2μ) / Σ r² minus
/// 2 Σ (den − raw)(r − μ) / Σ r²: the second term has mean 0 and variance 4 Σ (den − raw)² var(r)
/// / (Σ r²)². Once the paths make the two images nearly equal it is larger than the first (at 256
/// paths per pixel: a difference of 4.5e-9 against a standard deviation of 8.8e-8), and the
/// comparison's sign is the reference's noise, not the filter's.
fn excess_sq_error(den: &[[f32; 4]], raw: &[[f32; 4]], r: &Reference) -> (f64, f64) {
    let (mut d, mut noise, mut s) = (0.0f64, 0.0f64, 0.0f64);
    for ((a, b), (y, v)) in den.iter().zip(raw).zip(r.mean.iter().zip(&r.var)) {
        for c in 0..3 {
            let (a, b, y) = (f64::from(a[c]), f64::from(b[c]), f64::from(y[c]));
            d += (a - y).powi(2) - (b - y).powi(2);
            noise += (a - b).powi(2) * v[c];
            s += y * y;
        }
    }
    (d / s, 2.0 * noise.sqrt() / s)
}

/// Variance of each pixel's mean per channel from the moments image (0 below two paths).
fn var_of_mean(m: &[[f32; 4]]) -> Vec<[f64; 3]> {
    m.iter()
        .map(|p| {
            let n = f64::from(p[3]);
            let v = |c: usize| if n >= 2.0 { f64::from(p[c]) / (n * (n - 1.0)) } else { 0.0 };
            [v(0), v(1), v(2)]
        })
        .collect()
}

/// χ² of the 8×8 blocks' mean differences between `a` and the raw mean, each over the raw block
/// mean's variance (channels with variance: the medium, not the background).
fn chi2_blocks(a: &[[f32; 4]], raw: &[[f32; 4]], var: &[[f64; 3]]) -> f64 {
    let (mut sum, mut count) = (0.0, 0);
    for by in 0..SIZE[1] / 8 {
        for bx in 0..SIZE[0] / 8 {
            for c in 0..3 {
                let (mut d, mut v) = (0.0f64, 0.0f64);
                for y in by * 8..by * 8 + 8 {
                    for x in bx * 8..bx * 8 + 8 {
                        let i = (y * SIZE[0] + x) as usize;
                        d += f64::from(a[i][c]) - f64::from(raw[i][c]);
                        v += var[i][c];
                    }
                }
                if v > 1e-12 {
                    sum += (d / 64.0).powi(2) / (v / 4096.0);
                    count += 1;
                }
            }
        }
    }
    assert!(count > 0, "no block has variance");
    sum / f64::from(count)
}

fn run(ctx: &Context, r: &VolumeRenderer, t: &mut Targets, cam: &Camera, s: &RenderSettings, frames: u64, first: u64) {
    for f in first..first + frames {
        render_frame(ctx, r, t, cam, s, f).expect("render");
    }
}

fn reference(ctx: &Context, r: &VolumeRenderer, cam: &Camera, s: &RenderSettings, frames: u64) -> Reference {
    let mut t = Targets::new(ctx, SIZE).expect("targets");
    let s = RenderSettings { denoise: DenoiseSettings::default(), mc: McSettings { seed: 99, ..s.mc }, ..*s };
    run(ctx, r, &mut t, cam, &s, frames, 0);
    let moments = t.read_moments(ctx).expect("moments");
    let path_var =
        moments.iter().map(|p| [0, 1, 2].map(|c| f64::from(p[c]) / f64::from(p[3] - 1.0).max(1.0))).collect();
    Reference { mean: t.read_hdr(ctx).expect("readback"), var: var_of_mean(&moments), path_var }
}

/// A procedural cloud, lit by the default sun and sky.
fn cloud(ctx: &Context) -> VolumeRenderer {
    let vol = procedural::cloud([32; 3], 3).expect("volume");
    let tf = TransferFunction::ramp(0.05, 0.5, [0.9, 0.85, 0.8], 10.0);
    VolumeRenderer::new(ctx, &vol, &tf).expect("renderer")
}

#[test]
fn denoised_error_stays_below_raw_and_converges_to_the_mean() {
    common::gpu_test(|ctx| {
        let r = cloud(ctx);
        // Bounded work, the paths per frame raised with the checkpoint (a frame-time knob: the
        // mean goes on), so the checkpoints are paths per pixel from 1 to 4,096.
        let s = settings(6000, 1, 0, true);
        let want =
            reference(ctx, &r, &ortho(), &RenderSettings { mc: McSettings { paths_per_frame: 64, ..s.mc }, ..s }, 256);
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        let mut done = 0;
        // The image's paths per pixel (bounded work: pixels differ; the mean of their counts).
        let paths = |t: &Targets| {
            let m = t.read_moments(ctx).expect("moments");
            m.iter().map(|p| f64::from(p[3])).sum::<f64>() / m.len() as f64
        };
        let mut s = s;
        for checkpoint in [1u32, 4, 16, 64, 256, 1024, 4096] {
            while done == 0 || paths(&t) < f64::from(checkpoint) {
                s.mc.paths_per_frame = (checkpoint / 8).clamp(1, 64);
                run(ctx, &r, &mut t, &ortho(), &s, 1, done);
                done += 1;
            }
            assert!(t.shows_denoised());
            let (den, raw) = (t.read_shown(ctx).expect("shown"), t.read_hdr(ctx).expect("mean"));
            let (e_den, e_raw) = (rel_rmse(&den, &want), rel_rmse(&raw, &want));
            let (excess, noise) = excess_sq_error(&den, &raw, &want);
            eprintln!(
                "{checkpoint} paths ({done} frames): relative RMSE denoised {e_den:.4}, raw {e_raw:.4}; \
                 e_den² − e_raw² {excess:.2e}, the reference's noise in it ±{noise:.1e}"
            );
            // Never worse, as far as the reference can tell: not above raw's error by more than
            // 3 standard deviations of the reference's own noise in the comparison.
            assert!(
                excess <= 3.0 * noise,
                "{checkpoint} paths: denoised {e_den} above raw {e_raw} (e² difference {excess:.2e}, reference noise ±{noise:.1e})"
            );
        }
        let var = var_of_mean(&t.read_moments(ctx).expect("moments"));
        let raw = t.read_hdr(ctx).expect("mean");
        let chi2 = chi2_blocks(&t.read_shown(ctx).expect("shown"), &raw, &var);
        eprintln!("χ² of 8×8 blocks, denoised vs raw: {chi2:.3}");
        assert!(chi2 <= 1.5, "denoised image does not agree with the mean within its noise: χ² = {chi2}");
        // A filter whose strength ignores the variance keeps blurring: one more frame with it (the
        // mean barely moves). The shrink toward the mean (denoise_shrink.comp) must take that
        // bias back, and with the shrink off too the same check must fail.
        let mut chi2_with = |flags: u32| {
            let broken = RenderSettings { denoise: DenoiseSettings { on: true, debug_flags: flags }, ..s };
            run(ctx, &r, &mut t, &ortho(), &broken, 1, done);
            done += 1;
            let var = var_of_mean(&t.read_moments(ctx).expect("moments"));
            chi2_blocks(&t.read_shown(ctx).expect("shown"), &t.read_hdr(ctx).expect("mean"), &var)
        };
        let chi2_shrunk = chi2_with(1);
        eprintln!("χ² with the variance ignored, shrink on: {chi2_shrunk:.3}");
        assert!(chi2_shrunk <= 1.5, "the shrink does not keep a variance-blind filter consistent: χ² = {chi2_shrunk}");
        let chi2_broken = chi2_with(1 | 8);
        eprintln!("χ² with the variance ignored and no shrink: {chi2_broken:.3}");
        assert!(chi2_broken > 1.5, "the check cannot fail: a variance-blind filter gave χ² = {chi2_broken}");
        // The never-worse check resolves such a filter's error at 4,096 paths.
        let (excess, noise) =
            excess_sq_error(&t.read_shown(ctx).expect("shown"), &t.read_hdr(ctx).expect("mean"), &want);
        eprintln!("variance ignored, no shrink: e_den² − e_raw² {excess:.2e}, reference noise ±{noise:.1e}");
        assert!(excess > 3.0 * noise, "the never-worse check cannot fail: {excess:.2e} against ±{noise:.1e}");
        assert_eq!(r.majorant_violations(), 0);
    });
}

/// A 32³ volume of value `v(x, z)` (voxel indices).
fn two_regions(v: impl Fn(u32, u32) -> f32) -> Volume {
    let n = 32u32;
    let data = (0..n * n * n).map(|i| v(i % n, i / (n * n))).collect();
    Volume::new([n; 3], [1.0; 3], data, "two regions").expect("volume")
}

/// Per channel, over rows 12..28 of `column`: the mean of `a − want` and its standard error
/// from the raw image's variance `var`.
fn column_bias(a: &[[f32; 4]], want: &[[f32; 4]], var: &[[f64; 3]], column: u32) -> [(f64, f64); 3] {
    let rows = 12..28u32;
    let k = rows.len() as f64;
    [0, 1, 2].map(|c| {
        let (mut d, mut v) = (0.0, 0.0);
        for y in rows.clone() {
            let i = (y * SIZE[0] + column) as usize;
            d += f64::from(a[i][c]) - f64::from(want[i][c]);
            v += var[i][c];
        }
        (d / k, (v / (k * k)).sqrt())
    })
}

/// The largest bias of the columns beside the edge at pixel 20, in standard errors.
fn edge_bias(a: &[[f32; 4]], want: &[[f32; 4]], var: &[[f64; 3]]) -> f64 {
    [17, 18, 22, 23]
        .iter()
        .flat_map(|&col| column_bias(a, want, var, col))
        // Channels without variance are the background the rays see through the empty half.
        .filter(|&(_, se)| se > 1e-6)
        .map(|(d, se)| d.abs() / se)
        .fold(0.0, f64::max)
}

const SEEDS: u32 = 8;

/// The denoised image of one path per pixel, averaged over `SEEDS` independent runs.
fn seeds_mean(ctx: &Context, r: &VolumeRenderer, s: &RenderSettings) -> Vec<[f32; 4]> {
    let mut sum = vec![[0.0f32; 4]; (SIZE[0] * SIZE[1]) as usize];
    for seed in 0..SEEDS {
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        run(ctx, r, &mut t, &ortho(), &RenderSettings { mc: McSettings { seed, ..s.mc }, ..*s }, 1, 0);
        for (a, b) in sum.iter_mut().zip(t.read_shown(ctx).expect("shown")) {
            for c in 0..4 {
                a[c] += b[c] / SEEDS as f32;
            }
        }
    }
    sum
}

#[test]
fn denoiser_does_not_blur_across_albedo_or_depth_edges() {
    common::gpu_test(|ctx| {
        // Albedo edge: the left half (value 0.25) scatters red, the right half (0.75) blue, of
        // about the same luminance, at the same extinction, under the default sun and sky: only
        // the albedo feature differs.
        let a = [0.9, 0.2, 0.2];
        let b = [0.2, 0.35, 0.9];
        let point = |value, color, extinction| TfPoint { value, color, extinction };
        let tf_albedo = TransferFunction::OneD {
            points: vec![
                point(0.0, a, 0.0),
                point(0.2, a, 30.0),
                point(0.3, a, 30.0),
                point(0.7, b, 30.0),
                point(1.0, b, 30.0),
            ],
        };
        // Values are normalized by their range: a voxel of 0 and one of 1 at the corners (empty,
        // and a speck far from the rows measured) keep 0.25 and 0.75 where they are.
        let albedo_edge = two_regions(|x, z| match (x, z) {
            (0, 0) => 0.0,
            (31, 31) => 1.0,
            _ if x < 16 => 0.25,
            _ => 0.75,
        });
        // Depth edge: one albedo; a slab at the front on the left, at the back on the right,
        // whose part beside the edge the left one shadows from an orange sun on the left, so it
        // sees only the blue sky: the only feature that differs across the edge is the depth.
        let depth_edge = two_regions(|x, z| if (x < 16 && z >= 22) || (x >= 16 && z < 10) { 0.75 } else { 0.0 });
        let tf_depth =
            TransferFunction::OneD { points: vec![point(0.0, b, 0.0), point(0.5, b, 30.0), point(1.0, b, 30.0)] };
        let sun = |s: RenderSettings| {
            let mc = McSettings {
                sun_dir: Some([-0.45, 0.2, 0.87]),
                sun_radiance: [3.0, 1.5, 0.3],
                env_radiance: [0.2, 0.3, 1.0],
                ..s.mc
            };
            RenderSettings { mc, ..s }
        };
        let cases = [("albedo", albedo_edge, tf_albedo, (|s| s) as fn(_) -> _), ("depth", depth_edge, tf_depth, sun)];
        for (name, vol, tf, light) in cases {
            let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
            let want = reference(ctx, &r, &ortho(), &light(settings(2048, 64, 0, false)), 16);
            // One path a pixel: noise the luminance test cannot tell from the edge; the standard
            // errors are those of one path, from the reference's paths.
            // Averaged over independent seeds: the standard errors halve, a blur's bias does not.
            let s = light(settings(0, 1, 0, true));
            let var: Vec<[f64; 3]> = want.path_var.iter().map(|v| v.map(|x| x / SEEDS as f64)).collect();
            let bias = edge_bias(&seeds_mean(ctx, &r, &s), &want.mean, &var);
            eprintln!("{name} edge: largest bias beside it {bias:.2} standard errors of the raw mean");
            assert!(bias <= 4.0, "{name} edge: the denoiser blurs across it ({bias:.2} standard errors)");
            // The same frame filtered without the features must fail the check.
            let broken = RenderSettings { denoise: DenoiseSettings { on: true, debug_flags: 2 }, ..s };
            let bias_broken = edge_bias(&seeds_mean(ctx, &r, &broken), &want.mean, &var);
            eprintln!("{name} edge, features ignored: {bias_broken:.2} standard errors");
            assert!(bias_broken > 4.0, "{name} edge: the check cannot fail ({bias_broken:.2} without features)");
        }
    });
}

/// Views on an orbit `step` radians apart, looking slightly down at the volume.
fn orbit_view(k: u32) -> Camera {
    Camera::orbit(2.4, k as f32 * 3f32.to_radians(), 0.3, Projection::Perspective { fov_y: 0.8 })
}

fn luminance(p: &[f32; 4]) -> f64 {
    0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
}

/// Mean absolute frame-to-frame change not explained by the references' change.
fn flicker(images: &[Vec<[f32; 4]>], refs: &[Reference]) -> f64 {
    let refs: Vec<&Vec<[f32; 4]>> = refs.iter().map(|r| &r.mean).collect();
    let mut sum = 0.0;
    for t in 1..images.len() {
        let d: f64 = (0..images[t].len())
            .map(|i| {
                let change = luminance(&images[t][i]) - luminance(&images[t - 1][i]);
                (change - (luminance(&refs[t][i]) - luminance(&refs[t - 1][i]))).abs()
            })
            .sum();
        sum += d / images[t].len() as f64;
    }
    sum / (images.len() - 1) as f64
}

#[test]
fn moving_camera_halves_error_and_flicker() {
    common::gpu_test(|ctx| {
        let r = cloud(ctx);
        // 60 views 3° apart, 4 paths a pixel each (one a frame), as a window or a camera path.
        let s = settings(0, 1, 0, true);
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        let (mut shown, mut raw, mut refs) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..60 {
            run(ctx, &r, &mut t, &orbit_view(k), &s, 4, u64::from(k) * 4);
            shown.push(t.read_shown(ctx).expect("shown"));
            raw.push(t.read_hdr(ctx).expect("mean"));
            refs.push(reference(ctx, &r, &orbit_view(k), &settings(6000, 64, 0, false), 4));
        }
        let mean_err = |imgs: &[Vec<[f32; 4]>]| imgs.iter().zip(&refs).map(|(a, b)| rel_rmse(a, b)).sum::<f64>() / 60.0;
        let (e_shown, e_raw) = (mean_err(&shown), mean_err(&raw));
        let (f_shown, f_raw) = (flicker(&shown, &refs), flicker(&raw, &refs));
        eprintln!("60 views at 4 paths: mean relative RMSE shown {e_shown:.4}, raw {e_raw:.4}; flicker shown {f_shown:.5}, raw {f_raw:.5}");
        assert!(e_shown <= 0.5 * e_raw, "moving camera: shown error {e_shown} above half the raw {e_raw}");
        assert!(f_shown <= 0.5 * f_raw, "moving camera: shown flicker {f_shown} above half the raw {f_raw}");
    });
}

#[test]
fn a_removed_object_leaves_no_ghost_after_two_frames() {
    common::gpu_test(|ctx| {
        // Two boxes: value 0.5 on the left, 1 on the right; the second transfer function makes
        // the right one transparent, and the camera turns one step as it changes.
        let n = 32u32;
        let data = (0..n * n * n)
            .map(|i| {
                let (x, y, z) = (i % n, (i / n) % n, i / (n * n));
                let inside = (8..24).contains(&y) && (8..24).contains(&z);
                match x {
                    4..=13 if inside => 0.5,
                    18..=27 if inside => 1.0,
                    _ => 0.0,
                }
            })
            .collect();
        let vol = Volume::new([n; 3], [1.0; 3], data, "two boxes").expect("volume");
        let point = |value, color, extinction| TfPoint { value, color, extinction };
        let both = TransferFunction::OneD {
            points: vec![point(0.0, [0.9; 3], 0.0), point(0.4, [0.9; 3], 20.0), point(1.0, [0.9, 0.3, 0.2], 20.0)],
        };
        let left = TransferFunction::OneD {
            points: vec![
                point(0.0, [0.9; 3], 0.0),
                point(0.4, [0.9; 3], 20.0),
                point(0.6, [0.9; 3], 20.0),
                point(0.8, [0.9; 3], 0.0),
                point(1.0, [0.9; 3], 0.0),
            ],
        };
        let mut r = VolumeRenderer::new(ctx, &vol, &both).expect("renderer");
        let s = env_only(settings(0, 1, 0, true));
        let with = reference(ctx, &r, &orbit_view(1), &env_only(settings(6000, 64, 0, false)), 4).mean;
        r.set_transfer_function(ctx, &left).expect("tf");
        let without = reference(ctx, &r, &orbit_view(1), &env_only(settings(6000, 64, 0, false)), 4).mean;
        // Where the removed box was: the references differ by more than 10 %.
        let region: Vec<usize> = (0..with.len())
            .filter(|&i| (luminance(&with[i]) - luminance(&without[i])).abs() > 0.1 * luminance(&without[i]))
            .collect();
        assert!(region.len() > 20, "the removed box covers {} pixels", region.len());
        for flags in [0, 4] {
            r.set_transfer_function(ctx, &both).expect("tf");
            let s = RenderSettings { denoise: DenoiseSettings { on: true, debug_flags: flags }, ..s };
            let mut t = Targets::new(ctx, SIZE).expect("targets");
            run(ctx, &r, &mut t, &orbit_view(0), &s, 16, 0);
            r.set_transfer_function(ctx, &left).expect("tf");
            run(ctx, &r, &mut t, &orbit_view(1), &s, 2, 16);
            let shown = t.read_shown(ctx).expect("shown");
            // The signed fraction of the removed box's contribution still shown (noise cancels).
            let ghost = region.iter().map(|&i| luminance(&shown[i]) - luminance(&without[i])).sum::<f64>()
                / region.iter().map(|&i| luminance(&with[i]) - luminance(&without[i])).sum::<f64>();
            eprintln!("flags {flags}: {:.3} of the removed box left after 2 frames ({} pixels)", ghost, region.len());
            match flags {
                0 => assert!(ghost.abs() <= 0.1, "a ghost of the removed box survives: {ghost}"),
                _ => assert!(ghost.abs() > 0.1, "the check cannot fail: keeping every history tap left {ghost}"),
            }
        }
    });
}

#[test]
fn feature_march_skips_empty_cells_and_finds_the_half_transmittance_depth() {
    common::gpu_test(|ctx| {
        // The near half of the box (world z > 0, voxels z ≥ 16 of 32) is empty, the far half a
        // homogeneous absorber of extinction σ (a step of the transfer function at value ½, which
        // trilinear filtering puts on the plane z = 0). Looking down −Z the march passes the
        // empty majorant cell by lookups alone and must still find the depth where the
        // transmittance falls to ½: z = 0 reached at the box's entry + 0.5, then ln 2 / σ.
        let sigma = 8.0f32;
        let vol = two_regions(|_, z| if z < 16 { 1.0 } else { 0.0 });
        let point = |value, extinction| TfPoint { value, color: [0.5; 3], extinction };
        let tf = TransferFunction::OneD {
            points: vec![point(0.0, 0.0), point(0.498, 0.0), point(0.502, sigma), point(1.0, sigma)],
        };
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let cam = ortho();
        let s = RenderSettings { jitter: false, ..env_only(settings(0, 1, 1, true)) };
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        render_frame(ctx, &r, &mut t, &cam, &s, 0).expect("render");
        let f = t.read_features(ctx).expect("features");
        // The ray's origin on the near plane (depth is measured from it), from the inverse
        // view-projection in f64; the rays run along −Z.
        let m = cam.inverse_view_projection(1.0).to_cols_array().map(f64::from);
        let mut worst = 0.0f64;
        for y in 12..28u32 {
            for x in 12..28u32 {
                let nx = (f64::from(x) + 0.5) / f64::from(SIZE[0]) * 2.0 - 1.0;
                let ny = -((f64::from(y) + 0.5) / f64::from(SIZE[1]) * 2.0 - 1.0);
                let c: [f64; 4] = [0, 1, 2, 3].map(|row| m[row] * nx + m[4 + row] * ny + m[12 + row]);
                // From the near plane to z = 0, then ln 2 / σ into the absorber.
                let want = c[2] / c[3] + std::f64::consts::LN_2 / f64::from(sigma);
                let got = f64::from(f[(y * SIZE[0] + x) as usize].depth);
                worst = worst.max((got - want).abs());
            }
        }
        let corner = f[0].depth;
        eprintln!("empty half then absorber: feature depth worst error {worst:e}; corner {corner}");
        assert!(worst < 1e-3, "feature depth off by {worst}");
        assert!(corner < 0.0, "a ray that misses the box has feature depth {corner}, not background");
    });
}

/// With the camera still, the denoised image depends only on its own frame's mean, moments and
/// features: denoising the last of several frames alone (what a headless run that writes one
/// image does, `demos/src/volume_headless.rs`) shows the same image, bit for bit, as denoising
/// every frame. Fails if the filter kept anything from one frame of a view to the next.
#[test]
fn denoising_only_the_last_frame_of_a_still_view_shows_the_same_image() {
    common::gpu_test(|ctx| {
        let r = cloud(ctx);
        for budget in [0, 64] {
            let on = settings(budget, 2, 5, true);
            let off = RenderSettings { denoise: DenoiseSettings { on: false, ..on.denoise }, ..on };
            let (mut every, mut last) =
                (Targets::new(ctx, SIZE).expect("targets"), Targets::new(ctx, SIZE).expect("targets"));
            run(ctx, &r, &mut every, &ortho(), &on, 6, 0);
            run(ctx, &r, &mut last, &ortho(), &off, 5, 0);
            run(ctx, &r, &mut last, &ortho(), &on, 1, 5);
            let (a, b) = (every.read_shown(ctx).expect("shown"), last.read_shown(ctx).expect("shown"));
            assert!(every.shows_denoised() && last.shows_denoised());
            assert_ne!(a, last.read_hdr(ctx).expect("mean"), "budget {budget}: the filter changed nothing");
            let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            assert_eq!(differ, 0, "budget {budget}: {differ} pixels differ");
        }
    });
}
