//! Light propagation volumes against exact bookkeeping (lavapipe, validation + sync validation):
//! injected energy equals the RSM's flux for every injection variant, the variants agree with
//! each other, propagation in empty space conserves energy and respects the source's symmetry,
//! the fixed-point scale neither overflows silently nor loses dim light, propagation variants
//! agree, the GPU's propagation equals its f64 CPU twin (and sparse steps equal dense ones), the geometry volume blocks light
//! behind a wall, and tiled gather injection of a spot light's 256² and 512² RSM equals float
//! atomic injection cell by cell; the lighting pass's cascaded LPV read equals a CPU lookup.

mod common;

use common::scenes::{quad, scene};
use glam::Vec3;
use vkengine::lpv::grid::{Cascade, HostGrid};
use vkengine::lpv::settings::{FixedPoint, Injection, LpvSettings, Propagation, StepDispatch};
use vkengine::lpv::{sh, transport};
use vkengine::mesh::camera::View;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::scene::{Camera, Light, Scene};
use vkengine::vk::Context;

const N: u32 = 16;

/// A 0.2 m quad facing up at the centre of a 4 m box of empty space, lit straight down. The
/// grid fits the box (centred on it, origin equal on x and z), so the quad's VPLs sit near the
/// grid's centre and the setup is symmetric under swapping x and z.
fn lit_quad(irradiance: f32) -> Scene {
    let camera = Camera {
        position: [0.0, 1.0, 3.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 50.0,
        near: 0.05,
        far: 20.0,
    };
    let sun = Light::Directional { direction: [0.0, -1.0, 0.0], color: [1.0, 0.5, 0.25], intensity: irradiance };
    let mut sc = scene(vec![quad(Vec3::ZERO, Vec3::Z * 0.1, Vec3::X * 0.1, 0)], vec![sun], camera);
    // The grid fits these bounds (lpv_extent 0).
    sc.bounds.min = [-2.0, -2.0, -2.0];
    sc.bounds.max = [2.0, 2.0, 2.0];
    sc
}

struct Run {
    passes: Vec<String>,
    /// The RSM read back: position, normal, flux per texel.
    rsm: [Vec<[f32; 4]>; 3],
    injected: HostGrid,
    accum: HostGrid,
    rsm_flux: [f64; 3],
    overflows: u32,
    scale: f32,
}

fn run(ctx: &Context, sc: &Scene, lpv: LpvSettings, rsm: u32) -> Run {
    let gpu = GpuScene::upload(ctx, sc).expect("upload");
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let mut targets = MeshTargets::new(ctx, [16, 16], rsm).expect("targets");
    targets.enable_lpv_readback(ctx, &lpv).expect("readback");
    let settings = MeshSettings { shadow_tile: 64, lpv, ..Default::default() };
    let c = &sc.camera;
    let view = View::look_at(c.position.into(), c.target.into(), c.up.into(), c.fov_y_deg, c.near, c.far);
    let frame = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
    let passes = frame.timings.iter().map(|t| t.name.clone()).collect();
    let [injected, accum] = targets.lpv_grids().expect("grids");
    let rsm = targets.read_rsm(ctx).expect("rsm");
    let mut rsm_flux = [0.0f64; 3];
    for f in &rsm[2] {
        for k in 0..3 {
            rsm_flux[k] += f[k] as f64;
        }
    }
    Run { passes, rsm, injected, accum, rsm_flux, overflows: targets.lpv_stats.overflows(), scale: targets.lpv_scale }
}

/// Pinned to one cascade per dispatch (the layout `auto` picks is a measurement): tests name its
/// passes; `stacked_steps_equal_per_cascade_steps_bit_for_bit` covers the other layout.
fn settings(injection: Injection) -> LpvSettings {
    LpvSettings {
        enabled: true,
        size: N,
        extent: 0.0,
        steps: 0,
        injection,
        occlusion: false,
        dispatch: StepDispatch::Cascades,
        ..Default::default()
    }
}

/// Total flux per channel of a grid: band 0 integrates to c0·√(4π).
fn grid_flux(grid: &HostGrid, n: u32) -> [f64; 3] {
    assert_eq!(grid.cells(), (n as usize).pow(3), "one cascade of n³ cells");
    std::array::from_fn(|ch| {
        (0..grid.cells()).map(|i| grid.coeffs(ch, i)[0] as f64).sum::<f64>() * sh::integral([1.0, 0.0, 0.0, 0.0])
    })
}

/// Largest |coefficient| of a grid.
fn peak(grid: &HostGrid) -> f32 {
    grid.values().iter().fold(0.0f32, |m, &v| m.max(v.abs()))
}

/// Largest |a − b| over two grids' coefficients.
fn worst_difference(a: &HostGrid, b: &HostGrid) -> f32 {
    assert_eq!(a.values().len(), b.values().len());
    a.values().iter().zip(b.values()).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max)
}

#[test]
fn injected_energy_equals_rsm_flux_for_every_variant_and_the_variants_agree() {
    common::gpu_test(|ctx| {
        let sc = lit_quad(2.0);
        let mut grids = Vec::new();
        for inj in [Injection::AtomicInt, Injection::AtomicFloat, Injection::Gather, Injection::Raster] {
            let r = run(ctx, &sc, settings(inj), 128);
            let total = grid_flux(&r.injected, N);
            for (ch, (&got, &want)) in total.iter().zip(&r.rsm_flux).enumerate() {
                assert!(want > 0.01, "the RSM saw no light");
                assert!((got - want).abs() <= 1e-4 * want, "{inj:?} channel {ch}: injected {got} vs RSM {want}");
            }
            assert_eq!(r.overflows, 0, "{inj:?}");
            grids.push((inj, r.injected, r.scale));
        }
        let max = peak(&grids[1].1);
        for (inj, g, scale) in &grids {
            // Integer injection rounds each of up to `texels` additions by at most half a unit.
            let tol = if *inj == Injection::AtomicInt { 128.0 * 128.0 * 0.5 / scale } else { 1e-5 * max };
            let worst = worst_difference(g, &grids[1].1);
            assert!(worst <= tol.max(1e-6 * max), "{inj:?} differs from float atomics by {worst} (tolerance {tol})");
        }
    });
}

/// A 3.6 m floor at y = -1.5 lit by a spot light 0.1 m above it (pointing down, 50° half-angle):
/// the RSM is the spot's perspective view, and the cells around its apex project to the whole
/// map (their boxes straddle the apex), so gather injection reads every texel for them — and
/// those cells hold VPLs from every part of the map, its last rows included (the lit disc is
/// 0.24 m across, within the four columns of 0.25 m cells around the apex).
fn spot_floor() -> Scene {
    let camera = Camera {
        position: [0.0, 1.0, 3.0],
        target: [0.0, -1.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 50.0,
        near: 0.05,
        far: 20.0,
    };
    let spot = Light::Spot {
        position: [0.05, -1.4, -0.03],
        direction: [0.0, -1.0, 0.0],
        color: [1.0, 0.6, 0.3],
        intensity: 4.0,
        inner_angle: 0.85,
        outer_angle: 50f32.to_radians(),
        range: 10.0,
    };
    let floor = quad(Vec3::new(0.0, -1.5, 0.0), Vec3::Z * 1.8, Vec3::X * 1.8, 0);
    let mut sc = scene(vec![floor], vec![spot], camera);
    sc.bounds.min = [-2.0, -2.0, -2.0];
    sc.bounds.max = [2.0, 2.0, 2.0];
    sc
}

/// The f64 twin of injection into the `N`³ grid of [`spot_floor`] (the one cascade the engine
/// places over its bounds, VPL offset half a cell): per cell, the number of lit texels whose VPL
/// lands there and the sum of their band-0 coefficients (Φ/π)·(√π/2) in channel `ch`.
fn host_band0(rsm: &[Vec<[f32; 4]>; 3], ch: usize) -> (Vec<u32>, Vec<f64>) {
    let sc = spot_floor();
    let bounds = [Vec3::from(sc.bounds.min), Vec3::from(sc.bounds.max)];
    let grid = vkengine::lpv::grid::place(Vec3::ZERO, Vec3::Z, bounds, N, 1, 0.0);
    let (origin, size) = (grid[0].origin.map(f64::from), f64::from(grid[0].cell));
    let n = N as usize;
    let (mut counts, mut sums) = (vec![0u32; n * n * n], vec![0.0f64; n * n * n]);
    let [pos, nrm, flux] = rsm;
    for ((p, q), f) in pos.iter().zip(nrm).zip(flux) {
        let phi = f64::from(f[ch]) * (1.0 - f64::from(q[3]).clamp(0.0, 1.0));
        if p[3] <= 0.0 || phi <= 0.0 {
            continue;
        }
        let len = (0..3).map(|k| f64::from(q[k]).powi(2)).sum::<f64>().sqrt();
        let cell: Vec<i64> = (0..3)
            .map(|k| ((f64::from(p[k]) - origin[k]) / size + 0.5 * f64::from(q[k]) / len).floor() as i64)
            .collect();
        if cell.iter().all(|&c| (0..N as i64).contains(&c)) {
            let i = cell[0] as usize + n * (cell[1] as usize + n * cell[2] as usize);
            counts[i] += 1;
            sums[i] += phi / std::f64::consts::PI * std::f64::consts::PI.sqrt() / 2.0;
        }
    }
    (counts, sums)
}

#[test]
fn gather_injection_equals_float_atomic_injection_for_a_spot_rsm_at_256_and_512() {
    // One gather dispatch over the whole of a 256² map would run 66,058 loop iterations per
    // SIMD row at a cell around the spot's apex: over llvmpipe's limit, silently cut short. The
    // pass is split into 128² tiles, each declaring its bound (the executor refuses any over it).
    // (Integer atomics against float atomics: the test above.)
    use vkengine::lpv::passes::{gather_loop_iterations, GATHER_TILE};
    assert!(gather_loop_iterations(256) > vkengine::graph::work::LLVMPIPE_LOOP_LIMIT);
    assert!(gather_loop_iterations(GATHER_TILE) <= vkengine::graph::work::LLVMPIPE_LOOP_LIMIT);
    common::gpu_test(|ctx| {
        let sc = spot_floor();
        for rsm in [256u32, 512] {
            let gather = run(ctx, &sc, settings(Injection::Gather), rsm);
            let tiles = (rsm / GATHER_TILE).pow(2) as usize;
            let passes = gather.passes.iter().filter(|p| p.contains("inject (gather)")).count();
            assert_eq!(passes, tiles, "{rsm}²: one gather dispatch per {GATHER_TILE}² tile");
            let float = run(ctx, &sc, settings(Injection::AtomicFloat), rsm);
            let max = peak(&float.injected);
            assert!(max > 0.0, "{rsm}²: nothing was injected");
            for (ch, (&got, &want)) in grid_flux(&gather.injected, N).iter().zip(&gather.rsm_flux).enumerate() {
                assert!(want > 0.01, "the RSM saw no light");
                assert!((got - want).abs() <= 1e-4 * want, "{rsm}² gather channel {ch}: injected {got} vs RSM {want}");
            }
            // An f64 twin of injection from the RSM read back (REFERENCE.md: each lit texel adds
            // (Φ/π)·c(n) to the cell holding p + δ·n, c0 = √π/2): every cell's band 0, and its
            // number K of VPLs. A texel within f32 rounding of a cell face may land on either
            // side, moving one VPL's share of ~1/10⁴: 1e-3 of the cell allows a handful.
            let (counts, band0) = host_band0(&gather.rsm, 0);
            for (i, (&k, &want)) in counts.iter().zip(&band0).enumerate() {
                let got = f64::from(gather.injected.coeffs(0, i)[0]);
                assert!(
                    (got - want).abs() <= 1e-3 * want + 1e-9,
                    "{rsm}² cell {i} ({k} VPLs): gather {got} vs f64 {want}"
                );
            }
            // Gather and float atomics add the same f32 terms per cell in different orders. All
            // VPLs here share one normal (+Y), so each coefficient's terms share a sign and each
            // order's rounding error is a random walk of K steps of at most u·|S| (u = 2⁻²⁴):
            // about u·|S|·√(K/3) each, the difference √2 times that; 4·u·√K·|S| is ~5 of its
            // standard deviations. A truncated cell loses whole VPLs (≥ 1/K of |S| each).
            let u = f64::from(f32::EPSILON) / 2.0;
            let mut worst = 0.0f64;
            for (i, &k) in counts.iter().enumerate() {
                for ch in 0..3 {
                    let (a, b) = (gather.injected.coeffs(ch, i), float.injected.coeffs(ch, i));
                    for j in 0..4 {
                        let d = f64::from(a[j] - b[j]).abs();
                        let tol = 4.0 * u * f64::from(k).sqrt() * f64::from(b[j]).abs();
                        worst = worst.max(d / tol.max(1e-30));
                        assert!(
                            d <= tol,
                            "{rsm}² cell {i} ({k} VPLs) ch {ch} coefficient {j}: gather {} vs float atomics {} (tolerance {tol:e})",
                            a[j],
                            b[j]
                        );
                    }
                }
            }
            eprintln!(
                "{rsm}²: |gather - float atomics| ≤ {:e} (peak {max:e}); worst difference / tolerance {worst:.3}",
                worst_difference(&gather.injected, &float.injected)
            );
        }
    });
}

#[test]
fn propagation_in_empty_space_conserves_energy_and_mirror_symmetry() {
    common::gpu_test(|ctx| {
        let sc = lit_quad(2.0);
        let steps = 5; // the source sits near the centre of a 16³ grid: nothing leaves it in 5 steps
        for propagation in [Propagation::Gather, Propagation::Scatter] {
            let lpv = LpvSettings { steps, propagation, ..settings(Injection::AtomicFloat) };
            let r = run(ctx, &sc, lpv, 64);
            let (inj, acc) = (grid_flux(&r.injected, N), grid_flux(&r.accum, N));
            for ch in 0..3 {
                let want = inj[ch] * (steps as f64 + 1.0);
                assert!((acc[ch] - want).abs() <= 1e-5 * want, "{propagation:?} ch {ch}: {} vs {want}", acc[ch]);
            }
            // The source is symmetric under swapping x and z about the grid centre (its lobe
            // points along y), so band 0 of the result must be too.
            let n = N as usize;
            let c0 = |x: usize, y: usize, z: usize| r.accum.coeffs(0, x + n * (y + n * z))[0];
            let mut worst = 0.0f32;
            let peak = (0..n * n * n).map(|i| r.accum.coeffs(0, i)[0]).fold(0.0f32, f32::max);
            for z in 0..n {
                for y in 0..n {
                    for x in 0..n {
                        worst = worst.max((c0(x, y, z) - c0(z, y, x)).abs());
                    }
                }
            }
            assert!(worst <= 1e-5 * peak, "{propagation:?}: x↔z asymmetry {worst} (peak {peak})");
        }
    });
}

#[test]
fn gather_and_scatter_propagation_agree() {
    common::gpu_test(|ctx| {
        let sc = lit_quad(2.0);
        let a = run(ctx, &sc, LpvSettings { steps: 4, ..settings(Injection::AtomicFloat) }, 64);
        let b = run(
            ctx,
            &sc,
            LpvSettings { steps: 4, propagation: Propagation::Scatter, ..settings(Injection::AtomicFloat) },
            64,
        );
        let peak = peak(&a.accum);
        let worst = worst_difference(&a.accum, &b.accum);
        assert!(worst <= 1e-5 * peak, "gather vs scatter differ by {worst} (peak {peak})");
    });
}

/// Both seeds: float injection's resolved grid, and integer injection's fixed-point buffer,
/// which the steps read in place (the twin starts from the injected grid read back through
/// the resolve pass).
#[test]
fn gpu_propagation_matches_the_cpu_twin() {
    common::gpu_test(|ctx| {
        let sc = lit_quad(2.0);
        let steps = 6;
        for inj in [Injection::AtomicFloat, Injection::AtomicInt] {
            let r = run(ctx, &sc, LpvSettings { steps, ..settings(inj) }, 64);
            let n = N as usize;
            let cells = n * n * n;
            let peak = peak(&r.accum) as f64;
            assert!(peak > 0.0, "nothing was injected");
            for ch in 0..3 {
                let cell = |g: &HostGrid, i: usize| g.coeffs(ch, i).map(f64::from);
                let injected: Vec<[f64; 4]> = (0..cells).map(|i| cell(&r.injected, i)).collect();
                let want = transport::accumulate(&injected, n, steps);
                let mut worst = 0.0f64;
                for (i, w) in want.iter().enumerate() {
                    let got: [f64; 4] = cell(&r.accum, i);
                    for k in 0..4 {
                        worst = worst.max((got[k] - w[k]).abs());
                    }
                }
                assert!(worst <= 1e-5 * peak, "{inj:?} channel {ch}: GPU vs CPU twin differ by {worst} (peak {peak})");
            }
        }
    });
}

/// Consistency check (the same arithmetic with work skipped, so equality is exact): sparse
/// steps, which run only the bricks light can have reached, give the accumulated grid of dense
/// steps bit for bit: a small source in empty space (most bricks skipped early on), several
/// cascades with and without the geometry volume, and grids whose edge is no multiple of a
/// brick's (8 × 4 × 2 cells).
#[test]
fn sparse_steps_equal_dense_steps_bit_for_bit() {
    common::gpu_test(|ctx| {
        let quad = lit_quad(2.0);
        let atrium = common::scenes::builtin_scene("atrium").expect("atrium");
        let cases = [
            (&quad, LpvSettings { steps: 12, ..settings(Injection::AtomicFloat) }),
            (&quad, LpvSettings { size: 20, steps: 7, occlusion: true, ..settings(Injection::AtomicInt) }),
            (&atrium, LpvSettings { size: 12, cascades: 3, extent: 2.5, steps: 6, ..settings(Injection::AtomicInt) }),
            (
                &atrium,
                LpvSettings { cascades: 2, extent: 2.5, steps: 5, occlusion: true, ..settings(Injection::AtomicInt) },
            ),
            // One step: the first step is also the last, which must not write over its source.
            (&atrium, LpvSettings { cascades: 3, extent: 2.5, steps: 1, ..settings(Injection::AtomicFloat) }),
            (&atrium, LpvSettings { cascades: 3, extent: 2.5, steps: 1, ..settings(Injection::AtomicInt) }),
        ];
        for (i, (sc, lpv)) in cases.into_iter().enumerate() {
            let sparse = run(ctx, sc, lpv, 64);
            let dense = run(ctx, sc, LpvSettings { sparse: false, ..lpv }, 64);
            // (With one step, the only step is the last, a dense one that reads each brick's
            // first step: no lists.)
            assert!(sparse.passes.iter().any(|p| p == "lpv bricks first step"), "case {i}: no sparse schedule");
            assert!(!dense.passes.iter().any(|p| p.starts_with("lpv bricks")), "case {i}: dense ran a schedule");
            assert!(peak(&dense.accum) > 0.0, "case {i}: no light");
            let worst = worst_difference(&sparse.accum, &dense.accum);
            assert_eq!(worst, 0.0, "case {i}: sparse and dense steps differ by {worst}");
            // Every cascade in one dense dispatch per step: the same values, a quarter of the
            // dispatches.
            let stacked = run(ctx, sc, LpvSettings { dispatch: StepDispatch::Stacked, ..lpv }, 64);
            let propagations = |r: &Run| r.passes.iter().filter(|p| p.starts_with("lpv propagate")).count();
            assert_eq!(propagations(&stacked), lpv.steps as usize, "case {i}: stacked dispatches");
            assert!(!stacked.passes.iter().any(|p| p.starts_with("lpv bricks")), "case {i}: stacked ran a schedule");
            let worst = worst_difference(&stacked.accum, &dense.accum);
            assert_eq!(worst, 0.0, "case {i}: stacked and per-cascade steps differ by {worst}");
        }
    });
}

#[test]
fn fixed_point_neither_overflows_silently_nor_loses_dim_light() {
    common::gpu_test(|ctx| {
        // Very bright, 1024² VPLs: the automatic scale keeps every cell in range.
        let bright = run(ctx, &lit_quad(1e10), settings(Injection::AtomicInt), 1024);
        assert_eq!(bright.overflows, 0, "automatic scale overflowed");
        let (got, want) = (grid_flux(&bright.injected, N)[0], bright.rsm_flux[0]);
        assert!((got - want).abs() <= 1e-4 * want, "bright: {got} vs {want}");
        // Very dim: still all there.
        let dim = run(ctx, &lit_quad(1e-6), settings(Injection::AtomicInt), 256);
        let (got, want) = (grid_flux(&dim.injected, N)[0], dim.rsm_flux[0]);
        assert!((got - want).abs() <= 1e-3 * want, "dim: {got} vs {want}");
        // The thesis' ×1000 with truncation loses the dim light entirely and overflows on the
        // bright one — and the overflow is reported, not silent.
        let thesis = LpvSettings { fixed_point: FixedPoint::Thesis, ..settings(Injection::AtomicInt) };
        let dim_thesis = run(ctx, &lit_quad(1e-6), thesis, 256);
        assert!(grid_flux(&dim_thesis.injected, N)[0] < 0.01 * want, "thesis preset kept dim light");
        let bright_thesis = run(ctx, &lit_quad(1e10), thesis, 1024);
        assert!(bright_thesis.overflows > 0, "thesis preset overflow went unreported");
    });
}

#[test]
fn a_static_scene_reuses_its_lpv_and_lpv_off_has_no_lpv_pass() {
    common::gpu_test(|ctx| {
        let sc = common::scenes::builtin_scene("cornell").expect("cornell");
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let c = &sc.camera;
        let view = View::look_at(c.position.into(), c.target.into(), c.up.into(), c.fov_y_deg, c.near, c.far);
        let lpv = LpvSettings { enabled: true, size: 16, steps: 4, ..Default::default() };
        let mut targets = MeshTargets::new(ctx, [48, 48], 64).expect("targets");
        let settings = MeshSettings { shadow_tile: 128, lpv, ..Default::default() };
        let lpv_passes = |run: &vkengine::graph::execute::GraphRun| {
            run.timings.iter().filter(|t| t.name.starts_with("lpv") || t.name == "rsm").count()
        };
        let first = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("frame 1");
        let a = targets.read_hdr(ctx).expect("read");
        let second = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("frame 2");
        let b = targets.read_hdr(ctx).expect("read");
        assert!(lpv_passes(&first) > 5, "the first frame computes the LPV");
        assert_eq!(lpv_passes(&second), 0, "an unchanged scene recomputed its LPV");
        assert_eq!(a, b, "the reused LPV shades differently");
        // A different light position invalidates it.
        let mut moved = sc.clone();
        if let Some(vkengine::scene::Light::Spot { position, .. }) = moved.lights.first_mut() {
            position[0] -= 0.05;
        }
        let gpu2 = GpuScene::upload(ctx, &moved).expect("upload");
        let third = render_frame(ctx, &renderer, &gpu2, &mut targets, &view, &settings).expect("frame 3");
        assert!(lpv_passes(&third) > 5, "a moved light must recompute the LPV");
        // LPV off: none of its passes in the graph (the RSM stays: these targets asked for one).
        let off = MeshSettings { shadow_tile: 128, ..Default::default() };
        let run = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &off).expect("off");
        assert!(run.timings.iter().all(|t| !t.name.starts_with("lpv")), "LPV off still ran an LPV pass");
    });
}

/// Consistency check (exact equality, no reference): a camera step that moves only the finest
/// cascade computes that cascade alone, keeps the RSM of the static light, and leaves the
/// same packed LPV and the same image as a frame that computes everything from scratch.
#[test]
fn a_camera_step_recomputes_only_the_moved_cascades_and_matches_a_full_frame() {
    common::gpu_test(|ctx| {
        for dispatch in [StepDispatch::Cascades, StepDispatch::Stacked] {
            camera_step(ctx, dispatch);
        }
    });
}

/// `a_camera_step_recomputes_only_the_moved_cascades_and_matches_a_full_frame` with gather steps
/// dispatched per cascade or stacked (which writes only the computed cascades' slots).
fn camera_step(ctx: &Context, dispatch: StepDispatch) {
    {
        let sc = common::scenes::builtin_scene("cornell").expect("cornell");
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        // Inside the box, so that every cascade overlaps the scene.
        let (centre, side) = ((gpu.bounds[0] + gpu.bounds[1]) * 0.5, (gpu.bounds[1] - gpu.bounds[0]).max_element());
        let view = View::look_at(centre + Vec3::new(0.0, 0.0, 0.3 * side), centre, Vec3::Y, 60.0, 0.01, 10.0 * side);
        let extent = side / 3.0;
        // Occlusion off: with it on, the camera's depth feeds every cascade (all recompute).
        let lpv = LpvSettings {
            enabled: true,
            size: 16,
            steps: 4,
            cascades: 3,
            extent,
            occlusion: false,
            dispatch,
            ..Default::default()
        };
        let settings = MeshSettings { shadow_tile: 128, lpv, ..Default::default() };
        // Two views a quarter of a degree of yaw apart between which a coarser cascade moves
        // (the grids sit ahead of the camera, the coarser further) and the finest does not, found
        // with the renderer's own placement: the computed cascades are not a prefix of the list.
        let place =
            |v: &View| vkengine::lpv::grid::place(v.position.into(), v.forward.into(), gpu.bounds, 16, 3, extent);
        let at = |i: i32| {
            let mut v = view;
            v.forward = (glam::Quat::from_rotation_y((0.25 * i as f32).to_radians()) * Vec3::from(view.forward)).into();
            v
        };
        let (view, moved) = (0..400)
            .map(|i| (at(i), at(i + 1)))
            .find(|(a, b)| {
                let (a, b) = (place(a), place(b));
                a.len() == 3 && b.len() == 3 && a[0] == b[0] && a != b
            })
            .expect("a turn that moves a coarser cascade and not the finest");
        let mut targets = MeshTargets::new(ctx, [48, 48], 64).expect("targets");
        render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("frame 1");
        let run = render_frame(ctx, &renderer, &gpu, &mut targets, &moved, &settings).expect("frame 2");
        let names: Vec<&str> = run.timings.iter().map(|t| t.name.as_str()).collect();
        assert!(!names.contains(&"rsm"), "the static light's RSM was rendered again: {names:?}");
        let moved_count = (0..3).filter(|&i| place(&view)[i] != place(&moved)[i]).count();
        let first_steps = names.iter().filter(|n| n.starts_with("lpv propagate 1 (")).count();
        let stacked = dispatch == StepDispatch::Stacked;
        assert_eq!(
            first_steps,
            if stacked { 1 } else { moved_count },
            "{moved_count} cascades moved, {first_steps} were propagated: {names:?}"
        );
        let (partial, partial_hdr) = (targets.read_lpv(ctx).expect("read"), targets.read_hdr(ctx).expect("read"));
        let mut fresh = MeshTargets::new(ctx, [48, 48], 64).expect("targets");
        let run = render_frame(ctx, &renderer, &gpu, &mut fresh, &moved, &settings).expect("full frame");
        let first_steps = run.timings.iter().filter(|t| t.name.starts_with("lpv propagate 1 (")).count();
        assert!(if stacked { first_steps == 1 } else { first_steps >= 2 });
        let full = fresh.read_lpv(ctx).expect("read").expect("an LPV");
        let partial = partial.expect("an LPV");
        assert!(peak(&full) > 0.0, "no light in the LPV");
        assert_eq!(partial.values().len(), full.values().len());
        let differing = partial.values().iter().zip(full.values()).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
        assert_eq!(differing, 0, "{differing} of {} LPV values differ from the full frame's", full.values().len());
        assert!(partial_hdr == fresh.read_hdr(ctx).expect("read"), "the image differs from the full frame's");
        // A light changed in place (same upload, same view: only its colour) renders the RSM
        // again: the same targets then agree with fresh ones.
        let mut gpu = gpu;
        gpu.spots.first_mut().expect("cornell has a spot light").intensity[0] *= 0.5;
        render_frame(ctx, &renderer, &gpu, &mut targets, &moved, &settings).expect("changed light");
        let mut fresh = MeshTargets::new(ctx, [48, 48], 64).expect("targets");
        render_frame(ctx, &renderer, &gpu, &mut fresh, &moved, &settings).expect("changed light, fresh");
        let (a, b) = (targets.read_lpv(ctx).expect("read"), fresh.read_lpv(ctx).expect("read"));
        assert!(a.zip(b).is_some_and(|(a, b)| a.values() == b.values()), "a changed light kept a stale LPV");
    }
}

/// The lit quad of `lit_quad`, and beside it a black wall (no VPLs of its own) in the plane
/// x = 0.25, the boundary between cells 8 and 9. The camera looks at the wall's +x side, so the
/// camera-depth source puts it into the geometry volume with its normal along +x: the direction
/// light from the quad crosses it in, where the blocking lobe is strongest. The sun leans a
/// little toward −x so the wall's shadow stops short of the quad.
fn walled_quad() -> Scene {
    let mut sc = lit_quad(2.0);
    sc.lights = vec![Light::Directional {
        direction: Vec3::new(-0.1, -1.0, 0.0).normalize().to_array(),
        color: [1.0, 1.0, 1.0],
        intensity: 2.0,
    }];
    sc.camera.position = [2.5, 0.3, 0.0];
    sc.materials.push(common::scenes::lambert(0.0));
    sc.meshes.push(quad(Vec3::new(0.25, 0.0, 0.0), Vec3::Y, Vec3::Z * 1.5, 1));
    sc
}

/// Fraction of a grid's accumulated light (band 0, red) in the cells past `walled_quad`'s wall.
fn past_the_wall(g: &HostGrid) -> f64 {
    let n = N as usize;
    let c0 = |i: usize| g.coeffs(0, i)[0].max(0.0) as f64;
    let total: f64 = (0..g.cells()).map(c0).sum();
    (0..g.cells()).filter(|i| i % n >= 9).map(c0).sum::<f64>() / total
}

#[test]
fn the_geometry_volume_blocks_light_behind_a_wall() {
    common::gpu_test(|ctx| {
        let sc = walled_quad();
        for propagation in [Propagation::Gather, Propagation::Scatter] {
            let open = LpvSettings { steps: 5, propagation, ..settings(Injection::AtomicFloat) };
            let walled = LpvSettings { occlusion: true, ..open };
            let (a, b) = (run(ctx, &sc, open, 128), run(ctx, &sc, walled, 128));
            let (leak_open, leak_walled) = (past_the_wall(&a.accum), past_the_wall(&b.accum));
            eprintln!("{propagation:?}: past the wall {leak_open:.4} open, {leak_walled:.4} walled");
            assert!(leak_open > 0.05, "{propagation:?}: without occlusion only {leak_open} passes x = 0.25");
            assert!(
                leak_walled < 0.5 * leak_open,
                "{propagation:?}: the wall let {leak_walled} of the light past it (open space: {leak_open})"
            );
        }
    });
}

#[test]
fn directional_propagation_leaks_less_past_a_wall_and_adds_only_its_passes() {
    common::gpu_test(|ctx| {
        let sc = walled_quad();
        let steps = 5;
        let base = LpvSettings { steps, occlusion: true, ..settings(Injection::AtomicFloat) };
        let directional = LpvSettings { directional: true, ..base };
        let (a, b) = (run(ctx, &sc, base, 128), run(ctx, &sc, directional, 128));
        let (leak, leak_directional) = (past_the_wall(&a.accum), past_the_wall(&b.accum));
        eprintln!("past the wall: {leak:.4} plain, {leak_directional:.4} directional");
        assert!(leak_directional < leak, "directional propagation leaked {leak_directional} vs {leak} without");
        // The injected light is untouched; only propagation changes.
        assert_eq!(worst_difference(&a.injected, &b.injected), 0.0, "directional changed the injection");
        // Exactly its passes: the normal grid, its resolve, one dilation per step, and the copy of
        // the injected light its steps accumulate into (linear propagation needs none).
        let mut extra: Vec<String> = b.passes.iter().filter(|p| !a.passes.contains(p)).cloned().collect();
        extra.sort();
        let mut want: Vec<String> = (1..=steps).map(|k| format!("lpv dilate {k}")).collect();
        want.extend(["lpv normals", "lpv normals resolve", "lpv seed"].map(String::from));
        want.sort();
        assert_eq!(extra, want, "directional propagation's passes");
        // Its steps are not linear, so they run every brick: only the sparse schedule goes.
        let mut gone: Vec<String> = a.passes.iter().filter(|p| !b.passes.contains(p)).cloned().collect();
        gone.sort();
        let schedule = ["lpv bricks first step", "lpv bricks listed", "lpv bricks occupied", "lpv clear steps"];
        assert_eq!(gone, schedule.map(String::from), "directional propagation removed other passes");
        // Scatter cannot re-project a whole step in one place: a clear error, not a wrong image.
        let scatter = LpvSettings { propagation: Propagation::Scatter, ..directional };
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let mut targets = MeshTargets::new(ctx, [16, 16], 64).expect("targets");
        let view = common::scenes::view_of(&sc.camera);
        let settings = MeshSettings { shadow_tile: 64, lpv: scatter, ..Default::default() };
        let err = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).err().expect("scatter refused");
        assert!(err.to_string().contains("lpv_propagation=gather"), "{err}");
    });
}

/// One frame's pass names, accumulated grid, HDR image and cascade.
type SkyFrame = (Vec<String>, HostGrid, Vec<[f32; 4]>, vkengine::lpv::grid::Cascade);

/// Renders `sc` with and without sky light (`lpv_sky` 0 and 1 over `off`).
fn sky_frames(ctx: &Context, sc: &Scene, off: LpvSettings, sky_radiance: [f32; 3]) -> [SkyFrame; 2] {
    let gpu = GpuScene::upload(ctx, sc).expect("upload");
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let view = common::scenes::view_of(&sc.camera);
    [off, LpvSettings { sky: 1.0, ..off }].map(|lpv| {
        let mut targets = MeshTargets::new(ctx, [16, 16], 64).expect("targets");
        targets.enable_lpv_readback(ctx, &lpv).expect("readback");
        let settings =
            MeshSettings { shadow_tile: 64, sky: sky_radiance, ambient: [0.0; 3], lpv, ..Default::default() };
        let run = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
        let names: Vec<String> = run.timings.iter().map(|t| t.name.clone()).collect();
        let [_, accum] = targets.lpv_grids().expect("grids");
        (names, accum, targets.read_hdr(ctx).expect("hdr"), targets.lpv_cascades[0])
    })
}

#[test]
fn sky_light_fills_open_cells_exactly_spreads_under_a_roof_and_adds_only_its_passes() {
    common::gpu_test(|ctx| {
        // A 3 m ground (albedo 0.5) partly covered by a roof at y = 1 (x from the grid's edge to
        // −0.5, z from −1 to the grid's edge; not mirror-symmetric, so a flipped height map would
        // show). The sun (which the RSM needs) is dim: shading clamps each cell's irradiance at
        // zero, so the ground's own VPLs, which flow away from it, would otherwise eat into the
        // sky's share.
        let mut sc = lit_quad(1e-5);
        let ground = quad(Vec3::ZERO, Vec3::Z * 1.5, Vec3::X * 1.5, 0);
        sc.meshes = vec![ground.clone(), quad(Vec3::new(-1.45, 1.0, 0.7), Vec3::Z * 1.7, Vec3::X * 0.95, 0)];
        sc.camera.position = [1.0, 3.0, 0.01];
        sc.camera.target = [1.0, 0.0, 0.0];
        let sky_radiance = [0.2f32, 0.4, 0.8];
        let n = N as usize;
        for steps in [0u32, 2] {
            let off = LpvSettings { steps, ..settings(Injection::AtomicFloat) };
            let [(names_off, grid_off, _, _), (names_on, grid_on, _, cascade)] =
                sky_frames(ctx, &sc, off, sky_radiance);
            let (s, o) = (cascade.cell, cascade.origin);
            // The cell holding a world point, and the centre of a cell index along one axis.
            let at = |p: [f32; 3]| -> [usize; 3] { std::array::from_fn(|i| ((p[i] - o[i]) / s).floor() as usize) };
            let centre = |axis: usize, k: usize| o[axis] + (k as f32 + 0.5) * s;
            let sky = |[x, y, z]: [usize; 3], ch: usize| {
                let i = x + n * (y + n * z);
                let (a, b) = (grid_on.coeffs(ch, i), grid_off.coeffs(ch, i));
                [a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]]
            };
            let mut extra: Vec<&String> = names_on.iter().filter(|p| !names_off.contains(p)).collect();
            extra.sort();
            // With the seed: the accumulation's own start, which the sky adds to apart from the
            // injected light.
            assert_eq!(extra, ["lpv inject sky", "lpv seed", "lpv sky height", "lpv sky reduce"], "sky light's passes");
            assert_eq!(names_on.len(), names_off.len() + 4, "sky light removed a pass");
            // Covered cells between ground and roof: the last column whose centre is under the
            // roof (x < −0.5), and one three columns further in.
            let [mut edge, row, mid] = at([-0.5, 0.5, 0.0]);
            while centre(0, edge) >= -0.5 {
                edge -= 1;
            }
            let (covered, deep) = ([edge, row, mid], [edge - 3, row, mid]);
            if steps == 0 {
                // Cells above everything hold exactly L·s²·(√π, π·Y₁ along −y, 0, 0).
                for (ch, &l) in sky_radiance.iter().enumerate() {
                    let want = [1.7724539 * l * s * s, 1.5349854 * l * s * s, 0.0, 0.0];
                    for p in [[1.4, 1.6, -1.0], [0.3, 1.8, 1.2], [-1.0, 1.8, 0.0], [-1.45, 1.6, -1.6]] {
                        let got = sky(at(p), ch);
                        for k in 0..4 {
                            assert!(
                                (got[k] - want[k]).abs() <= 1e-5 * want[0],
                                "open cell at {p:?} ch {ch}: {got:?} vs {want:?}"
                            );
                        }
                    }
                    // Under the roof, nothing without propagation.
                    assert_eq!(sky(covered, ch), [0.0; 4], "a covered cell holds sky light");
                }
                // Beside the roof, low down, the roof hides part of the sky but most is open; in
                // the mirror image of that point (under the roof) nothing is.
                let full = 1.7724539 * sky_radiance[0] * s * s;
                let beside = sky(at([-1.45, 0.5, -1.6]), 0)[0];
                assert!(beside > 0.5 * full && beside < full, "beside the roof: {beside} of {full}");
                assert_eq!(sky(at([-1.45, 0.5, 1.6]), 0), [0.0; 4], "under the roof's far end");
            } else {
                // Two steps carry it under the roof's edge, and not three columns in.
                assert!(sky(covered, 0)[0] > 0.0, "no sky light under the roof's edge after {steps} steps");
                assert_eq!(sky(deep, 0), [0.0; 4], "sky light went 3 columns under the roof in {steps} steps");
            }
        }
        // Open ground with nothing around it reads E = πL times the trilinear weight of open
        // cells at its sample point half a cell above it: its radiance gains ρ·L·w, with ρ = 0.4,
        // which the 8-bit UNORM G-buffer stores exactly (102/255). An albedo of 0.5 is 127.5 there,
        // a rounding tie: the H200 stored 127 and read 0.8 % below lavapipe's 128.
        sc.meshes = vec![ground];
        sc.materials[0] = common::scenes::lambert(0.4);
        let off = LpvSettings { steps: 0, ..settings(Injection::AtomicFloat) };
        let [(_, _, hdr_off, _), (_, _, hdr_on, cascade)] = sky_frames(ctx, &sc, off, sky_radiance);
        let (s, o) = (cascade.cell, cascade.origin);
        let rho = 102.0f32 / 255.0;
        let q = (0.5 * s - o[1]) / s - 0.5;
        let (k0, f) = (q.floor(), q - q.floor());
        let open = |k: f32| if o[1] + (k + 0.5) * s > 0.0 { 1.0 } else { 0.0 };
        let w_open = (1.0 - f) * open(k0) + f * open(k0 + 1.0);
        assert!(w_open > 0.5, "the ground's sample point sits mostly in covered cells ({w_open})");
        // A texture unit with fixed-point weights (subTexelPrecisionBits) may move w by 2^-bits;
        // llvmpipe filters in f32, so there the bound is f32's alone.
        let q = common::quantized_filter_step(ctx);
        for (i, (a, b)) in hdr_on.iter().zip(&hdr_off).enumerate() {
            let (px, py) = (i % 16, i / 16);
            if !(6..10).contains(&px) || !(6..10).contains(&py) {
                continue;
            }
            for ch in 0..3 {
                let (got, want) = (a[ch] - b[ch], rho * sky_radiance[ch] * w_open);
                assert!(
                    (got - want).abs() <= 1e-3 * want + rho * sky_radiance[ch] * q,
                    "pixel ({px},{py}) ch {ch}: sky adds {got}, want ρLw = {want}"
                );
            }
        }
    });
}

#[test]
fn translucent_light_goes_to_the_subsurface_lpv_and_out_through_the_shadowed_side() {
    common::gpu_test(|ctx| {
        // Surface LPV bookkeeping: a quad letting in a quarter of its light injects the other
        // three quarters of its RSM flux.
        let mut quarter = lit_quad(2.0);
        quarter.materials[0].translucency = 0.25;
        let r = run(ctx, &quarter, settings(Injection::AtomicFloat), 128);
        let (got, want) = (grid_flux(&r.injected, N)[0], 0.75 * r.rsm_flux[0]);
        assert!((got - want).abs() <= 1e-4 * want, "surface LPV got {got} of the RSM's {}, want {want}", r.rsm_flux[0]);
        assert!(r.passes.iter().all(|p| !p.starts_with("sslpv")), "subsurface LPV ran while switched off");

        // A translucent slab lit from above, seen from below: its underside is in its own shadow.
        let mut sc = lit_quad(2.0);
        sc.meshes = common::scenes::boxed(Vec3::new(-0.6, -0.15, -0.6), Vec3::new(0.6, 0.15, 0.6), 0);
        sc.camera.position = [0.0, -1.5, 0.01];
        sc.camera.target = [0.0, 0.0, 0.0];
        let frame = |sc: &Scene, subsurface: bool| {
            let gpu = GpuScene::upload(ctx, sc).expect("upload");
            let renderer = MeshRenderer::new(ctx).expect("renderer");
            let mut targets = MeshTargets::new(ctx, [16, 16], 128).expect("targets");
            let lpv = LpvSettings { steps: 3, subsurface, ..settings(Injection::AtomicFloat) };
            let settings = MeshSettings { shadow_tile: 64, ambient: [0.0; 3], lpv, ..Default::default() };
            let view = common::scenes::view_of(&sc.camera);
            let run = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
            let names: Vec<String> = run.timings.iter().map(|t| t.name.clone()).collect();
            let underside: f64 =
                targets.read_hdr(ctx).expect("hdr")[6 * 16 + 6..6 * 16 + 10].iter().map(|p| p[0] as f64).sum();
            (names, underside)
        };
        // Opaque: the switch adds nothing, not even a pass.
        let (opaque_off, dark) = frame(&sc, false);
        let (opaque_on, dark_too) = frame(&sc, true);
        assert_eq!(opaque_off, opaque_on, "the subsurface switch added passes without a translucent material");
        assert_eq!(dark, dark_too, "the subsurface switch changed an opaque scene");
        // Translucent: its own passes, and light comes out underneath.
        sc.materials[0].translucency = 0.5;
        let (plain, without) = frame(&sc, false);
        let (with_sslpv, with) = frame(&sc, true);
        let extra: Vec<&String> = with_sslpv.iter().filter(|p| !plain.contains(p)).collect();
        assert!(extra.iter().all(|p| p.starts_with("sslpv ")), "non-subsurface passes added: {extra:?}");
        for want in ["sslpv inject (atomic float)", "sslpv propagate 3 (gather)"] {
            assert!(extra.iter().any(|p| *p == want), "missing {want} in {extra:?}");
        }
        assert!(!extra.iter().any(|p| p.contains("geometry volume")), "the subsurface LPV built a geometry volume");
        assert!(with > without + 1e-3, "the shadowed underside did not brighten: {without} → {with}");
    });
}

/// The lighting pass's LPV read, written again in f64 from its description: the finest cascade
/// holding x + offset·s·n, each of the 8 corners' max(0, SH · cosine lobe around −n) trilinearly
/// weighted, over s², blended into the next cascade over the last two cells when that one holds
/// the point at least a cell deep. Also returns the cascade chosen and whether it blended.
fn cpu_lpv_irradiance(
    grid: &HostGrid,
    cascades: &[Cascade],
    x: [f64; 3],
    n: [f64; 3],
    offset: f64,
) -> ([f64; 3], usize, bool) {
    let size = cascades[0].n as usize;
    let coords = |c: usize| {
        let (s, o) = (f64::from(cascades[c].cell), cascades[c].origin.map(f64::from));
        [0, 1, 2].map(|i| (x[i] + n[i] * offset * s - o[i]) / s)
    };
    let margin = |q: [f64; 3]| {
        let (lo, hi) = (q[0].min(q[1]).min(q[2]), q[0].max(q[1]).max(q[2]));
        lo.min(size as f64 - hi)
    };
    let lobe = sh::cosine_lobe(n.map(|v| -v));
    let lookup = |c: usize| -> [f64; 3] {
        let q = coords(c).map(|v| v.clamp(0.5, size as f64 - 0.5) - 0.5);
        let mut e = [0.0; 3];
        for corner in 0..8 {
            let mut w = 1.0;
            let mut cell = [0usize; 3];
            for i in 0..3 {
                let (b, f) = (q[i].floor(), q[i] - q[i].floor());
                let hi = corner >> i & 1 == 1;
                cell[i] = ((b as usize) + usize::from(hi)).min(size - 1);
                w *= if hi { f } else { 1.0 - f };
            }
            let index = cell[0] + size * (cell[1] + size * (cell[2] + c * size));
            for (ch, e) in e.iter_mut().enumerate() {
                let k = grid.coeffs(ch, index);
                *e += w * (0..4).map(|j| f64::from(k[j]) * lobe[j]).sum::<f64>().max(0.0);
            }
        }
        let s = f64::from(cascades[c].cell);
        e.map(|v| v / (s * s))
    };
    let mut c = 0;
    while margin(coords(c)) < 0.0 && c + 1 < cascades.len() {
        c += 1;
    }
    let m = margin(coords(c));
    if m < 0.0 {
        return ([0.0; 3], c, false);
    }
    let fine = lookup(c);
    if m >= 2.0 || c + 1 == cascades.len() || margin(coords(c + 1)) < 1.0 {
        return (fine, c, false);
    }
    let (t, coarse) = ((m * 0.5).clamp(0.0, 1.0), lookup(c + 1));
    ([0, 1, 2].map(|i| coarse[i] * (1.0 - t) + fine[i] * t), c, true)
}

/// Consistency check against an independent implementation (no analytic reference): the
/// lighting pass adds ρ/π times the irradiance `cpu_lpv_irradiance` reads from the same packed
/// grids, on a ground the finest cascade's edge crosses, so pixels of the finest cascade alone,
/// of its blend into the coarser one, and of the coarser one alone are all checked.
#[test]
fn the_lighting_pass_reads_and_blends_the_cascades_as_a_cpu_lookup_does() {
    common::gpu_test(|ctx| {
        // A 4 m ground (albedo 0.4, stored exactly as 102/255: 0.5 would be a rounding tie of the
        // 8-bit G-buffer) and a wall at x = −1 facing +x (albedo 0.8, 204/255); the sun comes from
        // above and from +x, so the wall's light flows out over the ground.
        let camera = Camera {
            position: [1.2, 0.5, 1.2],
            target: [-0.6, 0.0, -0.6],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 60.0,
            near: 0.05,
            far: 20.0,
        };
        let sun = Light::Directional { direction: [-0.6, -0.8, -0.1], color: [1.0, 0.8, 0.6], intensity: 3.0 };
        let ground = quad(Vec3::ZERO, Vec3::Z * 2.0, Vec3::X * 2.0, 0);
        let wall = quad(Vec3::new(-1.0, 0.75, 0.0), Vec3::Y * 0.75, Vec3::Z * 1.5, 1);
        let mut sc = scene(vec![ground, wall], vec![sun], camera);
        sc.materials[0] = common::scenes::lambert(0.4);
        sc.materials.push(common::scenes::lambert(0.8));
        let size = [64u32, 48];
        let lpv = LpvSettings {
            enabled: true,
            size: 8,
            cascades: 2,
            extent: 2.0,
            steps: 4,
            occlusion: false,
            ..Default::default()
        };
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let view = common::scenes::view_of(&sc.camera);
        // The LPV off, on, and on with the blend pass's dispatch limited to one workgroup along
        // x, so its list of blending pixels runs as rows of groups along y (as past 4.2 M pixels).
        let [(off, _), (on, targets), (rows, _)] =
            [(false, 65_535), (true, 65_535), (true, 1)].map(|(enabled, limit)| {
                let mut targets = MeshTargets::new(ctx, size, 64).expect("targets");
                targets.blend_group_limit = limit;
                let settings = MeshSettings {
                    shadow_tile: 128,
                    ambient: [0.0; 3],
                    sky: [0.0; 3],
                    lpv: LpvSettings { enabled, ..lpv },
                    ..Default::default()
                };
                render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
                let hdr = targets.read_hdr(ctx).expect("hdr");
                (hdr, targets)
            });
        let differ = on.iter().zip(&rows).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{differ} pixels differ when the blend pass dispatches rows of one group");
        let grid = targets.read_lpv(ctx).expect("read").expect("an LPV");
        assert_eq!(targets.lpv_cascades.len(), 2, "two cascades");
        let rho = f64::from(102.0f32 / 255.0);
        let q = f64::from(common::quantized_filter_step(ctx));
        let mut counts = [0usize; 3]; // finest alone, blended, coarser alone
        let (mut worst, mut peak) = (0.0f64, 0.0f64);
        let mut checks = Vec::new();
        for py in 0..size[1] {
            for px in 0..size[0] {
                let Some(x) = common::scenes::shaded_point(&view, size, px, py, 0.0) else { continue };
                // The ground, away from its edges and the wall's foot.
                if x[0] < -0.8 || x[0] > 1.8 || x[2].abs() > 1.8 {
                    continue;
                }
                let (e, c, blended) =
                    cpu_lpv_irradiance(&grid, &targets.lpv_cascades, x, [0.0, 1.0, 0.0], f64::from(lpv.sample_offset));
                counts[if blended {
                    1
                } else if c == 0 {
                    0
                } else {
                    2
                }] += 1;
                let i = (py * size[0] + px) as usize;
                for ch in 0..3 {
                    let want = rho / std::f64::consts::PI * e[ch];
                    let got = f64::from(on[i][ch]) - f64::from(off[i][ch]);
                    peak = peak.max(want);
                    checks.push((px, py, ch, got, want, f64::from(off[i][ch])));
                }
            }
        }
        assert!(peak > 0.0, "no indirect light on the ground");
        for &(px, py, ch, got, want, direct) in &checks {
            // f32 shading of a position rebuilt from depth: 3e-4 of the brightest indirect light,
            // plus the rounding of adding it to the direct light.
            let err = (got - want).abs();
            worst = worst.max(err / peak);
            // Plus, on a texture unit with fixed-point weights, 2^-bits per lerp level of the
            // trilinear read (three), of at most the peak's range.
            assert!(
                err <= 3e-4 * peak + 1e-6 * direct + 3.0 * q * peak,
                "pixel ({px},{py}) ch {ch}: the LPV adds {got}, the CPU lookup gives {want}"
            );
        }
        eprintln!("pixels: {counts:?} (finest, blended, coarser); worst difference {worst:.2e} of the peak");
        assert!(counts.iter().all(|&k| k >= 20), "too few pixels of some kind: {counts:?} (finest, blended, coarser)");
        // Rows of one group each: more than one row only if more than 64 pixels blend.
        assert!(counts[1] > 64, "{} blended pixels fill a single blend group", counts[1]);
    });
}

/// The thesis configuration (4 cascades of 32³, 8 steps, occlusion) with every cascade in one
/// dispatch per step: the whole propagation is at most 10 dispatches (8), the last step writes
/// the grid images itself (no whole-grid copy), and the executor counts what each pass recorded;
/// one cascade per dispatch (sparse) takes the schedule's 3 and 4 × 8, and one copy.
#[test]
fn thesis_propagation_takes_at_most_ten_dispatches_and_no_grid_copy() {
    common::gpu_test(|ctx| {
        let sc = common::scenes::builtin_scene("atrium").expect("atrium");
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let mut targets = MeshTargets::new(ctx, [32, 32], 64).expect("targets");
        let c = &sc.camera;
        let view = View::look_at(c.position.into(), c.target.into(), c.up.into(), c.fov_y_deg, c.near, c.far);
        for (dispatch, most) in [(StepDispatch::Stacked, 10), (StepDispatch::Cascades, 3 + 4 * 8)] {
            let lpv = LpvSettings {
                enabled: true,
                size: 32,
                cascades: 4,
                extent: 2.5,
                steps: 8,
                occlusion: true,
                reuse: false,
                dispatch,
                ..Default::default()
            };
            let settings = MeshSettings { shadow_tile: 64, lpv, ..Default::default() };
            let run = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("frame");
            let propagation: Vec<_> = run
                .timings
                .iter()
                .filter(|t| ["lpv propagate", "lpv bricks", "lpv clear steps"].iter().any(|p| t.name.starts_with(p)))
                .collect();
            let computed = run.timings.iter().filter(|t| t.name.starts_with("lpv propagate 1 (")).count();
            let dispatches: u32 = propagation.iter().map(|t| t.commands.dispatches).sum();
            eprintln!("{dispatch:?}: {computed} first steps, {dispatches} propagation dispatches");
            assert!(dispatches >= 8 && dispatches <= most, "{dispatch:?}: {dispatches} dispatches");
            // One dispatch recorded per compute pass of the propagation, none by its clears.
            for t in &propagation {
                let want = u32::from(!t.name.starts_with("lpv clear"));
                assert_eq!(t.commands.dispatches, want, "{}", t.name);
            }
            // Stacked, the last step writes the images; per cascade, one copy does.
            let copies = run.timings.iter().filter(|t| t.name.contains("accumulated copy")).count();
            assert_eq!(copies, usize::from(dispatch == StepDispatch::Cascades), "{dispatch:?}: whole-grid copies");
            // Transfer passes count the bytes they declared: the LPV clear writes at least the
            // fixed-point grid (12 × 4 bytes per cell of 4 × 32³).
            let clear = run.timings.iter().find(|t| t.name == "lpv clear").expect("lpv clear");
            assert!(clear.commands.transfer_bytes >= 48 * 4 * 32768, "{:?}", clear.commands);
            assert!(run.timings.iter().any(|t| t.commands.barriers > 0), "no barrier counted");
        }
    });
}
