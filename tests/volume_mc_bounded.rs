//! Bounded-work Monte Carlo (`mc_budget` > 0, `mc_bounded.comp`: persistent paths, a fixed
//! number of tracking steps and events per pixel and frame) against analytic answers and against
//! the one-path-per-frame estimator (`mc.comp`), on lavapipe with validation.

mod common;

use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{procedural, Volume};
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::mc_mode::{DispatchBound, AUTO_BUDGET, GPU_STEPS_PER_S};
use vkengine::volume::render::renderer::{
    mc_loop_iterations, render_frame, McSettings, RenderSettings, RendererKind, Targets, TransmittanceEstimator,
    VolumeRenderer, LOOP_LIMIT,
};
use vkengine::volume::render::settings::BUDGET_AUTO;

const SIZE: [u32; 2] = [32, 32];

/// Orthographic view down -Z: the unit cube covers pixels 8..24 on both axes; every ray crosses d = 1.
fn ortho() -> Camera {
    Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 2.0 })
}

/// The image after `frames` frames accumulated in one set of targets (the progressive mean).
fn render(ctx: &Context, vol: &Volume, tf: &TransferFunction, s: &RenderSettings, frames: u64) -> Vec<[f32; 4]> {
    let r = VolumeRenderer::new(ctx, vol, tf).expect("renderer");
    let mut t = Targets::new(ctx, SIZE).expect("targets");
    for f in 0..frames {
        render_frame(ctx, &r, &mut t, &ortho(), s, f).expect("render");
    }
    assert_eq!(r.majorant_violations(), 0);
    t.read_hdr(ctx).expect("readback")
}

fn inside() -> impl Iterator<Item = usize> {
    (10..22).flat_map(|y| (10..22).map(move |x| (y * SIZE[0] + x) as usize))
}

/// Mean and standard error over the block's pixels (each pixel's mean is independent).
fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Asserts that two images of the same expectation agree inside the box: per channel, the mean
/// per-pixel difference (the image itself cancels, what is left is noise around 0) within 4 SE
/// and 2 % of the level, on a channel bright enough to compare.
fn assert_same_image(a: &[[f32; 4]], b: &[[f32; 4]], what: &str) {
    for ch in 0..3 {
        let d: Vec<f64> = inside().map(|i| f64::from(a[i][ch]) - f64::from(b[i][ch])).collect();
        let (m, se) = mean_se(&d);
        let level = inside().map(|i| f64::from(a[i][ch])).sum::<f64>() / d.len() as f64;
        eprintln!("{what}, channel {ch}: mean {level:.4}, difference {m:.5} ± {se:.5}");
        assert!(level > 0.05, "{what}: too dark to compare: {level}");
        assert!(m.abs() <= 4.0 * se && m.abs() <= 0.02 * level, "{what}, channel {ch}: {m} ± {se} of {level}");
    }
}

fn mc(budget: u32, max_events: u32) -> McSettings {
    McSettings {
        sun_dir: None,
        env_radiance: [1.0; 3],
        max_events,
        phase: [1, 0.5f32.to_bits(), 0, 1.0f32.to_bits()],
        budget,
        ..Default::default()
    }
}

#[test]
fn bounded_work_passes_the_furnace_and_the_absorption_answer() {
    common::gpu_test(|ctx| {
        let vol = procedural::homogeneous_box([16, 16, 16], 1.0).expect("volume");
        let sigma = 2.0f32;
        // Albedo 1: every path ends in the unit environment (exactly 1, whatever its length;
        // paths longer than a frame's budget continue in the next). Albedo 0: only unscattered
        // light arrives, exp(-σ d) with d = 1.
        for (albedo, max_events) in [(1.0f32, 1000u32), (0.0, 64)] {
            let tf = TransferFunction::constant([albedo; 3], sigma);
            let s = RenderSettings { renderer: RendererKind::Mcm, mc: mc(64, max_events), ..Default::default() };
            let img = render(ctx, &vol, &tf, &s, 12);
            let v: Vec<f64> = inside().map(|i| f64::from(img[i][0])).collect();
            assert!(v.iter().all(|x| x.is_finite()), "non-finite radiance");
            let (m, se) = mean_se(&v);
            let want = if albedo == 1.0 { 1.0 } else { f64::from(-sigma).exp() };
            eprintln!("albedo {albedo}: {m:.4} ± {se:.4} (expected {want:.4})");
            assert!((m - want).abs() <= 4.0 * se.max(1e-3), "albedo {albedo}: {m} ± {se}, expected {want}");
        }
    });
}

#[test]
fn bounded_work_converges_to_the_one_path_per_frame_image() {
    common::gpu_test(|ctx| {
        // A heterogeneous cloud lit by the sun and the environment: NEE of both, MIS, roulette.
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.5, [0.9, 0.7, 0.5], 6.0);
        let base = McSettings { sun_dir: Some([0.4, 0.8, 0.45]), ..mc(0, 16) };
        let one = RenderSettings { renderer: RendererKind::Mcm, mc: base, ..Default::default() };
        let bounded = RenderSettings { mc: McSettings { budget: 96, ..base }, ..one };
        let a = render(ctx, &vol, &tf, &one, 48);
        let b = render(ctx, &vol, &tf, &bounded, 48);
        assert_same_image(&a, &b, "bounded vs one path");
        // Outside the box both see the environment only.
        for i in [0usize, 31, 32 * 31] {
            assert_eq!(a[i][0], 1.0);
            assert_eq!(b[i][0], 1.0);
        }
    });
}

#[test]
fn a_dense_absorber_is_black_with_bounded_work() {
    common::gpu_test(|ctx| {
        // ×1e6 extinction with an albedo-0 smooth sphere: the path tracer takes millions of null
        // collisions to cross the sparse border cells, where the one-path-per-frame shader runs
        // into llvmpipe's 65,535-iteration loop limit and its rays "escape" (the trust issue). In
        // bounded work no dispatch exceeds its budget: paths take as many frames as they need.
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.5, [0.0; 3], 5.0);
        let s = RenderSettings {
            renderer: RendererKind::Mcm,
            mc: McSettings { density_scale: 1e6, ..mc(2048, 8) },
            ..Default::default()
        };
        let img = render(ctx, &vol, &tf, &s, 2);
        assert!(img.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)), "non-finite or negative");
        // The rays through the sphere's middle cross its core: absorbed (exp(-1e6·…) = 0), or
        // still in flight, which the mean of no completed path also shows as 0.
        for y in 14..18 {
            for x in 14..18 {
                let p = img[(y * SIZE[0] + x) as usize];
                assert!(p[0] < 1e-6, "pixel ({x}, {y}) of the absorber is {p:?}, not black");
            }
        }
        assert_eq!(img[0][0], 1.0, "the environment outside the box");
    });
}

#[test]
fn the_budget_keeps_every_row_under_llvmpipes_loop_limit() {
    // The largest setting without an environment map stays under the limit…
    assert!(mc_loop_iterations(6000, None) <= LOOP_LIMIT);
    // …and a map's binary searches lower it: 2048 × 1024 adds 13 + 12 iterations per event.
    assert_eq!(mc_loop_iterations(1, Some([2048, 1024])), 10 + 13 + 12 + 1);
    assert!(mc_loop_iterations(6000, Some([2048, 1024])) > LOOP_LIMIT);
}

#[test]
fn the_paths_cap_is_a_rows_and_no_pixel_takes_more_than_four_times_it() {
    common::gpu_test(|ctx| {
        // Every ray crosses the cloud (the view is inside the box), so every lane counts toward
        // its row's cap, and paths differ in length from pixel to pixel.
        let cam = Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 0.8 });
        let vol = procedural::cloud([32; 3], 3).expect("volume");
        let tf = TransferFunction::ramp(0.05, 0.5, [0.9, 0.85, 0.8], 10.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let cap = 2u32;
        let s = RenderSettings {
            renderer: RendererKind::Mcm,
            mc: McSettings { paths_per_frame: cap, ..mc(4096, 8) },
            ..Default::default()
        };
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        render_frame(ctx, &r, &mut t, &cam, &s, 0).expect("render");
        let counts: Vec<u32> = t.read_moments(ctx).expect("moments").iter().map(|m| m[3] as u32).collect();
        let (max, total) = (counts.iter().copied().max().unwrap_or(0), counts.iter().sum::<u32>());
        let above = counts.iter().filter(|&&n| n > cap).count();
        eprintln!(
            "paths per pixel: at most {max}, {above} pixels above the cap {cap}, mean {:.2}",
            f64::from(total) / counts.len() as f64
        );
        assert!(max <= 4 * cap, "a pixel completed {max} paths, more than 4 × {cap}");
        // A row stops only once its pixels completed its caps' sum (4,096 steps never run out here).
        assert!(
            total >= cap * counts.len() as u32,
            "{total} paths in {} pixels: a row stopped short of its cap",
            counts.len()
        );
        // Pixels whose paths were short took their neighbours' share: a per-pixel cap would not.
        assert!(above * 10 >= counts.len(), "only {above} pixels above the cap: the cap is not the row's");
        assert_eq!(r.majorant_violations(), 0);
    });
}

#[test]
fn changing_the_budget_keeps_the_mean_and_turning_bounded_work_off_restarts_it() {
    common::gpu_test(|ctx| {
        let vol = procedural::homogeneous_box([8, 8, 8], 1.0).expect("volume");
        let tf = TransferFunction::constant([0.5; 3], 2.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let mut t = Targets::new(ctx, [16, 16]).expect("targets");
        let at = |budget, paths| RenderSettings {
            renderer: RendererKind::Mcm,
            mc: McSettings { paths_per_frame: paths, ..mc(budget, 8) },
            ..Default::default()
        };
        render_frame(ctx, &r, &mut t, &ortho(), &at(64, 4), 0).expect("render");
        render_frame(ctx, &r, &mut t, &ortho(), &at(256, 2), 1).expect("render");
        assert_eq!(t.samples, 2, "a new budget restarted the mean");
        render_frame(ctx, &r, &mut t, &ortho(), &at(0, 2), 2).expect("render");
        assert_eq!(t.samples, 1, "switching to one path per frame must restart the mean");
    });
}

#[test]
fn the_frame_time_target_steers_the_budget_proportionally_within_limits() {
    let mc = McSettings { frame_ms: 66.0, ..mc(64, 8) };
    assert_eq!(mc.steer_budget(64, 33.0), 128, "half the target: double");
    assert_eq!(mc.steer_budget(64, 132.0), 32, "twice the target: half");
    assert_eq!(mc.steer_budget(64, 1000.0), 32, "at most halving per frame");
    assert_eq!(mc.steer_budget(64, 60.0) % 8, 0, "steps of 8, as the setting");
    assert_eq!(mc.steer_budget(8, 1000.0), 8, "never below 8");
    assert_eq!(mc.steer_budget(6000, 1.0), 6000, "never above the loop-limit cap");
    assert_eq!(McSettings { frame_ms: 0.0, ..mc }.steer_budget(64, 10.0), 64, "no target: fixed");
    assert_eq!(mc.steer_budget(64, 0.0), 64, "no measurement yet: unchanged");
}

#[test]
fn the_view_ray_estimate_keeps_the_image_and_removes_the_coin_flip() {
    common::gpu_test(|ctx| {
        // vpt's kind of scene: red albedo, a white environment, no sun. Green and blue are then
        // only the environment seen through the medium, T·L along the camera ray: a coin flip per
        // path when counted at escape, a continuous estimate with the view-ray estimate. Residual
        // ratio tracking, whose estimate is continuous even where the cell is homogeneous.
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.5, [1.0, 0.0, 0.0], 6.0);
        // Bounded work's image is the mean of completed paths, biased by O(1/N): with the view
        // estimate a short (unscattered) path's red is T < 1, so the paths that complete first
        // read darker (48 frames: 3.4 SE; 192: 2.6). It gets twice the frames of mc.comp.
        for (budget, frames) in [(0u32, 48u64), (96, 96)] {
            let base = McSettings { transmittance: TransmittanceEstimator::ResidualRatio, ..mc(budget, 8) };
            let run = |view_estimate: bool, seed: u32| {
                let s = RenderSettings {
                    renderer: RendererKind::Mcm,
                    mc: McSettings { view_estimate, seed, ..base },
                    ..Default::default()
                };
                render(ctx, &vol, &tf, &s, frames)
            };
            let (escape, escape2) = (run(false, 0), run(false, 1));
            let (estimate, estimate2) = (run(true, 0), run(true, 1));
            assert_same_image(&escape, &estimate, &format!("budget {budget}, escape vs view-ray estimate"));
            // The noise of green (albedo 0): two seeds' images differ by √2 σ/√frames per pixel.
            let noise = |a: &[[f32; 4]], b: &[[f32; 4]]| {
                let n = inside().count() as f64;
                (inside().map(|i| (f64::from(a[i][1]) - f64::from(b[i][1])).powi(2)).sum::<f64>() / n).sqrt()
            };
            let (ne, nv) = (noise(&escape, &escape2), noise(&estimate, &estimate2));
            eprintln!("budget {budget}: green noise {ne:.5} counted at escape, {nv:.5} estimated");
            assert!(nv * 1.5 < ne, "budget {budget}: the view-ray estimate did not cut green's noise: {nv} vs {ne}");
        }
    });
}

#[test]
fn the_next_flight_environment_passes_the_furnace_and_keeps_the_image() {
    common::gpu_test(|ctx| {
        for budget in [0u32, 96] {
            // Analytic: albedo 1 in a unit environment is exactly 1 (every path ends in it); albedo
            // 0 is only the camera ray's transmittance, exp(-σ d) with d = 1. The flight's estimate
            // is the whole environment term: counting the escape as well would give 2 at albedo 1.
            let vol = procedural::homogeneous_box([16, 16, 16], 1.0).expect("volume");
            let sigma = 2.0f32;
            for (albedo, max_events) in [(1.0f32, 1000u32), (0.0, 64)] {
                let tf = TransferFunction::constant([albedo; 3], sigma);
                let m = McSettings {
                    env_flight: true,
                    transmittance: TransmittanceEstimator::ResidualRatio,
                    ..mc(budget, max_events)
                };
                let s = RenderSettings { renderer: RendererKind::Mcm, mc: m, ..Default::default() };
                let img = render(ctx, &vol, &tf, &s, 12);
                let v: Vec<f64> = inside().map(|i| f64::from(img[i][0])).collect();
                assert!(v.iter().all(|x| x.is_finite()), "non-finite radiance");
                let (m, se) = mean_se(&v);
                let want = if albedo == 1.0 { 1.0 } else { f64::from(-sigma).exp() };
                eprintln!("budget {budget}, albedo {albedo}: {m:.4} ± {se:.4} (expected {want:.4})");
                assert!(
                    (m - want).abs() <= 4.0 * se.max(1e-3),
                    "budget {budget}, albedo {albedo}: {m} ± {se}, expected {want}"
                );
            }
            // Heterogeneous, vpt's kind of scene (red albedo, white environment, 8 events): the same
            // image as NEE of the environment, per pixel within noise (a consistency check).
            let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
            let tf = TransferFunction::ramp(0.0, 0.5, [1.0, 0.0, 0.0], 6.0);
            let frames = if budget == 0 { 48 } else { 96 };
            let run = |env_flight: bool| {
                let m =
                    McSettings { env_flight, transmittance: TransmittanceEstimator::ResidualRatio, ..mc(budget, 8) };
                render(
                    ctx,
                    &vol,
                    &tf,
                    &RenderSettings { renderer: RendererKind::Mcm, mc: m, ..Default::default() },
                    frames,
                )
            };
            let (nee, flight) = (run(false), run(true));
            assert_same_image(&nee, &flight, &format!("budget {budget}, NEE vs next flight"));
        }
    });
}

#[test]
fn interleaving_advances_one_subset_of_tiles_a_frame_and_keeps_each_pixels_paths() {
    common::gpu_test(|ctx| {
        // Sun, environment, scattering: every event kind. 32² is 4 × 4 tiles of 8²; 3 subsets do
        // not divide a row of 4 tiles, so rows end in part-filled groups.
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.5, [0.9, 0.7, 0.5], 6.0);
        let at = |k| RenderSettings {
            renderer: RendererKind::Mcm,
            mc: McSettings { sun_dir: Some([0.4, 0.8, 0.45]), interleave: k, ..mc(64, 16) },
            ..Default::default()
        };
        // The first frame advances every tile (by a third of the budget, rounded up to 8: 24
        // steps); the second only those of subset 0, the tiles (x, y) with (x + 2y) mod 3 = 0. The
        // others keep their pixels exactly.
        let first = render(ctx, &vol, &tf, &at(3), 1);
        let second = render(ctx, &vol, &tf, &at(3), 2);
        let mut advanced = [0usize; 2];
        for (i, (a, b)) in first.iter().zip(&second).enumerate() {
            let (x, y) = (i as u32 % SIZE[0], i as u32 / SIZE[0]);
            let subset0 = (x / 8 + 2 * (y / 8)) % 3 == 0;
            if !subset0 {
                assert_eq!(a, b, "pixel ({x}, {y}) is not in this frame's subset but changed");
            }
            advanced[usize::from(subset0)] += usize::from(a != b);
        }
        assert!(advanced[1] > 40, "subset 0's tiles barely changed: {advanced:?}");
        assert_eq!(at(3).mc.first_budget(), 24);
        // Each pixel's path state goes on where it stopped, so after every pixel has been
        // advanced twice more the image is the one of three plain frames of the same budgets
        // (24, 64, 64: a budget change keeps the mean), bit for bit.
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        for (f, budget) in [24, 64, 64].into_iter().enumerate() {
            let s = RenderSettings { mc: McSettings { budget, ..at(1).mc }, ..at(1) };
            render_frame(ctx, &r, &mut t, &ortho(), &s, f as u64).expect("render");
        }
        let plain = t.read_hdr(ctx).expect("readback");
        let interleaved = render(ctx, &vol, &tf, &at(3), 1 + 2 * 3);
        assert!(plain == interleaved, "interleaved frames changed the paths");
    });
}

#[test]
fn a_sphere_at_density_1e6_renders_opaque_with_the_default_budget_on_every_device() {
    // The case: a smooth sphere at density ×1e6 (optical depth ~1e6 across it) with the
    // majorant grid. One whole path per frame needs millions of tracking steps a pixel (a cell
    // on the sphere's fringe has the core's majorant and almost no density: ~1e6 null collisions
    // to cross it): on an H200 one such frame ran 73 s; on llvmpipe the loops were cut and the
    // sphere came out fully transparent (the environment, 1.0) beside a warning.
    // mc_budget=auto (the default) must pick bounded work on every device, and every pixel that
    // shows anything must show an opaque sphere: the centre, where paths take those millions of
    // steps over thousands of frames, is 0 (no path completed yet) or the light its surface
    // scatters (albedo 0.5: far below the environment seen through it). A homogeneous block at
    // the same density, where paths end in a few steps, completes its paths in the first frames
    // and shows that scattered light (> 0, < 0.5).
    common::gpu_test(|ctx| {
        let sphere = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let block = procedural::homogeneous_box([16, 16, 16], 1.0).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.5, [0.5; 3], 5.0);
        let s = RenderSettings {
            renderer: RendererKind::Mcm,
            mc: McSettings { density_scale: 1e6, sun_dir: Some([0.3, 0.5, 1.0]), ..mc(BUDGET_AUTO, 64) },
            ..Default::default()
        };
        let r = VolumeRenderer::new(ctx, &sphere, &tf).expect("renderer");
        let resolved = r.resolve_mc(DispatchBound::of_device(&ctx.info.name), &s, SIZE).expect("resolve");
        assert!(resolved.mc_bounded(), "auto kept one whole path per frame at density 1e6");
        for (name, vol, completes) in [("sphere", &sphere, false), ("block", &block, true)] {
            let img = render(ctx, vol, &tf, &s, 4);
            let img = &img;
            let centre: Vec<f64> =
                (14..18).flat_map(|y| (14..18).map(move |x| f64::from(img[y * 32 + x][0]))).collect();
            let (m, se) = mean_se(&centre);
            eprintln!("density 1e6, {name}, centre: {m:.4} ± {se:.4}");
            assert!(centre.iter().all(|v| v.is_finite() && (0.0..0.5).contains(v)), "{name}: not opaque: {centre:?}");
            assert!(!completes || centre.iter().all(|v| *v > 0.0), "{name}: pixels without a completed path");
            // A corner ray misses the box and sees the environment exactly.
            assert_eq!(img[0][0], 1.0, "{name}");
        }

        // The rate a GPU's frames show raises its bound (to half of it), never lowers it, and
        // ignores frames under a millisecond; llvmpipe's bound is its loop limit regardless.
        assert_eq!(r.dispatch_bound("NVIDIA H200"), DispatchBound::Time { steps_per_s: GPU_STEPS_PER_S });
        r.note_mc_frame(4_000_000_000, 10.0); // 1e9 steps in 10 ms at 4 fetches a step
        assert_eq!(r.dispatch_bound("NVIDIA H200"), DispatchBound::Time { steps_per_s: 5e10 });
        r.note_mc_frame(4_000, 2.0);
        r.note_mc_frame(4_000_000_000, 0.5);
        assert_eq!(r.dispatch_bound("NVIDIA H200"), DispatchBound::Time { steps_per_s: 5e10 });
        assert_eq!(r.dispatch_bound("llvmpipe (LLVM 15.0.6, 256 bits)"), DispatchBound::LoopLimit);

        // The same choice as a GPU would make it (100 ms at the assumed floor rate), at any size:
        // the bounded budget shrinks with the pixel count so one dispatch stays under the time,
        // down to the 8-step floor; a light medium keeps one whole path per frame.
        let gpu = DispatchBound::Time { steps_per_s: GPU_STEPS_PER_S };
        assert!(r.path_steps(&RenderSettings { mc: McSettings { density_scale: 1.0, ..s.mc }, ..s }) < 1e5);
        for size in [[32u32, 32], [512, 512], [1920, 1080], [3840, 2160]] {
            let pixels = u64::from(size[0]) * u64::from(size[1]);
            let g = r.resolve_mc(gpu, &s, size).expect("resolve");
            assert!(g.mc_bounded(), "{size:?}: one whole path at density 1e6");
            let allowed = gpu.steps_per_pixel(pixels, s.mc.dispatch_ms);
            assert!(
                g.mc.budget <= AUTO_BUDGET && (g.mc.budget == 8 || f64::from(g.mc.budget) <= allowed),
                "{size:?}: budget {}",
                g.mc.budget
            );
            let light = RenderSettings { mc: McSettings { density_scale: 1.0, ..s.mc }, ..s };
            let light_budget = r.resolve_mc(gpu, &light, size).expect("resolve").mc.budget;
            let light_fits = r.path_steps(&light) <= allowed;
            assert_eq!(light_budget == 0, light_fits, "{size:?}: light medium, budget {light_budget}");
        }
    });
}

/// A volume of 1,100 bricks along x (8,800 × 8 × 8 voxels, spacing making the box a cube): a
/// grid of a cell per brick would pass x index 1,023, past the 10 bits per axis in which bounded
/// work keeps a walk's cell from one dispatch to the next. Rays along +x cross a thousand empty
/// cells, a step each, 16 steps a dispatch, and then a black medium (voxels from 8,200 on,
/// 0.068 world units deep at extinction 3,000 per unit: transmittance e⁻²⁰⁴, and the next-flight
/// estimate's ratio weights are 0 there) that absorbs every path: each pixel the box covers is
/// exactly 0. A walk resumed in a wrapped cell would see
/// the empty start's majorants from there on and carry its path through to the white environment.
#[test]
fn a_volume_longer_than_the_walk_state_holds_along_x_absorbs_every_path() {
    common::gpu_test(|ctx| {
        let dims = [8800u32, 8, 8];
        let data: Vec<f32> = (0..dims[0] * 64).map(|i| if i % dims[0] >= 8200 { 1.0 } else { 0.0 }).collect();
        let vol = Volume::new(dims, [1.0, 1100.0, 1100.0], data, "long along x").expect("volume");
        let point = |value, extinction| vkengine::volume::optics::tf::TfPoint { value, color: [0.0; 3], extinction };
        let tf = TransferFunction::OneD {
            points: vec![point(0.0, 0.0), point(0.5, 0.0), point(0.51, 3000.0), point(1.0, 3000.0)],
        };
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let mc = McSettings { budget: 16, interleave: 1, sun_dir: None, env_radiance: [1.0; 3], ..Default::default() };
        let s = RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() };
        let size = [32u32, 32];
        for yaw in [-std::f32::consts::FRAC_PI_2, std::f32::consts::FRAC_PI_2] {
            let cam = Camera::orbit(3.0, yaw, 0.0, Projection::Orthographic { height: 2.0 });
            let mut t = Targets::new(ctx, size).expect("targets");
            for f in 0..120 {
                render_frame(ctx, &r, &mut t, &cam, &s, f).expect("render");
            }
            let img = t.read_hdr(ctx).expect("readback");
            // The box covers pixels 8..24 on both axes; jittered rays in its edge pixels may
            // graze past it.
            let inside = (9..23).flat_map(|y| (9..23).map(move |x| (x, y)));
            let lit: Vec<_> =
                inside.map(|(x, y)| (x, y, img[(y * size[0] + x) as usize][0])).filter(|p| p.2 != 0.0).collect();
            assert!(
                lit.is_empty(),
                "yaw {yaw}: {} pixels of the box see light through the medium: {:?}",
                lit.len(),
                &lit[..lit.len().min(6)]
            );
            assert!(img[0][0] > 0.99, "yaw {yaw}: the environment around the box is {}", img[0][0]);
        }
        assert_eq!(r.majorant_violations(), 0);
    });
}

/// `mc_budget=auto` takes the way this device measured to reach an error sooner
/// (`engine/volume/render/mc_calibrate.rs`): whole paths when they cost under 0.9× bounded work's
/// (relative variance × GPU time), bounded work otherwise, even for a light medium whose whole
/// paths fit the bound. (This checks the mechanism, both ways, not which way wins on
/// this device: the measurement is the device's.)
#[test]
fn auto_takes_the_way_this_device_measured_faster() {
    use vkengine::volume::render::mc_calibrate::{cached, Measured};
    common::gpu_test(|ctx| {
        let m = cached(ctx).expect("measurement");
        eprintln!("{}: {m:?}", ctx.info.name);
        for c in [m.whole_cost, m.bounded_cost] {
            assert!(c.is_finite() && c > 0.0, "cost {c}");
        }
        assert!(Measured { whole_cost: 1.0, bounded_cost: 1.05 }.bounded(), "a tie goes to bounded work");
        assert!(Measured { whole_cost: 0.91, bounded_cost: 1.0 }.bounded());
        assert!(!Measured { whole_cost: 0.89, bounded_cost: 1.0 }.bounded());
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.5, [0.5; 3], 5.0);
        let s = RenderSettings { renderer: RendererKind::Mcm, mc: mc(BUDGET_AUTO, 64), ..Default::default() };
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let bound = r.dispatch_bound(&ctx.info.name);
        assert_eq!(r.resolve_mc(bound, &s, SIZE).expect("resolve").mc.budget, 0, "whole paths fit here");
        let preferring = |b| r.resolve_mc_preferring(bound, b, &s, SIZE).expect("resolve").mc.budget;
        assert_eq!((preferring(false), preferring(true)), (0, AUTO_BUDGET));
        let auto = r.resolve_auto(ctx, &s, SIZE).expect("resolve");
        assert_eq!(auto.mc.budget, preferring(m.bounded() && ctx.info.bounded_mc()), "{m:?}");
    });
}

/// A measurement kept on disk is found again under its key only; a missing, broken or foreign
/// file yields none (the device is measured again), and storing then rewrites the file whole.
#[test]
fn auto_measurement_is_kept_per_key_and_a_broken_file_is_remeasured() {
    use vkengine::volume::render::mc_calibrate::{load, store, Measured};
    let dir = std::env::temp_dir().join(format!("vkengine-mc-cache-{}", std::process::id()));
    let file = dir.join("sub").join("mc_budget_auto.json");
    let a = Measured { whole_cost: 3.2e-3, bounded_cost: 2.2e-3 };
    let b = Measured { whole_cost: 1.0e-4, bounded_cost: 1.2e-4 };
    assert_eq!(load(&file, "dev a"), None, "no file yet");
    store(&file, "dev a", a).expect("store a");
    store(&file, "dev b", b).expect("store b");
    assert_eq!((load(&file, "dev a"), load(&file, "dev b"), load(&file, "dev c")), (Some(a), Some(b), None));
    for broken in
        ["{\"dev a\": {\"whole_cost\": 1.0", "[1, 2]", "{\"dev a\": {\"whole_cost\": 0.0, \"bounded_cost\": 1.0}}"]
    {
        std::fs::write(&file, broken).expect("write");
        assert_eq!(load(&file, "dev a"), None, "{broken}");
    }
    store(&file, "dev a", a).expect("store over a broken file");
    assert_eq!(load(&file, "dev a"), Some(a));
    let _ = std::fs::remove_dir_all(&dir);
}
