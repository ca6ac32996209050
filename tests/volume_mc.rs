//! Monte Carlo volume rendering against analytic answers (lavapipe, validation + sync validation):
//! transmittance estimators vs `exp(-σd)`, the white furnace, and majorant bookkeeping.

mod common;

use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{procedural, Volume};
use vkengine::volume::optics::tf::{TfBox, TfPoint, TransferFunction};
use vkengine::volume::render::mc_mode::DispatchBound;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, TransmittanceEstimator, VolumeRenderer,
};

const SIZE: [u32; 2] = [32, 32];

/// Orthographic view down -Z: the unit cube covers pixels 8..24 on both axes; every ray crosses d = 1.
fn ortho() -> Camera {
    Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 2.0 })
}

/// Per-pixel samples from `frames` independent frames (no accumulation, no jitter).
fn samples(ctx: &Context, r: &VolumeRenderer, s: &RenderSettings, frames: u64, pixels: &[(u32, u32)]) -> Vec<f32> {
    let mut out = Vec::new();
    for f in 0..frames {
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        render_frame(ctx, r, &mut t, &ortho(), s, f).expect("render");
        let img = t.read_hdr(ctx).expect("readback");
        out.extend(pixels.iter().map(|&(x, y)| img[(y * SIZE[0] + x) as usize][0]));
    }
    out
}

fn mean_se(v: &[f32]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().map(|&x| x as f64).sum::<f64>() / n;
    let var = v.iter().map(|&x| (x as f64 - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

fn block(x0: u32, x1: u32, y0: u32, y1: u32) -> Vec<(u32, u32)> {
    (y0..y1).flat_map(|y| (x0..x1).map(move |x| (x, y))).collect()
}

#[test]
fn transmittance_estimators_match_exp_minus_sigma_d() {
    common::gpu_test(|ctx| {
        // Left half (normalized value 0) has σ1, right half (value 1) σ2 > σ1: the global majorant
        // σ2 over-estimates the left half, so ratio tracking is not degenerate there.
        let n = 32u32;
        let data: Vec<f32> = (0..n * n * n).map(|i| if (i % n) < n / 2 { 0.0 } else { 1.0 }).collect();
        let vol = Volume::new([n; 3], [1.0; 3], data, "two halves").expect("volume");
        let (s1, s2) = (1.0f32, 3.0f32);
        let tf = TransferFunction::OneD {
            points: vec![
                TfPoint { value: 0.0, color: [1.0; 3], extinction: s1 },
                TfPoint { value: 1.0, color: [1.0; 3], extinction: s2 },
            ],
        };
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        assert_eq!(r.global_majorant(), [s2, s1]);
        // Rays through the left half, away from the trilinear blend at the middle.
        let px = block(9, 14, 9, 23);
        let want = (-s1 as f64).exp();
        for grid in [false, true] {
            for est in
                [TransmittanceEstimator::Delta, TransmittanceEstimator::Ratio, TransmittanceEstimator::ResidualRatio]
            {
                let mc = McSettings {
                    majorant_grid: grid,
                    transmittance: est,
                    debug_transmittance: true,
                    ..Default::default()
                };
                let s = RenderSettings { renderer: RendererKind::Mcs, mc, ..Default::default() };
                let v = samples(ctx, &r, &s, 24, &px);
                let (m, se) = mean_se(&v);
                eprintln!("grid={grid} {est:?}: T = {m:.5} ± {se:.5} (analytic {want:.5})");
                assert!((m - want).abs() <= 4.0 * se.max(1e-4), "grid={grid} {est:?}: {m} ± {se} vs {want}");
                if est == TransmittanceEstimator::ResidualRatio && !grid {
                    // Control = σ1 = the true extinction here: the estimate is exact every time.
                    assert!(se < 1e-5, "residual ratio tracking should have zero variance here, se {se}");
                }
            }
        }
        assert_eq!(r.majorant_violations(), 0);
    });
}

#[test]
fn transmittance_estimators_agree_on_a_heterogeneous_cloud() {
    common::gpu_test(|ctx| {
        // No closed form here, but every estimator is unbiased: their means must agree pixel by
        // pixel (a control above the true minimum, or a majorant below the maximum, would not).
        let vol = procedural::cloud([32; 3], 3).expect("volume");
        let tf = TransferFunction::ramp(0.05, 0.7, [1.0; 3], 12.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let px = block(12, 20, 12, 20);
        let mut means = Vec::new();
        for est in [TransmittanceEstimator::Delta, TransmittanceEstimator::Ratio, TransmittanceEstimator::ResidualRatio]
        {
            let mc = McSettings { transmittance: est, debug_transmittance: true, ..Default::default() };
            let s = RenderSettings { renderer: RendererKind::Mcs, mc, ..Default::default() };
            // Per pixel: the mean over frames; the estimators are compared pixel by pixel.
            let v = samples(ctx, &r, &s, 48, &px);
            let per_pixel: Vec<(f64, f64)> = (0..px.len())
                .map(|i| mean_se(&v.iter().skip(i).step_by(px.len()).copied().collect::<Vec<f32>>()))
                .collect();
            means.push((est, per_pixel));
        }
        let (dark, total) = (means[0].1.iter().filter(|m| m.0 < 0.9).count(), px.len());
        assert!(dark * 2 > total, "the cloud should attenuate most of these rays ({dark}/{total})");
        let (delta, others) = means.split_first().expect("three estimators");
        for (est, pp) in others {
            // Sum of squared z-scores over the pixels: chi-square with `total` degrees of freedom.
            let chi2: f64 =
                pp.iter().zip(&delta.1).map(|(a, b)| (a.0 - b.0).powi(2) / (a.1 * a.1 + b.1 * b.1).max(1e-6)).sum();
            let limit = total as f64 + 4.0 * (2.0 * total as f64).sqrt();
            eprintln!("{est:?} vs delta: chi2 {chi2:.1} over {total} pixels (limit {limit:.1})");
            assert!(chi2 < limit, "{est:?} disagrees with delta tracking: chi2 {chi2:.1} > {limit:.1}");
        }
        assert_eq!(r.majorant_violations(), 0);
    });
}

#[test]
fn white_furnace_conserves_energy_and_absorption_darkens_as_expected() {
    common::gpu_test(|ctx| {
        let vol = procedural::homogeneous_box([16, 16, 16], 1.0).expect("volume");
        let inside = block(10, 22, 10, 22);
        let sigma = 2.0;
        for (albedo, max_events) in [(1.0f32, 1000u32), (0.0, 64)] {
            let tf = TransferFunction::constant([albedo; 3], sigma);
            let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
            let mc = McSettings {
                sun_dir: None,
                env_radiance: [1.0; 3],
                max_events,
                phase: [1, 0.5f32.to_bits(), 0, 1.0f32.to_bits()],
                ..Default::default()
            };
            let s = RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() };
            let v = samples(ctx, &r, &s, 16, &inside);
            assert!(v.iter().all(|x| x.is_finite()), "non-finite radiance");
            let (m, se) = mean_se(&v);
            // Albedo 1: nothing is absorbed, every path ends in the unit environment. Albedo 0:
            // only unscattered light arrives, exp(-σ d) with d = 1.
            let want = if albedo == 1.0 { 1.0 } else { (-sigma as f64).exp() };
            eprintln!("albedo {albedo}: {m:.4} ± {se:.4} (expected {want:.4})");
            assert!((m - want).abs() <= 4.0 * se.max(1e-3), "albedo {albedo}: {m} ± {se}, expected {want}");
            assert_eq!(r.majorant_violations(), 0);
        }
    });
}

#[test]
fn single_scattering_is_dimmer_than_multiple_and_both_are_finite() {
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([24, 24, 24], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.5, [0.95; 3], 20.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let px = block(12, 20, 12, 20);
        let mut means = Vec::new();
        for kind in [RendererKind::Mcs, RendererKind::Mcm] {
            let s = RenderSettings { renderer: kind, ..Default::default() };
            let v = samples(ctx, &r, &s, 8, &px);
            assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0));
            means.push(mean_se(&v));
        }
        let ((ms, ses), (mm, sem)) = (means[0], means[1]);
        assert!(mm - ms > 4.0 * (ses * ses + sem * sem).sqrt(), "MCM {mm} should exceed MCS {ms}");
    });
}

#[test]
fn stress_density_scales_and_degenerate_volumes_stay_finite() {
    common::gpu_test(|ctx| {
        let tf = TransferFunction::ramp(0.0, 0.5, [0.9; 3], 5.0);
        let mut cases: Vec<(String, Volume, f32)> = Vec::new();
        let sphere = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        for scale in [1e-6f32, 1e-3, 1.0, 1e3, 1e6] {
            cases.push((format!("density x{scale}"), sphere.clone(), scale));
        }
        cases.push(("single voxel".into(), Volume::new([1, 1, 1], [1.0; 3], vec![1.0], "1 voxel").expect("v"), 1.0));
        let column: Vec<f32> = (0..4096).map(|i| (i % 7) as f32 / 6.0).collect();
        cases.push(("1x1x4096".into(), Volume::new([1, 1, 4096], [1.0; 3], column, "column").expect("v"), 1.0));
        let mut nan = vec![0.5f32; 8 * 8 * 8];
        nan[100] = f32::NAN;
        let v = Volume::new([8, 8, 8], [1.0; 3], nan, "nan voxel").expect("NaN is sanitized, not fatal");
        assert!(!v.warnings.is_empty(), "NaN sanitizing must warn");
        cases.push(("NaN voxel".into(), v, 1.0));
        for (name, vol, scale) in &cases {
            let r = VolumeRenderer::new(ctx, vol, &tf).expect("renderer");
            for kind in [RendererKind::Mcs, RendererKind::Mcm] {
                // One path per frame at ×1e3 and up would need millions of tracking steps per
                // pixel: on llvmpipe rows would be cut short (a "finite" image would prove
                // nothing), on a GPU one dispatch would run for seconds to minutes. mc_budget=0
                // is refused there, and auto (the default) renders them with bounded work.
                let s = RenderSettings {
                    renderer: kind,
                    mc: McSettings { density_scale: *scale, max_events: 32, ..Default::default() },
                    ..Default::default()
                };
                let classic = RenderSettings { mc: McSettings { budget: 0, ..s.mc }, ..s };
                let dense = *scale >= 1e3;
                let bound = DispatchBound::of_device(&ctx.info.name);
                let resolved = r.resolve_mc(bound, &s, [16, 16]).expect("auto always resolves");
                // ×1e3 fits a GPU's 100 ms at 16² pixels; ×1e6 fits no device.
                let must_bound = *scale >= 1e6 || (dense && bound == DispatchBound::LoopLimit);
                assert!(!must_bound || resolved.mc_bounded(), "{name} {kind:?}: auto kept one whole path");
                assert!(dense || !resolved.mc_bounded(), "{name} {kind:?}: auto bounded a light medium");
                if must_bound {
                    let e = r.resolve_mc(bound, &classic, [16, 16]).expect_err("mc_budget=0 must be refused");
                    assert!(e.to_string().contains("mc_budget=0"), "{name} {kind:?}: {e}");
                }
                // The column is ±1/8192 wide around the axis the camera looks down: only an odd
                // size puts a pixel centre on it (the middle one of 17 sits at exactly 0).
                let column = name == "1x1x4096";
                let size = if column { COLUMN_SIZE } else { [16, 16] };
                let frames = if column { 8 } else { 1 };
                let mut hit = 0;
                for frame in 0..frames {
                    let mut t = Targets::new(ctx, size).expect("targets");
                    render_frame(ctx, &r, &mut t, &ortho(), &s, frame).expect("render");
                    let img = t.read_hdr(ctx).expect("readback");
                    assert!(
                        img.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)),
                        "{name} {kind:?}: non-finite or negative radiance"
                    );
                    if column {
                        hit += column_hits(&img, size, &format!("{kind:?} frame {frame}"));
                    }
                }
                // Optical depth ≈ 3 along the column: a ray that never collides in 8 frames
                // (e^-24) means it never entered the column.
                assert!(!column || hit > 0, "{name} {kind:?}: the centre ray never met the column");
            }
            assert_eq!(r.majorant_violations(), 0, "{name}");
        }
    });
}

/// The column case's image size (odd, so the centre pixel's ray runs down the column's axis).
const COLUMN_SIZE: [u32; 2] = [17, 17];

/// Checks a frame of the 1×1×4096 column seen end-on: every pixel but the centre misses the
/// volume's bounds and shows the environment exactly (the orthographic rays all look the same
/// way, so that is one value); returns 1 if the centre pixel differs from it (its ray collided).
fn column_hits(img: &[[f32; 4]], size: [u32; 2], what: &str) -> u32 {
    let centre = ((size[1] / 2) * size[0] + size[0] / 2) as usize;
    let env = img[0];
    for (i, p) in img.iter().enumerate() {
        if i != centre {
            assert_eq!(p[..3], env[..3], "{what}: pixel {i} misses the column but is not the environment");
        }
    }
    u32::from(img[centre][..3] != env[..3])
}

/// Accumulates `frames` frames (seeds starting at `seed0`), reading the mean back after each
/// power-of-two count.
fn accumulate_curve(
    ctx: &Context,
    r: &VolumeRenderer,
    s: &RenderSettings,
    frames: u64,
    seed0: u64,
) -> Vec<Vec<[f32; 4]>> {
    let mut t = Targets::new(ctx, [16, 16]).expect("targets");
    let mut out = Vec::new();
    for f in 0..frames {
        render_frame(ctx, r, &mut t, &ortho(), s, seed0 + f).expect("render");
        if (f + 1).is_power_of_two() {
            out.push(t.read_hdr(ctx).expect("readback"));
        }
    }
    out
}

#[test]
fn error_falls_as_inverse_square_root_of_samples() {
    common::gpu_test(|ctx| {
        // Two independent accumulations differ by RMSE ∝ sqrt(2σ²/n): slope -1/2 in log-log,
        // without the bias a finite reference would add.
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.6, [0.9; 3], 8.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let s = RenderSettings { renderer: RendererKind::Mcs, ..Default::default() };
        let a = accumulate_curve(ctx, &r, &s, 64, 0);
        let b = accumulate_curve(ctx, &r, &s, 64, 1_000_000);
        let points: Vec<(f64, f64)> = a
            .iter()
            .zip(&b)
            .enumerate()
            .map(|(i, (x, y))| (2f64.powi(i as i32), vkengine::metrics::compare(x, y).expect("same size").rmse))
            .collect();
        let slope = vkengine::plot::loglog_slope(&points);
        eprintln!("RMSE(A_n, B_n): {points:?}, slope {slope:.3}");
        assert!((-0.55..=-0.45).contains(&slope), "fitted slope {slope} outside [-0.55, -0.45]");
    });
}

#[test]
fn majorant_grid_and_global_majorant_agree_statistically() {
    common::gpu_test(|ctx| {
        let vol = procedural::cloud([32, 32, 32], 3).expect("volume");
        let tf = TransferFunction::preset("cloud").expect("preset");
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let frames = 32;
        let mut images = Vec::new();
        for (grid, seed) in [(true, 0u64), (false, 1_000_000)] {
            let mc = McSettings { majorant_grid: grid, density_scale: 6.0, ..Default::default() };
            let s = RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() };
            images.push(accumulate_curve(ctx, &r, &s, frames, seed).pop().expect("final image"));
        }
        // Per-pixel differences of two independent unbiased estimates have mean zero.
        let d: Vec<f32> =
            images[0].iter().zip(&images[1]).flat_map(|(a, b)| (0..3).map(move |c| a[c] - b[c])).collect();
        let (m, se) = mean_se(&d);
        eprintln!("grid - global: mean difference {m:.5} ± {se:.5}");
        assert!(m.abs() <= 4.0 * se.max(1e-6), "majorant modes disagree: {m} ± {se}");
        assert!(images[0].iter().any(|p| p[0] > 0.05), "image is empty");
        assert_eq!(r.majorant_violations(), 0);
    });
}

#[test]
fn point_light_follows_inverse_square() {
    common::gpu_test(|ctx| {
        // The point light's NEE term: moving the light from 4 to 8 units away along the same
        // line leaves every attenuation path the same and scales the single-scattered radiance
        // by the mean of 1/d²: about 4.05 for the unit cube (exactly 4 for a point-like medium).
        let vol = procedural::homogeneous_box([8, 8, 8], 1.0).expect("volume");
        let tf = TransferFunction::constant([1.0; 3], 0.5);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let px = block(14, 18, 14, 18);
        let mut means = Vec::new();
        for dist in [4.0f32, 8.0] {
            let mc = McSettings {
                sun_dir: None,
                env_radiance: [0.0; 3],
                point_light: Some(([dist, 0.0, 0.0], [100.0; 3])),
                phase: vkengine::volume::optics::phase::PhaseFunction::Isotropic.to_gpu(),
                ..Default::default()
            };
            let s = RenderSettings { renderer: RendererKind::Mcs, mc, ..Default::default() };
            means.push(mean_se(&samples(ctx, &r, &s, 64, &px)));
        }
        let ((m4, se4), (m8, se8)) = (means[0], means[1]);
        let ratio = m4 / m8;
        let se = ratio * ((se4 / m4).powi(2) + (se8 / m8).powi(2)).sqrt();
        eprintln!("point light at 4 vs 8: {m4:.5} / {m8:.5} = {ratio:.3} ± {se:.3}");
        // Both runs use the same random streams (same scatter points), so the ratio is far more
        // precise than the independent-sample error printed above suggests.
        assert!(m8 > 0.0 && (3.7..=4.4).contains(&ratio), "inverse-square ratio {ratio} ± {se}");
    });
}

#[test]
fn too_small_majorants_are_counted_as_violations() {
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.6, [0.9; 3], 8.0);
        for (grid, scale, expect_violations) in [(true, 1.0f32, false), (true, 0.5, true), (false, 0.5, true)] {
            let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
            let mc = McSettings { majorant_grid: grid, majorant_scale: scale, ..Default::default() };
            let s = RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() };
            let mut t = Targets::new(ctx, [16, 16]).expect("targets");
            render_frame(ctx, &r, &mut t, &ortho(), &s, 0).expect("render");
            let v = r.majorant_violations();
            assert_eq!(v > 0, expect_violations, "grid={grid} scale={scale}: {v} violations");
        }
    });
}

#[test]
fn the_majorant_grid_bounds_a_volume_whose_size_is_no_multiple_of_its_block() {
    common::gpu_test(|ctx| {
        // 37 × 45 × 29 voxels: the last cell on each axis is a partial 8-voxel block. Both the
        // one-path-per-frame and the bounded-work tracker must find every sample under its cell's
        // majorant (a cell-count mapping shifted the cells off their blocks: hundreds of
        // violations per frame).
        let vol = procedural::smooth_sphere([37, 45, 29], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.6, [0.9; 3], 8.0);
        for budget in [0, 256] {
            let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
            let mc = McSettings { budget, ..Default::default() };
            let s = RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() };
            let mut t = Targets::new(ctx, [24, 24]).expect("targets");
            for f in 0..2 {
                render_frame(ctx, &r, &mut t, &ortho(), &s, f).expect("render");
            }
            assert_eq!(r.majorant_violations(), 0, "mc_budget={budget}");
        }
    });
}

#[test]
fn the_monte_carlo_pass_reports_the_fetches_it_made() {
    common::gpu_test(|ctx| {
        // Uniform σ = 2 with the global majorant m = σ: delta tracking along each camera ray
        // (d = 1) stops at its first tentative collision, so a ray makes one medium lookup with
        // probability 1 - e^{-2} and none otherwise. A lookup is two filtered fetches (volume,
        // transfer function) with a 1D transfer function, three when the function depends on the
        // gradient magnitude (its table's rows differ) — here σ wherever |∇v| ≤ 0.5, which in the
        // uniform volume is everywhere, so the same physics.
        let n = 8u32;
        let vol = Volume::new([n; 3], [1.0; 3], vec![0.5; (n * n * n) as usize], "uniform").expect("volume");
        let sigma = 2.0f32;
        let one_d = TransferFunction::OneD {
            points: vec![
                TfPoint { value: 0.0, color: [1.0; 3], extinction: sigma },
                TfPoint { value: 1.0, color: [1.0; 3], extinction: sigma },
            ],
        };
        let two_d = TransferFunction::TwoD {
            boxes: vec![TfBox { value: [0.0, 1.0], gradient: [0.0, 0.5], color: [1.0; 3], extinction: sigma }],
        };
        for (tf, per_lookup) in [(one_d, 2.0), (two_d, 3.0)] {
            let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
            let mc = McSettings {
                majorant_grid: false,
                transmittance: TransmittanceEstimator::Delta,
                debug_transmittance: true,
                ..Default::default()
            };
            let s = RenderSettings { renderer: RendererKind::Mcs, mc, ..Default::default() };
            let frames = 8u64;
            let mut total = 0u64;
            for f in 0..frames {
                let mut t = Targets::new(ctx, SIZE).expect("targets");
                let run = render_frame(ctx, &r, &mut t, &ortho(), &s, f).expect("render");
                let pass = run.timings.iter().find(|p| p.name == "mcs").expect("mcs pass");
                assert!(pass.work.declared);
                total += pass.work.texel_fetches;
            }
            // 16×16 pixels see the cube.
            let rays = (256 * frames) as f64;
            let p = 1.0 - (-sigma as f64).exp();
            let (mean, sd) = (per_lookup * rays * p, per_lookup * (rays * p * (1.0 - p)).sqrt());
            eprintln!("{per_lookup} fetches per lookup: {total}, expected {mean:.0} ± {sd:.0}");
            assert!((total as f64 - mean).abs() <= 4.0 * sd, "{total} fetches, expected {mean:.0} ± {sd:.0}");
        }
    });
}

/// The shader's ratio-tracking weight, as a device may contract it: `fma(−(σ − c), rcp(M − c), 1)`
/// (NVIDIA's division is a reciprocal and a multiply, and the compiler fuses the subtraction).
fn textbook_weight_fused(sigma: f32, c: f32, majorant: f32) -> f32 {
    (-(sigma - c)).mul_add(1.0 / (majorant - c), 1.0)
}

/// `tracking.glsl`'s `ratio_weight`, under the same reciprocal arithmetic.
fn shader_weight_fused(sigma: f32, c: f32, majorant: f32) -> f32 {
    (majorant - sigma).max(0.0) * (1.0 / (majorant - c))
}

#[test]
fn the_ratio_weight_cannot_go_negative_under_fused_reciprocal_arithmetic() {
    // A CPU model of the H200's negative pixels (no GPU needed): in a homogeneous medium every
    // tentative collision has σ = M, the weight is 0 in exact arithmetic, and the textbook form
    // evaluated with a reciprocal and an FMA is −ulp for about half of all σ (σ = 3: −3.0e-8), so a
    // product of weights, and the pixel, goes negative. The shader's form is ≥ 0 for every σ ≤ M
    // and 0 above M, whatever the rounding.
    let sigmas = (1..20_000).map(|i| i as f32 * 0.05);
    let mut textbook_negative = 0;
    for s in sigmas {
        for (c, m) in [(0.0, s), (0.25 * s, s), (0.0, s * 1.5), (0.0, s * (1.0 - f32::EPSILON))] {
            let w = shader_weight_fused(s, c, m);
            assert!(w.is_finite() && w >= 0.0, "σ={s} c={c} M={m}: weight {w}");
            if m == s {
                assert_eq!(w, 0.0, "σ = M must weigh exactly 0");
            }
            if textbook_weight_fused(s, c, m) < 0.0 && s <= m {
                textbook_negative += 1;
            }
        }
    }
    // The model reproduces the failure it guards against (the H200 saw −1e-9 … −2e-8 pixels).
    assert!(textbook_negative > 1000, "the textbook form went negative only {textbook_negative} times");
}

#[test]
fn every_estimator_stays_finite_and_non_negative_where_the_density_exceeds_its_majorant() {
    // majorant_scale 0.5 makes half of the cloud's densities exceed their (grid or global)
    // majorant, as an inexact filter could on a GPU: ratio tracking's textbook weight 1 − σ/M
    // turns negative there (down to −1), and so do transmittance estimates and pixels. Every
    // estimator, in both MC shaders, must still return finite, non-negative radiance, and count
    // the violations it met.
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.6, [0.9; 3], 8.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        for grid in [true, false] {
            for est in [TransmittanceEstimator::Ratio, TransmittanceEstimator::ResidualRatio] {
                for (kind, debug, budget, flight) in [
                    (RendererKind::Mcs, true, 0, false),
                    (RendererKind::Mcs, false, 0, false),
                    (RendererKind::Mcm, false, 0, false),
                    (RendererKind::Mcm, false, 0, true),
                    (RendererKind::Mcm, false, 64, false),
                    (RendererKind::Mcm, false, 64, true),
                ] {
                    let mc = McSettings {
                        majorant_grid: grid,
                        majorant_scale: 0.5,
                        transmittance: est,
                        debug_transmittance: debug,
                        budget,
                        env_flight: flight,
                        ..Default::default()
                    };
                    let s = RenderSettings { renderer: kind, mc, ..Default::default() };
                    let what =
                        format!("grid={grid} {est:?} {kind:?} test_mode={debug} budget={budget} flight={flight}");
                    let mut t = Targets::new(ctx, SIZE).expect("targets");
                    for frame in 0..4 {
                        render_frame(ctx, &r, &mut t, &ortho(), &s, frame).expect("render");
                        let img = t.read_hdr(ctx).expect("readback");
                        let bad = img.iter().flatten().filter(|c| !c.is_finite() || **c < 0.0).count();
                        assert_eq!(bad, 0, "{what} frame {frame}: {bad} negative or non-finite values");
                        if debug {
                            assert!(img.iter().all(|p| p[0] <= 1.0), "{what}: a transmittance above 1");
                        }
                    }
                }
            }
        }
        assert!(r.majorant_violations() > 0, "the test must run above the majorant");
    });
}
