//! Each Monte Carlo pixel's second moment (`volume::render::variance`) and adaptive sampling,
//! on lavapipe with validation: the per-pixel variance of the mean against the spread of
//! independent runs, the image's estimated relative error against its measured error against a
//! long independent reference (both accuracy checks against independent measurements), and
//! adaptive sampling's guards and unbiasedness.

mod common;

use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{procedural, Volume};
use vkengine::volume::optics::tf::{TfPoint, TransferFunction};
use vkengine::volume::render::convergence::ConvergenceSettings;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};

const SIZE: [u32; 2] = [32, 32];

/// Orthographic view down -Z: the unit cube covers pixels 8..24 of a 32² image.
fn ortho() -> Camera {
    Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 2.0 })
}

fn sphere_scene(ctx: &Context) -> VolumeRenderer {
    let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
    let tf = TransferFunction::ramp(0.0, 0.6, [0.8, 0.6, 0.9], 8.0);
    VolumeRenderer::new(ctx, &vol, &tf).expect("renderer")
}

/// A mean of `frames` frames whose first frame index is `first` (independent streams apart):
/// the mean and the moments.
fn run(
    ctx: &Context,
    r: &VolumeRenderer,
    s: &RenderSettings,
    frames: u64,
    first: u64,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Targets) {
    let mut t = Targets::new(ctx, SIZE).expect("targets");
    for f in 0..frames {
        render_frame(ctx, r, &mut t, &ortho(), s, first + f).expect("render");
    }
    assert_eq!(r.majorant_violations(), 0);
    (t.read_hdr(ctx).expect("hdr"), t.read_moments(ctx).expect("moments"), t)
}

/// The variance of the pixel's mean per channel from its moments, M2 / (n (n − 1)).
fn var_of_mean(m: &[f32; 4]) -> [f64; 3] {
    let n = f64::from(m[3]);
    [0, 1, 2].map(|c| if n >= 2.0 { f64::from(m[c]) / (n * (n - 1.0)) } else { 0.0 })
}

/// Over `k` independent runs: Σ over pixels and channels of the sample variance of the runs'
/// means (measured), and of the runs' average variance-of-the-mean estimate, with the standard
/// error of the measured sum were the estimate exact (a χ² of k − 1 degrees per value).
fn spread_against_estimate(ctx: &Context, r: &VolumeRenderer, s: &RenderSettings, k: u64, frames: u64) -> [f64; 3] {
    let runs: Vec<_> = (0..k).map(|i| run(ctx, r, s, frames, 10_000 * i)).collect();
    let (mut measured, mut estimated, mut se2) = (0.0, 0.0, 0.0);
    for p in 0..(SIZE[0] * SIZE[1]) as usize {
        for c in 0..3 {
            let xs: Vec<f64> = runs.iter().map(|(h, _, _)| f64::from(h[p][c])).collect();
            let mean = xs.iter().sum::<f64>() / k as f64;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1) as f64;
            let est = runs.iter().map(|(_, m, _)| var_of_mean(&m[p])[c]).sum::<f64>() / k as f64;
            measured += var;
            estimated += est;
            se2 += est * est * 2.0 / (k - 1) as f64;
        }
    }
    [measured, estimated, se2.sqrt()]
}

/// A frame's mean, moments and each tile's two halves' stopped flags.
type Snapshot = (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<[bool; 2]>);
#[test]
fn per_pixel_variance_of_the_mean_matches_the_spread_of_independent_runs() {
    common::gpu_test(|ctx| {
        let r = sphere_scene(ctx);
        for (label, budget, frames) in [("one path per frame", 0, 16), ("bounded work 256/4", 256, 8)] {
            let mc = McSettings { budget, paths_per_frame: 4, ..Default::default() };
            let s = RenderSettings { renderer: RendererKind::Mcm, jitter: true, mc, ..Default::default() };
            let [measured, estimated, se] = spread_against_estimate(ctx, &r, &s, 24, frames);
            let ratio = measured / estimated;
            eprintln!(
                "{label}: measured Σ var {measured:.4e}, estimated {estimated:.4e}, ratio {ratio:.3} ± {:.3}",
                se / estimated
            );
            assert!(estimated > 0.0, "{label}: no variance estimated");
            // 5 standard errors of the χ² spread, plus 3 % for the heavier tails of path radiance.
            assert!((ratio - 1.0).abs() <= 5.0 * se / estimated + 0.03, "{label}: ratio {ratio}");
        }
    });
}

/// Relative RMSE of `img` against `reference` over the pixels where the reference is not the
/// bare environment `env` (volume_bench's foreground), with the reference's own noise (its
/// estimated variance of the mean, `ref_var`) taken out of the squared error.
fn measured_relative_error(img: &[[f32; 4]], reference: &[[f32; 4]], ref_moments: &[[f32; 4]], env: [f32; 3]) -> f64 {
    let (mut err, mut norm) = (0.0f64, 0.0f64);
    for ((a, r), m) in img.iter().zip(reference).zip(ref_moments) {
        if r[..3].iter().zip(env).all(|(&c, e)| (c - e).abs() < 1e-6) {
            continue;
        }
        let v = var_of_mean(m);
        for c in 0..3 {
            err += (f64::from(a[c]) - f64::from(r[c])).powi(2) - v[c];
            norm += f64::from(r[c]).powi(2);
        }
    }
    (err.max(0.0) / norm).sqrt()
}

/// From 16 paths per pixel (`adaptive_min_paths`' default, before which `until_error` does not
/// stop a run) on. With fewer, the estimate counts fewer pixels: a pixel is foreground once its
/// paths differ, and at 4 paths the sphere's thin rim often has not (estimated 0.233, measured
/// 0.193 here).
#[test]
fn the_estimated_relative_error_predicts_the_error_against_a_long_reference() {
    common::gpu_test(|ctx| {
        let r = sphere_scene(ctx);
        let base = RenderSettings { renderer: RendererKind::Mcm, jitter: true, ..Default::default() };
        let one_path = RenderSettings { mc: McSettings { budget: 0, ..base.mc }, ..base };
        let (reference, ref_moments, _) = run(ctx, &r, &one_path, 1024, 1_000_000);
        let env = one_path.mc.env_radiance;
        let mut bad = Vec::new();
        for (label, budget, frames) in
            [("one path per frame", 0, 16), ("one path per frame", 0, 64), ("bounded work 256/4", 256, 8)]
        {
            let s = RenderSettings { mc: McSettings { budget, paths_per_frame: 4, ..base.mc }, ..base };
            let (img, _, t) = run(ctx, &r, &s, frames, 0);
            let e = t.error_estimate().expect("estimate");
            let est = e.relative.expect("estimate ready");
            let measured = measured_relative_error(&img, &reference, &ref_moments, env);
            eprintln!("{label}, {frames} frames: estimated {est:.4}, measured {measured:.4} ({} foreground pixels, ≥ {} paths)", e.foreground_pixels, e.min_paths);
            assert!(e.min_paths >= 2 && e.foreground_pixels > 100, "{e:?}");
            if (est / measured - 1.0).abs() > 0.15 {
                bad.push(format!("{label}, {frames} frames: estimated {est}, measured {measured}"));
            }
        }
        assert!(bad.is_empty(), "{bad:?}");
    });
}

/// A 48³ slab filling a 48² orthographic view: extinction 2 everywhere except a column through
/// the central 16×16 pixels (2×2 tiles) of 0.0002, lit by the sun only (black environment),
/// single scattering: a path there sees light only if it scatters, once in about 5,000.
fn slab_with_a_thin_column(ctx: &Context) -> (VolumeRenderer, RenderSettings) {
    let n = 48u32;
    let data: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let (x, y) = (i % n, (i / n) % n);
            if (16..32).contains(&x) && (16..32).contains(&y) {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    let vol = Volume::new([n; 3], [1.0; 3], data, "slab with a thin column").expect("volume");
    let tf = TransferFunction::OneD {
        points: vec![
            TfPoint { value: 0.0, color: [1.0; 3], extinction: 0.0002 },
            TfPoint { value: 1.0, color: [1.0; 3], extinction: 2.0 },
        ],
    };
    let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
    let mc = McSettings {
        env_radiance: [0.0; 3],
        convergence: ConvergenceSettings {
            adaptive: true,
            adaptive_error: 0.3,
            adaptive_min_paths: 4,
            until_error: 0.0,
        },
        ..Default::default()
    };
    (r, RenderSettings { renderer: RendererKind::Mcs, mc, ..Default::default() })
}

/// The mean radiance of each of the 6×6 tiles of a 48² image.
fn tile_means(img: &[[f32; 4]]) -> Vec<f64> {
    let mut out = vec![0.0; 36];
    for (i, p) in img.iter().enumerate() {
        let (x, y) = (i % 48, i / 48);
        out[(y / 8) * 6 + x / 8] += f64::from(p[0] + p[1] + p[2]) / 64.0;
    }
    out
}

#[test]
fn adaptive_sampling_keeps_sampling_a_dark_tile_beside_lit_ones() {
    common::gpu_test(|ctx| {
        // The column's four tiles see no light in their first 4 paths per pixel with probability
        // about 0.95 each; the tiles around them are lit, converge (target 0.3) and stop. Were a
        // dark tile stopped at 4 paths, its mean would stay 0 for ever; kept sampling, 512 frames
        // give each about 6 scattered paths.
        let (r, s) = slab_with_a_thin_column(ctx);
        let cam = Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 1.0 });
        let mut t = Targets::new(ctx, [48, 48]).expect("targets");
        let mut dark_at_min_paths = 0;
        for f in 0..512 {
            render_frame(ctx, &r, &mut t, &cam, &s, f).expect("render");
            if f == 3 {
                let m = tile_means(&t.read_hdr(ctx).expect("hdr"));
                dark_at_min_paths = [14, 15, 20, 21].iter().filter(|&&i| m[i] == 0.0).count();
            }
        }
        let img = t.read_hdr(ctx).expect("hdr");
        let moments = t.read_moments(ctx).expect("moments");
        let e = t.error_estimate().expect("estimate");
        let means = tile_means(&img);
        let paths = |tile: usize| {
            let (tx, ty) = (tile % 6, tile / 6);
            moments[ty * 8 * 48 + tx * 8][3]
        };
        eprintln!("dark column tiles after 4 paths: {dark_at_min_paths} of 4; {e:?}");
        eprintln!("tile means {means:.4?}");
        eprintln!("paths of the column's tiles {:?}, of a corner tile {}", [14, 15, 20, 21].map(paths), paths(0));
        assert!(dark_at_min_paths > 0, "the scene does not make a dark tile (none dark after 4 paths)");
        assert!(e.stopped_tiles > 0, "adaptive sampling stopped nothing: {e:?}");
        for tile in [14, 15, 20, 21] {
            assert!(means[tile] > 0.0, "column tile {tile} stopped without having seen light ({} paths)", paths(tile));
        }
    });
}

#[test]
fn no_tile_stops_before_its_minimum_paths_and_a_stopped_tile_keeps_its_pixels() {
    common::gpu_test(|ctx| {
        let r = sphere_scene(ctx);
        for budget in [0, 128] {
            let mc = McSettings {
                budget,
                paths_per_frame: 1,
                convergence: ConvergenceSettings {
                    adaptive: true,
                    adaptive_error: 1.0,
                    adaptive_min_paths: 6,
                    until_error: 0.0,
                },
                ..Default::default()
            };
            let s = RenderSettings { renderer: RendererKind::Mcm, jitter: true, mc, ..Default::default() };
            let mut t = Targets::new(ctx, SIZE).expect("targets");
            let mut before: Option<Snapshot> = None;
            let mut stopped_halves = 0;
            for f in 0..12u64 {
                render_frame(ctx, &r, &mut t, &ortho(), &s, f).expect("render");
                let e = t.error_estimate().expect("estimate");
                let img = t.read_hdr(ctx).expect("hdr");
                let mom = t.read_moments(ctx).expect("moments");
                // With a target of 1 every tile converges as soon as it may: at 6 paths each pixel
                // (one path per frame, or one per frame at most in bounded work).
                for (i, tile) in t.tile_stats().expect("tiles").iter().enumerate() {
                    for h in 0..2 {
                        assert!(
                            !tile.stopped[h] || tile.n_min[h] >= 6,
                            "budget {budget}, frame {f}: half {h} of tile {i} stopped at {} paths",
                            tile.n_min[h]
                        );
                    }
                }
                if let Some((prev_img, prev_mom, stopped)) = before {
                    // The halves stopped after the previous frame did not change.
                    for (i, (a, b)) in prev_img.iter().zip(&img).enumerate() {
                        let (x, y) = (i % 32, i / 32);
                        if stopped[(y / 8) * 4 + x / 8][(x + y) % 2] {
                            assert!(
                                a == b && prev_mom[i] == mom[i],
                                "budget {budget}, frame {f}: stopped pixel ({x}, {y}) changed"
                            );
                        }
                    }
                }
                let halves: Vec<[bool; 2]> = t.tile_stats().expect("tiles").iter().map(|t| t.stopped).collect();
                stopped_halves = halves.iter().flatten().filter(|&&s| s).count();
                eprintln!("budget {budget}, frame {f}: {e:?}, {stopped_halves} halves stopped");
                before = Some((img, mom, halves));
            }
            assert!(stopped_halves > 0, "budget {budget}: target 1 and 12 frames stopped no half tile");
        }
    });
}

#[test]
fn adaptive_sampling_converges_to_the_unbiased_image_with_fewer_paths() {
    common::gpu_test(|ctx| {
        // 64²: the sphere covers about 40 tiles. Per tile, the red channel's summed difference
        // against an independent non-adaptive reference, over its variance from both images'
        // moments, is a χ²(1) value when the adaptive image is unbiased (channels of one path
        // are correlated, pixels are not).
        let r = sphere_scene(ctx);
        let cam = Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 1.2 });
        let size = [64, 64];
        let mean = |s: &RenderSettings, frames: u64, first: u64| {
            let mut t = Targets::new(ctx, size).expect("targets");
            for f in 0..frames {
                render_frame(ctx, &r, &mut t, &cam, s, first + f).expect("render");
            }
            (t.read_hdr(ctx).expect("hdr"), t.read_moments(ctx).expect("moments"), t)
        };
        for budget in [0, 256] {
            let base = RenderSettings {
                renderer: RendererKind::Mcm,
                jitter: true,
                mc: McSettings { budget, paths_per_frame: 2, ..Default::default() },
                ..Default::default()
            };
            let conv = ConvergenceSettings { adaptive: true, adaptive_error: 0.03, ..Default::default() };
            let adaptive = RenderSettings { mc: McSettings { convergence: conv, ..base.mc }, ..base };
            let (reference, ref_moments, _) = mean(&base, 192, 1_000_000);
            let (img, moments, t) = mean(&adaptive, 192, 0);
            let e = t.error_estimate().expect("estimate");
            let paths = |m: &[[f32; 4]]| m.iter().map(|p| f64::from(p[3])).sum::<f64>();
            let (pa, pr) = (paths(&moments), paths(&ref_moments));
            let mut chi2 = Vec::new();
            for tile in 0..64 {
                let (mut d, mut v) = (0.0f64, 0.0f64);
                for k in 0..64 {
                    let i = ((tile / 8) * 8 + k / 8) * 64 + (tile % 8) * 8 + k % 8;
                    // Background: every path returned the environment (bounded work's sum / n
                    // leaves rounding noise there, of relative size 1e-7, not a variance).
                    let m = ref_moments[i];
                    if f64::from(m[0]) <= 1e-8 * f64::from(m[3] - 1.0) * f64::from(reference[i][0]).powi(2) {
                        continue;
                    }
                    d += f64::from(img[i][0]) - f64::from(reference[i][0]);
                    v += var_of_mean(&moments[i])[0] + var_of_mean(&ref_moments[i])[0];
                }
                if v > 0.0 {
                    chi2.push(d * d / v);
                }
            }
            let mean_chi2 = chi2.iter().sum::<f64>() / chi2.len() as f64;
            eprintln!(
                "budget {budget}: χ² per tile {mean_chi2:.2} over {} tiles; paths {pa} adaptive vs {pr}; {e:?}",
                chi2.len()
            );
            assert!(chi2.len() >= 30, "too few tiles with variance");
            // The mean of k χ²(1) values: 1 ± sqrt(2/k); 4 standard errors.
            assert!(mean_chi2 <= 1.0 + 4.0 * (2.0 / chi2.len() as f64).sqrt(), "budget {budget}: χ² {mean_chi2}");
            assert!(
                e.stopped_tiles > 0 && pa < 0.9 * pr,
                "budget {budget}: adaptive sampling saved nothing ({pa} paths vs {pr})"
            );
        }
    });
}
