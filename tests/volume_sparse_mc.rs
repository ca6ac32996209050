//! Monte Carlo through the sparse layout's segment words (`volume/common.glsl`: the majorant
//! grid's cells are bricks and carry their page-table words; the walk's cells are shifted half a
//! voxel to be the bricks' sample regions) against the dense layout's page-free lookups, on
//! lavapipe under validation. Statistical consistency checks: both are unbiased estimates of the
//! same transmittance and image (dense is tested against analytic answers in `volume_mc.rs`),
//! and one exact check of where the shifted walk reads each brick's slot.

mod common;

use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::Volume;
use vkengine::volume::device::layout::VolumeLayout;
use vkengine::volume::optics::tf::{TfPoint, TransferFunction};
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, TransmittanceEstimator, VolumeRenderer,
};

const SIZE: [u32; 2] = [32, 32];

/// Oblique orthographic view: rays cross brick boundaries along every axis and enter through
/// low and high faces alike.
fn camera() -> Camera {
    Camera::orbit(3.0, 0.7, 0.4, Projection::Orthographic { height: 2.0 })
}

/// Voxels in [0.5, 1] hashed per voxel: density everywhere (the box's faces included) that
/// changes by up to half its range from one voxel to the next, so a slot read half a voxel off
/// or from the wrong brick shows.
fn noise(n: u32) -> Volume {
    let data: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let h = i.wrapping_mul(2_654_435_761).rotate_left(13).wrapping_mul(2_246_822_519);
            0.5 + 0.5 * (h >> 8) as f32 / (1u32 << 24) as f32
        })
        .collect();
    Volume::new([n; 3], [1.0; 3], data, "noise").expect("volume")
}

/// Voxels alternating 1 (odd x) and 0.5 (even x): every brick's first voxel is 0.5 and the
/// voxel below it 1, so the half voxel below a brick (the sample region of the brick below)
/// read as the brick's own first voxel loses density, always in one direction.
fn stripes(n: u32) -> Volume {
    let data: Vec<f32> = (0..n * n * n).map(|i| if (i % n) % 2 == 1 { 1.0 } else { 0.5 }).collect();
    Volume::new([n; 3], [1.0; 3], data, "stripes").expect("volume")
}

/// Extinction 0 up to value 0.55 and `s` from 0.6: where the stripes' filtered value falls off
/// between 1 and 0.5, most of the way the medium is at `s`.
fn cliff(s: f32) -> TransferFunction {
    TransferFunction::OneD {
        points: vec![
            TfPoint { value: 0.0, color: [1.0; 3], extinction: 0.0 },
            TfPoint { value: 0.55, color: [1.0; 3], extinction: 0.0 },
            TfPoint { value: 0.6, color: [1.0; 3], extinction: s },
            TfPoint { value: 1.0, color: [1.0; 3], extinction: s },
        ],
    }
}

/// Extinction linear in the value, 0 to `s`.
fn ramp(s: f32) -> TransferFunction {
    TransferFunction::OneD {
        points: vec![
            TfPoint { value: 0.0, color: [1.0; 3], extinction: 0.0 },
            TfPoint { value: 1.0, color: [1.0; 3], extinction: s },
        ],
    }
}

/// Red channel of every pixel in the box's footprint, frame after frame (no accumulation).
fn frames(ctx: &Context, r: &VolumeRenderer, s: &RenderSettings, n: u64, seed0: u64) -> Vec<Vec<f32>> {
    (0..n)
        .map(|f| {
            let mut t = Targets::new(ctx, SIZE).expect("targets");
            render_frame(ctx, r, &mut t, &camera(), s, seed0 + f).expect("render");
            t.read_hdr(ctx).expect("readback").iter().map(|p| p[0]).collect()
        })
        .collect()
}

/// Per pixel (mean, standard error) over frames.
fn per_pixel(f: &[Vec<f32>]) -> Vec<(f64, f64)> {
    let n = f.len() as f64;
    (0..f[0].len())
        .map(|i| {
            let m = f.iter().map(|v| f64::from(v[i])).sum::<f64>() / n;
            let var = f.iter().map(|v| (f64::from(v[i]) - m).powi(2)).sum::<f64>() / (n - 1.0);
            (m, (var / n).sqrt())
        })
        .collect()
}

/// Chi-square of two per-pixel estimates over the pixels where either varies, its degrees of
/// freedom, and the mean difference with its standard error.
fn compare(a: &[(f64, f64)], b: &[(f64, f64)]) -> (f64, usize, f64, f64) {
    let pairs: Vec<_> = a.iter().zip(b).filter(|(p, q)| p.1 > 0.0 || q.1 > 0.0).collect();
    let chi2 = pairs.iter().map(|(p, q)| (p.0 - q.0).powi(2) / (p.1 * p.1 + q.1 * q.1)).sum();
    let k = pairs.len() as f64;
    let mean = pairs.iter().map(|(p, q)| p.0 - q.0).sum::<f64>() / k;
    let se = pairs.iter().map(|(p, q)| p.1 * p.1 + q.1 * q.1).sum::<f64>().sqrt() / k;
    (chi2, pairs.len(), mean, se)
}

fn layouts(ctx: &Context, vol: &Volume, tf: &TransferFunction) -> [VolumeRenderer; 2] {
    let dense = VolumeRenderer::with_layout(ctx, vol, tf, VolumeLayout::Dense).expect("dense");
    let sparse = VolumeRenderer::with_layout(ctx, vol, tf, VolumeLayout::Sparse).expect("sparse");
    assert!(sparse.segment_words() && !dense.segment_words(), "the sparse 32³ volume should take segment words");
    [dense, sparse]
}

fn assert_agree(what: &str, d: &[(f64, f64)], s: &[(f64, f64)]) {
    let (chi2, k, mean, se) = compare(d, s);
    let limit = k as f64 + 4.0 * (2.0 * k as f64).sqrt();
    eprintln!("{what}: chi2 {chi2:.1} over {k} pixels (limit {limit:.1}); mean sparse − dense {:.5} ± {se:.5}", -mean);
    assert!(k > 200, "{what}: only {k} pixels see the volume");
    assert!(chi2 < limit, "{what}: sparse disagrees with dense pixel by pixel: chi2 {chi2:.1} > {limit:.1}");
    assert!(mean.abs() < 4.0 * se, "{what}: sparse is off dense by {:.5} ± {se:.5} on average", -mean);
}

#[test]
fn segment_words_estimate_the_transmittance_dense_lookups_do() {
    common::gpu_test(|ctx| {
        let [dense, sparse] = layouts(ctx, &stripes(32), &cliff(3.0));
        for est in [TransmittanceEstimator::Delta, TransmittanceEstimator::Ratio] {
            let mc = McSettings { transmittance: est, debug_transmittance: true, ..Default::default() };
            let s = RenderSettings { renderer: RendererKind::Mcs, mc, ..Default::default() };
            let d = per_pixel(&frames(ctx, &dense, &s, 96, 0));
            let sp = per_pixel(&frames(ctx, &sparse, &s, 96, 1_000_000));
            assert_agree(&format!("{est:?} transmittance"), &d, &sp);
        }
        assert_eq!(sparse.majorant_violations(), 0);
    });
}

#[test]
fn bounded_work_through_segment_words_renders_as_dense() {
    common::gpu_test(|ctx| {
        let [dense, sparse] = layouts(ctx, &noise(32), &ramp(3.0));
        let mc = McSettings { budget: 256, max_events: 4, ..Default::default() };
        let s = RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() };
        let d = per_pixel(&frames(ctx, &dense, &s, 48, 0));
        let sp = per_pixel(&frames(ctx, &sparse, &s, 48, 1_000_000));
        assert_agree("bounded MCM", &d, &sp);
        assert_eq!(sparse.majorant_violations(), 0);
    });
}

/// Zeros with one plane of ones at voxel 15 (the last of brick 1) across `axis`.
fn plane(axis: usize) -> Volume {
    let n = 32u32;
    let data: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let c = [i % n, (i / n) % n, i / (n * n)];
            if c[axis] == 15 {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    Volume::new([n; 3], [1.0; 3], data, "plane").expect("volume")
}

#[test]
fn segment_words_block_exactly_the_rays_dense_lookups_block() {
    // Rays parallel to a plane of ones at voxel 15 (texel centre 15.5) on an image of half-voxel
    // pixels: those within 0.95 texels of the plane see a filtered value above 0.05, an extinction
    // of 100 per world unit along their whole length, and are blocked for sure; the others see
    // exactly 0 and pass for sure. So one frame of delta tracking is exact. The ray at texel 16.25
    // lies in the half voxel below brick 2, the sample region of brick 1: a walk reading brick 2's
    // slot there (clamped to its region) would let it through.
    // The same with bounded work (its own walk): a black medium under a white environment, so a
    // blocked camera ray's paths all end in 0 (absorbed; the view-ray estimate's ratio weights are
    // 0 where the extinction is its majorant) and a free one's all see 1.
    common::gpu_test(|ctx| {
        let tf = |albedo: f32| TransferFunction::OneD {
            points: vec![
                TfPoint { value: 0.0, color: [albedo; 3], extinction: 0.0 },
                TfPoint { value: 0.05, color: [albedo; 3], extinction: 0.0 },
                TfPoint { value: 0.06, color: [albedo; 3], extinction: 100.0 },
                TfPoint { value: 1.0, color: [albedo; 3], extinction: 100.0 },
            ],
        };
        let transmittance = McSettings {
            transmittance: TransmittanceEstimator::Delta,
            debug_transmittance: true,
            ..Default::default()
        };
        let bounded =
            McSettings { budget: 2048, interleave: 1, sun_dir: None, env_radiance: [1.0; 3], ..Default::default() };
        let cases = [
            ("transmittance", RendererKind::Mcs, transmittance, tf(1.0)),
            ("bounded MCM", RendererKind::Mcm, bounded, tf(0.0)),
        ];
        let size = [128, 128];
        // Down −Z (planes across x and y), then down the x axis (the plane across z).
        let views = [(0, 0.0), (1, 0.0), (2, std::f32::consts::FRAC_PI_2)];
        for (what, renderer, mc, tf) in &cases {
            let s = RenderSettings { renderer: *renderer, mc: *mc, ..Default::default() };
            for (axis, yaw) in views {
                let [dense, sparse] = layouts(ctx, &plane(axis), tf);
                let cam = Camera::orbit(3.0, yaw, 0.0, Projection::Orthographic { height: 2.0 });
                let blocked = |r: &VolumeRenderer| -> Vec<bool> {
                    let mut t = Targets::new(ctx, size).expect("targets");
                    render_frame(ctx, r, &mut t, &cam, &s, 0).expect("render");
                    t.read_hdr(ctx).expect("readback").iter().map(|p| p[0] < 0.5).collect()
                };
                let (d, sp) = (blocked(&dense), blocked(&sparse));
                // Four half-voxel lines (14.75 … 16.25) of the 64 × 64 pixels the box covers.
                let lines = d.iter().zip(&sp).filter(|(a, _)| **a).count();
                assert_eq!(lines, 4 * 64, "{what}, axis {axis}: dense blocks {lines} pixels");
                let differ = d.iter().zip(&sp).filter(|(a, b)| a != b).count();
                assert_eq!(differ, 0, "{what}, axis {axis}: sparse blocks {differ} pixels differently from dense");
            }
        }
    });
}
