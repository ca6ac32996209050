//! Absolute accuracy of the volume renderers (issue 22): each image is compared pixel block by
//! pixel block with an answer computed here, independently of the shaders, in f64 — the
//! analytic transmittance `exp(-σ d)` of a homogeneous box along each camera ray, a quadrature
//! of single scattering from the sun and from a point light, and the white furnace (albedo 1 in
//! a unit environment: radiance 1 everywhere) of a dense heterogeneous cloud.

mod common;

use glam::Vec3;
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection, Rig};
use vkengine::volume::data::procedural;
use vkengine::volume::optics::phase::PhaseFunction;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, TransmittanceEstimator, VolumeRenderer,
};

const SIZE: [u32; 2] = [64, 64];
/// Pixel blocks of the statistical comparisons: 16×16 pixels, 16 blocks of a 64² image (a frame
/// costs little more than a 32² one on lavapipe: more pixels per frame, fewer frames).
const BLOCK: u32 = 16;

/// A perspective view from above and to the side: the box's chord length varies from pixel to
/// pixel (three faces visible), and the image's corners miss it.
fn camera() -> Camera {
    Camera::orbit(2.4, 0.5, 0.35, Projection::Perspective { fov_y: 0.75 })
}

/// One camera ray in f64: origin (the eye) and unit direction, from the camera's parameters
/// (`Camera::orbit`'s eye, `look_to_rh` with +Y up, a pinhole of vertical field of view
/// `fov_y`, square pixels; the image's top row looks up) — not from the engine's matrices.
fn pinhole_ray(cam: &Camera, px: u32, py: u32) -> ([f64; 3], [f64; 3]) {
    let (Rig::Orbit { target, distance, yaw, pitch }, Projection::Perspective { fov_y }) = (cam.rig, cam.projection)
    else {
        panic!("the tests use an orbit camera with a perspective projection");
    };
    let (yaw, pitch, dist) = (f64::from(yaw), f64::from(pitch), f64::from(distance));
    let dir = [yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos()];
    let eye = [0, 1, 2].map(|i| f64::from(target.to_array()[i]) + dir[i] * dist);
    let fwd = dir.map(|c| -c);
    let right = normalize(cross(fwd, [0.0, 1.0, 0.0]));
    let up = cross(right, fwd);
    let h = (f64::from(fov_y) * 0.5).tan();
    let aspect = f64::from(SIZE[0]) / f64::from(SIZE[1]);
    let nx = (f64::from(px) + 0.5) / f64::from(SIZE[0]) * 2.0 - 1.0;
    let ny = -((f64::from(py) + 0.5) / f64::from(SIZE[1]) * 2.0 - 1.0);
    let d = [0, 1, 2].map(|i| fwd[i] + nx * h * aspect * right[i] + ny * h * up[i]);
    (eye, normalize(d))
}

/// The ray the shaders trace through pixel (px, py)'s centre, in f64: the engine's camera
/// matrix (f32, `Camera::inverse_view_projection`) unprojecting the pixel at NDC depth 0 and 1, as
/// `camera_ray_at` does. The matrix is the camera's definition (checked against the pinhole model
/// above); everything after it is exact here. With near 0.01 and far 100 the f32 inverse is good
/// to ~2e-5 rad, which at a grazing chord is already more than the rounding EAM may show.
fn ray(cam: &Camera, px: u32, py: u32) -> ([f64; 3], [f64; 3]) {
    let m = cam.inverse_view_projection(SIZE[0] as f32 / SIZE[1] as f32).to_cols_array().map(f64::from);
    let nx = (f64::from(px) + 0.5) / f64::from(SIZE[0]) * 2.0 - 1.0;
    let ny = -((f64::from(py) + 0.5) / f64::from(SIZE[1]) * 2.0 - 1.0);
    let unproject = |z: f64| {
        let v = [nx, ny, z, 1.0];
        let c: [f64; 4] = [0, 1, 2, 3].map(|r| (0..4).map(|k| m[k * 4 + r] * v[k]).sum());
        [c[0] / c[3], c[1] / c[3], c[2] / c[3]]
    };
    let (o, f) = (unproject(0.0), unproject(1.0));
    (o, normalize([f[0] - o[0], f[1] - o[1], f[2] - o[2]]))
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    a.map(|c| c / l)
}

/// Entry and exit distances of the ray through the box `[-h, h]` (h = 0.5: the renderers put a
/// cubic volume's box there), or `None` if it misses.
fn chord(o: [f64; 3], d: [f64; 3], h: f64) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for i in 0..3 {
        if d[i].abs() < 1e-300 {
            if o[i].abs() > h {
                return None;
            }
            continue;
        }
        let (a, b) = ((-h - o[i]) / d[i], (h - o[i]) / d[i]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t1 > t0).then_some((t0, t1))
}

/// Henyey–Greenstein density over the sphere at the cosine μ between the light's direction
/// before and after scattering (REFERENCE.md).
fn hg(g: f64, mu: f64) -> f64 {
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5))
}

/// `runs` independent accumulations of `frames` frames each (fresh targets, disjoint frame
/// numbers, so disjoint random streams): one image per run, each pixel the run's mean.
fn runs(
    ctx: &Context,
    r: &VolumeRenderer,
    s: &RenderSettings,
    cam: &Camera,
    runs: u64,
    frames: u64,
    size: [u32; 2],
) -> Vec<Vec<[f32; 4]>> {
    (0..runs)
        .map(|run| {
            let mut t = Targets::new(ctx, size).expect("targets");
            for f in 0..frames {
                render_frame(ctx, r, &mut t, cam, s, run * 100_000 + f).expect("render");
            }
            assert_eq!(r.majorant_violations(), 0);
            t.read_hdr(ctx).expect("readback")
        })
        .collect()
}

/// Compares independent runs with a per-pixel reference, block by block: the block's mean
/// residual (over its pixels and runs) must be within 4 standard errors of 0, the standard
/// error estimated from the residuals themselves (every pixel of every run is independent), with
/// `floor` the smallest standard error credited (a block whose samples are all identical, e.g.
/// Bernoulli samples with p ≈ 0 or 1, has an estimated 0). Returns the largest |z|.
fn compare_blocks(
    what: &str,
    imgs: &[Vec<[f32; 4]>],
    reference: &[f64],
    size: [u32; 2],
    block: u32,
    floor: impl Fn(f64, usize) -> f64,
) -> f64 {
    let mut worst = 0.0f64;
    for by in 0..size[1] / block {
        for bx in 0..size[0] / block {
            let mut res = Vec::new();
            let mut level = 0.0;
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let i = (y * size[0] + x) as usize;
                    level += reference[i];
                    for img in imgs {
                        let v = f64::from(img[i][0]);
                        assert!(v.is_finite() && v >= 0.0, "{what}: pixel ({x}, {y}) is {v}");
                        res.push(v - reference[i]);
                    }
                }
            }
            let n = res.len() as f64;
            level /= f64::from(block * block);
            let m = res.iter().sum::<f64>() / n;
            let var = res.iter().map(|e| (e - m).powi(2)).sum::<f64>() / (n - 1.0);
            let se = (var / n).sqrt().max(floor(level, res.len()));
            let z = m / se.max(1e-300);
            worst = worst.max(z.abs());
            assert!(
                m.abs() <= 4.0 * se,
                "{what}: block ({bx}, {by}) differs from the reference {level:.6} by {m:.6} ± {se:.6} (z = {z:.2})"
            );
        }
    }
    eprintln!("{what}: worst block |z| = {worst:.2}");
    worst
}

/// Standard error of the mean of `n` Bernoulli samples with success probability `p`: the
/// exact spread of an escape/absorb estimator, credited where every sample came out the same.
fn bernoulli_se(p: f64, n: usize) -> f64 {
    (p * (1.0 - p) / n as f64).sqrt()
}

/// Per-pixel `exp(-σ d)` along the f64 camera rays through the unit box (1 where they miss).
fn transmittance_reference(cam: &Camera, sigma: f64) -> Vec<f64> {
    (0..SIZE[1])
        .flat_map(|y| (0..SIZE[0]).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (o, d) = ray(cam, x, y);
            chord(o, d, 0.5).map_or(1.0, |(t0, t1)| (-sigma * (t1 - t0)).exp())
        })
        .collect()
}

#[test]
fn the_f64_camera_model_matches_the_engines_rays() {
    // The reference rays are built from the camera's parameters; the engine's come from its
    // inverse view-projection. They must be the same rays (f32 accuracy), or every reference
    // here would be compared with a different image.
    let cam = camera();
    let inv = cam.inverse_view_projection(1.0);
    for (x, y) in [(0, 0), (63, 0), (5, 37), (32, 32), (63, 63)] {
        let ndc = glam::Vec2::new(
            (x as f32 + 0.5) / SIZE[0] as f32 * 2.0 - 1.0,
            -((y as f32 + 0.5) / SIZE[1] as f32 * 2.0 - 1.0),
        );
        let near = inv.project_point3(ndc.extend(0.0));
        let d = (inv.project_point3(ndc.extend(1.0)) - near).normalize();
        let (o, dd) = pinhole_ray(&cam, x, y);
        let e = Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32);
        let dv = Vec3::new(dd[0] as f32, dd[1] as f32, dd[2] as f32);
        // 5e-5: the f32 matrix's own accuracy (see `ray`).
        assert!((dv - d).length() < 5e-5, "pixel ({x}, {y}): direction {dv} vs the engine's {d}");
        // The engine's ray starts on the near plane, on the same line through the eye.
        assert!((near - e).cross(d).length() < 5e-5, "pixel ({x}, {y}): origin {near} off the line from {e}");
    }
    let refs = transmittance_reference(&cam, 1.0);
    let hits = refs.iter().filter(|&&t| t < 1.0).count();
    assert!(hits > 1600 && hits < 4000, "the box should cover part of the image: {hits} pixels");
}

fn absorber(ctx: &Context, extinction: f32) -> VolumeRenderer {
    let vol = procedural::homogeneous_box([8, 8, 8], 1.0).expect("volume");
    VolumeRenderer::new(ctx, &vol, &TransferFunction::constant([0.0; 3], extinction)).expect("renderer")
}

/// Albedo 0 in a unit environment, no other light: a path's radiance is 1 if its camera ray
/// leaves the box without a collision, else 0 — the mean is the transmittance.
fn absorbing(scale: f32, budget: u32) -> RenderSettings {
    RenderSettings {
        renderer: RendererKind::Mcm,
        jitter: false,
        mc: McSettings {
            sun_dir: None,
            point_light: None,
            env_radiance: [1.0; 3],
            density_scale: scale,
            max_events: 4,
            budget,
            // Paths here take a handful of steps: every pixel completes exactly this many per
            // frame, so bounded work's ratio estimator has a fixed denominator (no O(1/N) bias).
            paths_per_frame: 4,
            ..Default::default()
        },
        ..Default::default()
    }
}

#[test]
fn absorption_matches_exp_minus_optical_depth_at_extreme_density_scales() {
    common::gpu_test(|ctx| {
        let cam = camera();
        let sigma0 = 1.5f64;
        for scale in [1e-6f32, 1e3, 1e6] {
            // (a) The density scale compensated by the table: extinction σ0/scale in the transfer
            // function, ×scale at render time. The medium is σ0 = 1.5 whatever the scale, so the
            // image is the same visible exp(-σ0 d): the scale's products (majorants, tracking
            // steps) must be exact at 1e-6 and at 1e6 too.
            let r = absorber(ctx, (sigma0 / f64::from(scale)) as f32);
            let want = transmittance_reference(&cam, sigma0);
            for budget in [0u32, 256] {
                // Paths behind each residual (one run's pixel): frames × (1 or 4 paths). Measured
                // power: free flights 6 % too long fail the classic case (z = 4.6), 3 % too long
                // the bounded one (z = 4.1); 3 % in the classic case reached only z = 3.8.
                let (count, frames) = if budget > 0 { (6, 4) } else { (8, 6) };
                let imgs = runs(ctx, &r, &absorbing(scale, budget), &cam, count, frames, SIZE);
                let n = frames as usize * if budget > 0 { 4 } else { 1 };
                compare_blocks(
                    &format!("σ0/{scale} × {scale}, budget {budget}"),
                    &imgs,
                    &want,
                    SIZE,
                    BLOCK,
                    |p, px| bernoulli_se(p, px * n),
                );
            }
            // (b) The scale applied to a fixed medium of σ0: ×1e-6 is nearly clear, ×1e3 and ×1e6
            // opaque (exp(-1500 d) < 1e-30 for every chord here longer than 0.05).
            let r = absorber(ctx, sigma0 as f32);
            let sigma = sigma0 * f64::from(scale);
            let want = transmittance_reference(&cam, sigma);
            if scale < 1.0 {
                // Residual ratio tracking with the control at the (constant) extinction is exact:
                // T = exp(-σc d), one number per pixel, compared to f32 rounding.
                let s = RenderSettings {
                    renderer: RendererKind::Mcs,
                    mc: McSettings {
                        density_scale: scale,
                        transmittance: TransmittanceEstimator::ResidualRatio,
                        debug_transmittance: true,
                        ..Default::default()
                    },
                    ..Default::default()
                };
                let img = &runs(ctx, &r, &s, &cam, 1, 1, SIZE)[0];
                let mut worst = 0.0f64;
                for (i, (p, w)) in img.iter().zip(&want).enumerate() {
                    // 1 - T ≈ 1.5e-6 d: f32 resolves it to ~6e-8 (an ulp just below 1).
                    let e = (f64::from(p[0]) - w).abs();
                    worst = worst.max(e);
                    assert!(e <= 1.5e-7, "pixel {i}: T = {} vs exp(-σd) = {w} (σ = {sigma:e})", p[0]);
                }
                eprintln!("σ = {sigma:e}: largest |T - exp(-σd)| = {worst:e}");
            } else {
                for budget in [0u32, 256] {
                    let imgs = runs(ctx, &r, &absorbing(scale, budget), &cam, 4, 2, SIZE);
                    let n = 2 * if budget > 0 { 4 } else { 1 };
                    let what = format!("σ = {sigma:e}, budget {budget}");
                    compare_blocks(&what, &imgs, &want, SIZE, BLOCK, |p, px| bernoulli_se(p, px * n));
                    // Where the reference is 0 (below 1e-30) or 1 in f64, every path must agree.
                    for (i, w) in want.iter().enumerate().filter(|(_, w)| **w < 1e-30 || **w == 1.0) {
                        for img in &imgs {
                            assert_eq!(f64::from(img[i][0]), w.round(), "{what}: pixel {i}");
                        }
                    }
                }
            }
        }
    });
}

#[test]
fn emission_absorption_matches_exp_minus_optical_depth() {
    common::gpu_test(|ctx| {
        // EAM with black emission over a unit background shows its transmittance. The medium is
        // homogeneous, so its segments' exp(-σ Δs) multiply to exp(-σ d) for any step: the only
        // differences allowed are f32 rounding (a few ulps per segment, ≤ 32 segments) and early
        // termination, which stops below T = ε = 1e-3 (so it can leave at most ε).
        // With filter=exact that holds on every device. With the texture unit's filter (the
        // default) a GPU weighs texels with fixed-point fractions of subTexelPrecisionBits bits:
        // the weights of two equal table texels may sum to 1 ± 2^-bits, so σ is off by that
        // fraction in each of the two filtered lookups (volume, table), and T = exp(-σd) by
        // T·σd·2·2^-bits = −T ln T·2^(1−bits). (The H200, 8 bits: T = 0.965279 against 0.965199.)
        let cam = camera();
        let bits = ctx.info.limits.sub_texel_precision_bits;
        for exact in [true, false] {
            for sigma in [1.5f64, 1.5e-6, 1.5e3, 1.5e6] {
                let r = absorber(ctx, sigma as f32);
                let s = RenderSettings {
                    renderer: RendererKind::Eam,
                    background: [1.0; 3],
                    exact_filter: exact,
                    ..Default::default()
                };
                let img = &runs(ctx, &r, &s, &cam, 1, 1, SIZE)[0];
                let want = transmittance_reference(&cam, sigma);
                let mut worst = 0.0f64;
                for (i, (p, w)) in img.iter().zip(&want).enumerate() {
                    let v = f64::from(p[0]);
                    // Below ε: terminated. Otherwise f32 rounding: ≤ 32 segments of a few ulps
                    // each, and the shader's ray and box entry/exit in f32 (≈1e-6 of the chord).
                    let filter = if exact || *w <= 0.0 { 0.0 } else { -w * w.ln() * 2f64.powi(1 - bits as i32) };
                    let tol = if v < f64::from(s.termination) {
                        f64::from(s.termination)
                    } else {
                        w * (64.0 * 1.2e-7 + sigma * 1e-6) + 1e-7 + filter
                    };
                    worst = worst.max((v - w).abs());
                    assert!(
                        (v - w).abs() <= tol,
                        "σ = {sigma:e}, exact {exact}: pixel {i} shows T = {v}, exp(-σd) = {w} ± {tol}"
                    );
                }
                eprintln!("EAM σ = {sigma:e}, exact filter {exact}: largest |T - exp(-σd)| = {worst:e}");
            }
        }
    });
}

/// Single-scattering reference of the homogeneous unit box: along each camera ray
/// `∫ T(eye→x) σs p(μ) T(x→light) E(x) dt`, with `light(x)` giving the unit direction towards
/// the light, the distance the shadow ray is attenuated over (inside the box) and the
/// irradiance arriving unattenuated. Composite Simpson over 4000 intervals of the chord.
fn single_scattering_reference(
    cam: &Camera,
    sigma_t: f64,
    albedo: f64,
    g: f64,
    light: impl Fn([f64; 3]) -> ([f64; 3], f64, f64),
) -> Vec<f64> {
    let mut out = Vec::new();
    for y in 0..SIZE[1] {
        for x in 0..SIZE[0] {
            let (o, d) = ray(cam, x, y);
            let Some((t0, t1)) = chord(o, d, 0.5) else {
                out.push(0.0);
                continue;
            };
            let f = |t: f64| {
                let p = [0, 1, 2].map(|i| o[i] + d[i] * t);
                let (l, shadow, e) = light(p);
                // μ between the light's travel before (-l) and after (-d) scattering: l · d.
                (-sigma_t * (t - t0)).exp() * sigma_t * albedo * hg(g, dot(l, d)) * (-sigma_t * shadow).exp() * e
            };
            let n = 4000;
            let h = (t1 - t0) / f64::from(n);
            let mut sum = f(t0) + f(t1);
            for k in 1..n {
                sum += f(t0 + h * f64::from(k)) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            out.push(sum * h / 3.0);
        }
    }
    out
}

/// Distance from `p` (inside the unit box) to the box's boundary along unit `l`.
fn exit(p: [f64; 3], l: [f64; 3]) -> f64 {
    chord(p, l, 0.5).map_or(0.0, |(_, t1)| t1)
}

#[test]
fn single_scattering_of_the_sun_and_a_point_light_matches_quadrature() {
    common::gpu_test(|ctx| {
        // MCS of a homogeneous box: σt = 1.2, albedo 0.7, Henyey–Greenstein g = 0.5, no
        // environment. The sun is a directional light whose `sun_radiance` is the irradiance it
        // delivers (W/m² on a plane facing it: the estimator adds β·p·T·E), the point light's
        // `intensity` is radiant intensity (E = I/r²); the image is radiance, linear (the HDR
        // accumulation target, before tone mapping).
        let cam = camera();
        let (sigma, albedo, g) = (1.2f64, 0.7f64, 0.5f64);
        let vol = procedural::homogeneous_box([8, 8, 8], 1.0).expect("volume");
        let tf = TransferFunction::constant([albedo as f32; 3], sigma as f32);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let base = McSettings {
            sun_dir: None,
            point_light: None,
            env_radiance: [0.0; 3],
            phase: PhaseFunction::HenyeyGreenstein { g: g as f32 }.to_gpu(),
            ..Default::default()
        };
        let sun = normalize([-0.45, 0.6, -0.66]);
        let e_sun = 2.5f64;
        let point = [1.1f64, 0.9, -0.2];
        let intensity = 12.0f64;
        let cases: [(&str, McSettings, Vec<f64>); 2] = [
            (
                "sun",
                McSettings { sun_dir: Some(sun.map(|c| c as f32)), sun_radiance: [e_sun as f32; 3], ..base },
                single_scattering_reference(&cam, sigma, albedo, g, |p| (sun, exit(p, sun), e_sun)),
            ),
            (
                "point light",
                McSettings { point_light: Some((point.map(|c| c as f32), [intensity as f32; 3])), ..base },
                single_scattering_reference(&cam, sigma, albedo, g, |p| {
                    let to = [0, 1, 2].map(|i| point[i] - p[i]);
                    let r2 = dot(to, to);
                    let l = normalize(to);
                    (l, exit(p, l).min(r2.sqrt()), intensity / r2)
                }),
            ),
        ];
        for (name, mc, want) in cases {
            let s = RenderSettings { renderer: RendererKind::Mcs, jitter: false, mc, ..Default::default() };
            let imgs = runs(ctx, &r, &s, &cam, 8, 10, SIZE);
            let lit = want.iter().cloned().fold(0.0, f64::max);
            assert!(lit > 0.05, "{name}: the reference is too dark to test ({lit})");
            // No floor: every block that sees the box has scatter-point noise.
            compare_blocks(&format!("MCS {name}"), &imgs, &want, SIZE, BLOCK, |_, _| 1e-9);
            // Pixels missing the box see nothing at all.
            for (i, w) in want.iter().enumerate() {
                if *w == 0.0 {
                    assert!(imgs.iter().all(|im| im[i][0] == 0.0), "{name}: pixel {i} misses the box but is lit");
                }
            }
        }
    });
}

#[test]
fn a_dense_cloud_in_a_white_furnace_is_white_in_both_majorant_modes() {
    common::gpu_test(|ctx| {
        // The procedural cloud at density ×50 (extinction up to 200 per unit; the cloud's core
        // tens of mean free paths across), albedo 1, in a unit environment: no light is
        // absorbed and the radiance is 1 everywhere, whatever the heterogeneity or the majorant.
        // Bounded work keeps every dispatch under llvmpipe's loop limit; the paths' scattering
        // events are capped at 4096, far beyond what they need here.
        let size = [32u32, 32];
        let vol = procedural::cloud([32; 3], 3).expect("volume");
        let tf = TransferFunction::ramp(0.05, 0.7, [1.0; 3], 4.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let cam = Camera::orbit(2.0, 0.4, 0.3, Projection::Perspective { fov_y: 0.6 });
        let want = vec![1.0f64; (size[0] * size[1]) as usize];
        for grid in [false, true] {
            let s = RenderSettings {
                renderer: RendererKind::Mcm,
                mc: McSettings {
                    sun_dir: None,
                    point_light: None,
                    env_radiance: [1.0; 3],
                    density_scale: 50.0,
                    max_events: 4096,
                    majorant_grid: grid,
                    phase: PhaseFunction::HenyeyGreenstein { g: 0.3 }.to_gpu(),
                    // 10 × 4096 + 1 loop iterations per row and dispatch (mc_loop_iterations).
                    budget: 4096,
                    paths_per_frame: 4,
                    ..Default::default()
                },
                ..Default::default()
            };
            let imgs = runs(ctx, &r, &s, &cam, 4, 6, size);
            // A pixel with no completed path reads 0 (the mean of none): every pixel must have
            // finished paths in every run, or the comparison would hide missing ones in the noise.
            for (k, img) in imgs.iter().enumerate() {
                let zeros = img.iter().filter(|p| p[0] == 0.0).count();
                let lo = img.iter().map(|p| p[0]).fold(f32::MAX, f32::min);
                eprintln!("grid={grid} run {k}: lowest pixel {lo}, {zeros} without a completed path");
                assert_eq!(zeros, 0, "grid={grid} run {k}: pixels without a completed path");
            }
            // No floor: a block the cloud does not cover is exactly 1 (the environment seen directly).
            compare_blocks(&format!("furnace grid={grid}"), &imgs, &want, size, 8, |_, _| 0.0);
        }
    });
}

#[test]
fn exact_filtering_agrees_with_the_texture_unit_within_its_fraction_bits() {
    // A consistency check of filter=exact's hand-made trilinear and table lookups against the
    // texture unit, on a cloud whose values change from voxel to voxel: MIP (one sample's
    // filtering, no accumulation) and EAM. A fixed-point filter of subTexelPrecisionBits bits
    // puts each fraction within 2^-bits of the exact one, so a lerp moves by at most 2^-bits of
    // its texels' difference (≤ the value range, 1): per pixel |hardware − exact| ≤ 3·2^-bits
    // for MIP (three lerp levels); EAM compounds it, so its bound is on the mean difference.
    // llvmpipe filters in f32, so there the two agree to f32 rounding. A swapped axis or a
    // misplaced texel centre in the exact path is off by a whole voxel's change (≫ these bounds).
    common::gpu_test(|ctx| {
        let vol = procedural::cloud([24, 20, 16], 3).expect("volume");
        let tf = TransferFunction::ramp(0.1, 0.8, [0.9, 0.7, 0.5], 12.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let cam = Camera::orbit(2.2, 0.5, 0.35, Projection::Perspective { fov_y: 0.7 });
        let q = 2f64.powi(-(ctx.info.limits.sub_texel_precision_bits as i32));
        for (kind, per_pixel) in [(RendererKind::Mip, 3.0 * q + 1e-5), (RendererKind::Eam, f64::INFINITY)] {
            let render = |exact| {
                let s = RenderSettings { renderer: kind, exact_filter: exact, ..Default::default() };
                runs(ctx, &r, &s, &cam, 1, 1, SIZE).remove(0)
            };
            let (hw, ex) = (render(false), render(true));
            let diffs: Vec<f64> =
                hw.iter().zip(&ex).flat_map(|(a, b)| (0..3).map(move |c| f64::from((a[c] - b[c]).abs()))).collect();
            let max = diffs.iter().cloned().fold(0.0, f64::max);
            let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
            let level = ex.iter().map(|p| f64::from(p[0])).sum::<f64>() / ex.len() as f64;
            eprintln!("{kind:?}: |hardware − exact| max {max:e}, mean {mean:e} (level {level:.4}, 2^-bits {q:e})");
            assert!(level > 0.01, "{kind:?}: the image is empty");
            assert!(max <= per_pixel, "{kind:?}: a pixel differs by {max}, over {per_pixel}");
            assert!(mean <= 3.0 * q * level + 1e-6, "{kind:?}: mean difference {mean} over 3·2^-bits of {level}");
            if ctx.info.name.starts_with("llvmpipe") {
                // Pinned to lavapipe on purpose: its texture unit filters in f32.
                assert!(max <= 1e-4, "{kind:?} (lavapipe, f32 filtering): largest difference {max}");
            }
        }
    });
}

/// The clip planes of the clipping tests, `(n, d)` with a unit normal, kept where `n·x <= d`,
/// as `--set clip=0.1,0,0,1,0.3,0` and `crop=-0.5,-0.5,-0.5,0.5,0.25,0.5` state them (the
/// crop box's top face at y = 0.25; its other faces are the volume box's own).
fn clip_planes() -> Vec<([f64; 3], f64)> {
    let n = normalize([1.0, 0.3, 0.0]);
    vec![(n, dot(n, [0.1, 0.0, 0.0])), ([0.0, 1.0, 0.0], 0.25)]
}

fn clipped_settings(mut s: RenderSettings) -> RenderSettings {
    s.clip.planes[0] = Some([0.1, 0.0, 0.0, 1.0, 0.3, 0.0]);
    s.clip.crop = Some([-0.5, -0.5, -0.5, 0.5, 0.25, 0.5]);
    s
}

/// The part `(t0, t1)` of the ray through the unit box on the kept side of every plane of
/// `clip_planes` (f64, from the line–half-space intersections; t1 <= t0 when nothing is kept),
/// `None` where the ray misses the box.
fn clipped_chord(o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = chord(o, d, 0.5)?;
    for (n, c) in clip_planes() {
        // o + t d is kept where n·o + t n·d <= c.
        let (a, b) = (dot(n, d), c - dot(n, o));
        if a > 0.0 {
            t1 = t1.min(b / a);
        } else if a < 0.0 {
            t0 = t0.max(b / a);
        } else if b < 0.0 {
            t1 = t0;
        }
    }
    Some((t0, t1))
}

/// Per-pixel `exp(-σ d)` with d the length of [`clipped_chord`].
fn clipped_transmittance_reference(cam: &Camera, sigma: f64) -> Vec<f64> {
    (0..SIZE[1])
        .flat_map(|y| (0..SIZE[0]).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (o, d) = ray(cam, x, y);
            clipped_chord(o, d).map_or(1.0, |(t0, t1)| (-sigma * (t1 - t0).max(0.0)).exp())
        })
        .collect()
}

/// A clipped homogeneous absorber against its per-pixel transmittance `want`: EAM with
/// filter=exact to f32 rounding (as `emission_absorption_matches_exp_minus_optical_depth`, the
/// planes' entry/exit in f32 like the box faces'), then MCM in the classic and the bounded mode
/// within noise (albedo 0 in a unit environment, so a path's mean is the camera ray's
/// transmittance). `clip` adds the clipping to a renderer's settings.
fn check_clipped_transmittance(
    ctx: &Context,
    what: &str,
    sigma: f64,
    want: &[f64],
    clip: impl Fn(RenderSettings) -> RenderSettings,
) {
    let cam = camera();
    let r = absorber(ctx, sigma as f32);
    let eam =
        RenderSettings { renderer: RendererKind::Eam, background: [1.0; 3], exact_filter: true, ..Default::default() };
    let img = &runs(ctx, &r, &clip(eam), &cam, 1, 1, SIZE)[0];
    let mut worst = 0.0f64;
    for (i, (p, w)) in img.iter().zip(want).enumerate() {
        let v = f64::from(p[0]);
        let tol = w * (64.0 * 1.2e-7 + sigma * 1e-6) + 1e-7;
        worst = worst.max((v - w).abs());
        assert!((v - w).abs() <= tol, "{what} EAM: pixel {i} shows T = {v}, exp(-σd) = {w} ± {tol}");
    }
    eprintln!("{what} EAM σ = {sigma}: largest |T - exp(-σd)| = {worst:e}");
    for budget in [0u32, 256] {
        let (count, frames) = if budget > 0 { (6, 4) } else { (8, 6) };
        let imgs = runs(ctx, &r, &clip(absorbing(1.0, budget)), &cam, count, frames, SIZE);
        let n = frames as usize * if budget > 0 { 4 } else { 1 };
        let z = compare_blocks(&format!("{what} MCM, budget {budget}"), &imgs, want, SIZE, BLOCK, |p, px| {
            bernoulli_se(p, px * n)
        });
        eprintln!("{what} MCM budget {budget}: worst block |z| = {z:.2}");
    }
}

#[test]
fn a_clipped_box_transmits_exp_minus_sigma_times_the_remaining_length() {
    common::gpu_test(|ctx| {
        let cam = camera();
        let sigma = 1.5f64;
        let want = clipped_transmittance_reference(&cam, sigma);
        let unclipped = transmittance_reference(&cam, sigma);
        // The cut must matter: many pixels lose part of their chord.
        let cut = want.iter().zip(&unclipped).filter(|(w, u)| **w > **u + 0.05).count();
        assert!(cut > 500, "the clip planes should shorten many chords: {cut} pixels");
        check_clipped_transmittance(ctx, "clipped", sigma, &want, clipped_settings);
    });
}

/// Mean and variance of the mean of one 16×16 block over independent runs.
fn block_mean(imgs: &[Vec<[f32; 4]>], bx: u32, by: u32, channel: usize) -> (f64, f64) {
    let v: Vec<f64> = imgs
        .iter()
        .flat_map(|img| {
            (by * BLOCK..(by + 1) * BLOCK).flat_map(move |y| {
                (bx * BLOCK..(bx + 1) * BLOCK).map(move |x| f64::from(img[(y * SIZE[0] + x) as usize][channel]))
            })
        })
        .collect();
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0) / n)
}

#[test]
fn a_clipped_slab_lit_through_the_cut_matches_the_precut_slab() {
    common::gpu_test(|ctx| {
        // A scattering cube cut at z = 0 (the half z > 0 removed), the sun shining from +z
        // through the removed half onto the cut face: vacuum to the paths, so the face is lit.
        // The reference is the half-height slab written to a raw file and loaded as a volume of
        // its own: its box is z ∈ [-0.25, 0.25], the kept half's z ∈ [-0.5, 0], so its camera
        // looks at a target 0.25 higher (the sun and environment do not depend on position).
        let tf = TransferFunction::constant([0.8; 3], 4.0);
        let cube = procedural::homogeneous_box([16, 16, 16], 1.0).expect("volume");
        let dir = std::env::temp_dir().join(format!("vkengine-clip-slab-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let file = dir.join("slab.raw");
        std::fs::write(&file, vec![200u8; 16 * 16 * 8]).expect("write slab");
        let opts = vkengine::volume::data::LoadOptions {
            dims: Some([16, 16, 8]),
            voxel: Some(vkengine::volume::data::VoxelType::U8),
            ..Default::default()
        };
        let slab = vkengine::volume::data::load(&file, &opts).expect("load slab");
        let _ = std::fs::remove_dir_all(&dir);
        let mc = McSettings {
            sun_dir: Some([0.3, 0.2, 1.0]),
            sun_radiance: [3.0; 3],
            env_radiance: [0.0; 3],
            max_events: 16,
            ..Default::default()
        };
        let base = RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() };
        let mut clipped = base;
        clipped.clip.planes[0] = Some([0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        clipped.mc.seed = 7; // a random stream of its own, independent of the reference's
        let cam_cut = Camera::orbit(2.2, 0.4, 0.5, Projection::Perspective { fov_y: 0.75 });
        let mut cam_slab = cam_cut;
        if let Rig::Orbit { target, .. } = &mut cam_slab.rig {
            *target += Vec3::new(0.0, 0.0, 0.25);
        }
        let cut = runs(ctx, &VolumeRenderer::new(ctx, &cube, &tf).expect("renderer"), &clipped, &cam_cut, 6, 8, SIZE);
        let pre = runs(ctx, &VolumeRenderer::new(ctx, &slab, &tf).expect("renderer"), &base, &cam_slab, 6, 8, SIZE);
        // χ² of the 16 blocks' differences, each over its own standard error (both sides'
        // variance from their pixels); 16 degrees of freedom, p = 0.001 at 39.25.
        let mut chi2 = 0.0;
        let mut lit = 0.0f64;
        for by in 0..SIZE[1] / BLOCK {
            for bx in 0..SIZE[0] / BLOCK {
                let (a, va) = block_mean(&cut, bx, by, 0);
                let (b, vb) = block_mean(&pre, bx, by, 0);
                lit = lit.max(b);
                chi2 += (a - b).powi(2) / (va + vb).max(1e-12);
                eprintln!("block ({bx}, {by}): clipped {a:.4}, pre-cut {b:.4}");
            }
        }
        eprintln!("clipped vs pre-cut slab: χ² = {chi2:.1} over 16 blocks");
        // Only the sun lights the slab: a cut face in the shadow of the removed half (σ d = 2)
        // would be several times darker.
        assert!(lit > 0.05, "the pre-cut slab should be lit: brightest block {lit}");
        assert!(chi2 < 39.25, "the clipped cube differs from the pre-cut slab: χ² = {chi2:.1} over 16 blocks");
    });
}

/// Rotates `v` by `deg` degrees about the unit axis `k` (Rodrigues' formula).
fn rotate(v: [f64; 3], k: [f64; 3], deg: f64) -> [f64; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    let kxv = cross(k, v);
    let kv = dot(k, v);
    [0, 1, 2].map(|i| v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
}

/// The oriented crop box of the rotated-crop test: `crop` and `crop_rotation` (degrees about x,
/// then y, then z, about the box's centre). Its corners reach past the volume's box, so both
/// boxes' faces cut chords.
const ORIENTED_CROP: [f32; 6] = [-0.3, -0.35, -0.25, 0.35, 0.3, 0.4];
const ORIENTED_ANGLES: [f32; 3] = [25.0, -40.0, 60.0];

/// Per-pixel `exp(-σ d)` with d the length of the camera ray inside both the unit box and the
/// oriented crop box: the ray taken into the crop box's own frame (the inverse rotations, z then
/// y then x, by Rodrigues' formula about the world axes) and cut by its axis-aligned slabs there.
fn oriented_crop_reference(cam: &Camera, sigma: f64) -> Vec<f64> {
    let c = ORIENTED_CROP.map(f64::from);
    let m = [0, 1, 2].map(|i| 0.5 * (c[i] + c[i + 3]));
    let h = [0, 1, 2].map(|i| 0.5 * (c[i + 3] - c[i]));
    let [ax, ay, az] = ORIENTED_ANGLES.map(f64::from);
    let to_local = |v: [f64; 3]| {
        let v = rotate(v, [0.0, 0.0, 1.0], -az);
        let v = rotate(v, [0.0, 1.0, 0.0], -ay);
        rotate(v, [1.0, 0.0, 0.0], -ax)
    };
    (0..SIZE[1])
        .flat_map(|y| (0..SIZE[0]).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (o, d) = ray(cam, x, y);
            let Some((mut t0, mut t1)) = chord(o, d, 0.5) else { return 1.0 };
            let (lo, ld) = (to_local([0, 1, 2].map(|i| o[i] - m[i])), to_local(d));
            for i in 0..3 {
                if ld[i].abs() < 1e-300 {
                    if lo[i].abs() > h[i] {
                        t1 = t0;
                    }
                    continue;
                }
                let (a, b) = ((-h[i] - lo[i]) / ld[i], (h[i] - lo[i]) / ld[i]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
            (-sigma * (t1 - t0).max(0.0)).exp()
        })
        .collect()
}

#[test]
fn an_oriented_crop_box_transmits_exp_minus_sigma_times_the_remaining_length() {
    common::gpu_test(|ctx| {
        let cam = camera();
        let sigma = 1.5f64;
        let r = absorber(ctx, sigma as f32);
        let want = oriented_crop_reference(&cam, sigma);
        // The rotation must matter: many pixels differ from the unrotated crop box's chords.
        let crop = |mut s: RenderSettings, rotated: bool| {
            s.clip.crop = Some(ORIENTED_CROP);
            s.clip.crop_rotation = rotated.then_some(ORIENTED_ANGLES);
            s
        };
        let eam = RenderSettings {
            renderer: RendererKind::Eam,
            background: [1.0; 3],
            exact_filter: true,
            ..Default::default()
        };
        let axis_aligned = &runs(ctx, &r, &crop(eam, false), &cam, 1, 1, SIZE)[0];
        let moved = axis_aligned.iter().zip(&want).filter(|(p, w)| (f64::from(p[0]) - **w).abs() > 0.05).count();
        assert!(moved > 500, "the rotation should change many chords: {moved} pixels");
        // MIP of the homogeneous box: 1 wherever the kept chord is not empty, else 0.
        let mip = RenderSettings { renderer: RendererKind::Mip, exact_filter: true, ..Default::default() };
        let img = &runs(ctx, &r, &crop(mip, true), &cam, 1, 1, SIZE)[0];
        let mut shown = 0;
        for (i, (p, w)) in img.iter().zip(&want).enumerate() {
            // Chords shorter than 1e-3 are left out: a grazing ray may round either way.
            if (*w - 1.0).abs() < 1e-12 || *w < (-sigma * 1e-3).exp() {
                let hit = *w < 1.0;
                shown += usize::from(hit);
                assert_eq!(p[0] > 0.5, hit, "oriented crop, MIP: pixel {i} shows {}, kept chord T = {w}", p[0]);
            }
        }
        assert!(shown > 500, "MIP should show the kept box: {shown} pixels");
        check_clipped_transmittance(ctx, "oriented crop", sigma, &want, |s| crop(s, true));
    });
}

#[test]
fn with_clip_shadows_on_the_removed_part_shadows_the_cut_face_by_its_transmittance() {
    common::gpu_test(|ctx| {
        // Single scattering (MCS) in a homogeneous cube cut at z = 0 (the half z > 0 removed),
        // lit only by a sun straight down −z. Every shadow ray from the kept half runs up to
        // z = 0 and then through the removed half's whole 0.5: with `clip_shadows` on it is
        // attenuated by exactly exp(−σ·0.5) more than in vacuum, the camera segment being the
        // same, so the image is the vacuum image times that factor, pixel by pixel.
        let sigma = 2.0f64;
        let tf = TransferFunction::constant([0.8; 3], sigma as f32);
        let cube = procedural::homogeneous_box([16, 16, 16], 1.0).expect("volume");
        let r = VolumeRenderer::new(ctx, &cube, &tf).expect("renderer");
        let cam = Camera::orbit(2.2, 0.4, 0.5, Projection::Perspective { fov_y: 0.75 });
        let k = (-sigma * 0.5).exp();
        for budget in [0u32, 256] {
            let mut off = RenderSettings {
                renderer: RendererKind::Mcs,
                mc: McSettings {
                    sun_dir: Some([0.0, 0.0, 1.0]),
                    sun_radiance: [3.0; 3],
                    env_radiance: [0.0; 3],
                    density_scale: 1.0,
                    budget,
                    ..Default::default()
                },
                ..Default::default()
            };
            off.clip.planes[0] = Some([0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
            let mut on = off;
            on.clip.shadows = true;
            on.mc.seed = 7; // independent of the vacuum run's stream
            let (a_imgs, b_imgs) = (runs(ctx, &r, &on, &cam, 6, 6, SIZE), runs(ctx, &r, &off, &cam, 6, 6, SIZE));
            // χ² of the 16 blocks of on − k·off over their standard errors; p = 0.001 at 39.25.
            let (mut chi2, mut sum_on, mut sum_off) = (0.0, 0.0, 0.0);
            for by in 0..SIZE[1] / BLOCK {
                for bx in 0..SIZE[0] / BLOCK {
                    let (a, va) = block_mean(&a_imgs, bx, by, 0);
                    let (b, vb) = block_mean(&b_imgs, bx, by, 0);
                    sum_on += a;
                    sum_off += b;
                    chi2 += (a - k * b).powi(2) / (va + k * k * vb).max(1e-12);
                }
            }
            let ratio = sum_on / sum_off;
            eprintln!(
                "clip_shadows budget {budget}: on/off = {ratio:.4} (exp(-σ/2) = {k:.4}), χ² = {chi2:.1} over 16 blocks"
            );
            assert!(sum_off > 0.005 * 16.0, "the cut face should be lit in vacuum: mean {}", sum_off / 16.0);
            assert!(ratio < 0.6, "clip_shadows=on should darken the cut face: on/off = {ratio}");
            assert!(chi2 < 39.25, "clip_shadows=on is not the vacuum image × exp(-σ/2): χ² = {chi2:.1}");
        }
    });
}

#[test]
fn the_denoisers_features_see_the_clipped_volume() {
    common::gpu_test(|ctx| {
        // Feature depth in a homogeneous absorber is where the transmittance from the kept
        // chord's entry t0 falls to 1/2: t0 + ln 2 / σ, exactly, for chords longer than that.
        // A ray whose kept chord is empty sees background (depth < 0).
        let cam = camera();
        let sigma = 6.0f64;
        let r = absorber(ctx, sigma as f32);
        let mut s = clipped_settings(absorbing(1.0, 0));
        s.denoise = vkengine::volume::render::denoise::DenoiseSettings { on: true, debug_flags: 0 };
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        render_frame(ctx, &r, &mut t, &cam, &s, 0).expect("render");
        let f = t.read_features(ctx).expect("features");
        let half = std::f64::consts::LN_2 / sigma;
        let (mut deep, mut empty, mut worst) = (0, 0, 0.0f64);
        for y in 0..SIZE[1] {
            for x in 0..SIZE[0] {
                let (o, d) = ray(&cam, x, y);
                let Some((t0, t1)) = clipped_chord(o, d) else { continue };
                let got = f64::from(f[(y * SIZE[0] + x) as usize].depth);
                if t1 <= t0 - 1e-3 {
                    empty += 1;
                    assert!(got < 0.0, "pixel ({x}, {y}): the kept chord is empty, feature depth {got}");
                } else if t1 - t0 > half + 0.05 {
                    deep += 1;
                    worst = worst.max((got - (t0 + half)).abs());
                    assert!(
                        (got - (t0 + half)).abs() < 2e-3,
                        "pixel ({x}, {y}): feature depth {got}, want {}",
                        t0 + half
                    );
                }
            }
        }
        eprintln!("clipped features: {deep} pixels at t0 + ln2/σ (worst {worst:e}), {empty} clipped away");
        assert!(deep > 300 && empty > 100, "too few pixels checked: {deep} deep, {empty} empty");
    });
}

/// The emissive slab's colour c (the transfer function's, as EAM emits it) and emission scale.
const EMISSIVE_COLOR: [f32; 3] = [0.9, 0.5, 0.1];
const EMISSION: f32 = 2.0;

/// Monte Carlo settings of an emissive medium lit by a constant environment only.
fn emissive(renderer: RendererKind, albedo: f32, env: [f32; 3], budget: u32, flight: bool) -> RenderSettings {
    RenderSettings {
        renderer,
        jitter: false,
        mc: McSettings {
            sun_dir: None,
            point_light: None,
            env_radiance: env,
            emission: EMISSION,
            albedo,
            max_events: 256,
            budget,
            env_flight: flight,
            paths_per_frame: 4,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// `compare_blocks` on one colour channel (it reads channel 0).
fn compare_channel(what: &str, imgs: &[Vec<[f32; 4]>], reference: &[f64], channel: usize) -> f64 {
    let moved: Vec<Vec<[f32; 4]>> =
        imgs.iter().map(|img| img.iter().map(|p| [p[channel], 0.0, 0.0, 0.0]).collect()).collect();
    compare_blocks(&format!("{what}, channel {channel}"), &moved, reference, SIZE, BLOCK, |_, _| 0.0)
}

#[test]
fn an_absorbing_emitting_box_glows_le_times_one_minus_exp_minus_optical_depth() {
    common::gpu_test(|ctx| {
        // Source σa·Le with Le = S·c. (a) Albedo 0: no scattering, σa = σt, and each camera ray
        // sees L = Le·(1 − e^(−σd)) + L_env·e^(−σd) (the closed form of the emission–absorption
        // equation in a homogeneous medium), in MCS and MCM, whole paths, bounded work and the
        // next-flight walk. (b) Albedo 1 in MCS without lights: only the unscattered emission
        // reaches the camera (MCS scatters once, and nothing lights the scattered paths), and
        // σa = σt·(1 − c): L = (1 − c)·Le·(1 − e^(−σd)). The residuals' spread gives each
        // block's standard error; no floor is credited (blocks off the box are exact).
        // Measured: with the emission counted twice in `collide` it fails (MCS, the first case
        // run, a block 0.017 ± 0.004 above, z = 4.2); without the (1 − albedo) factor (b) fails
        // (z = 5.2); with bounded work's collision adding no emission, its case fails (z = −6.9).
        let cam = camera();
        let sigma = 1.5f64;
        let r = VolumeRenderer::new(
            ctx,
            &procedural::homogeneous_box([8, 8, 8], 1.0).expect("volume"),
            &TransferFunction::constant(EMISSIVE_COLOR, sigma as f32),
        )
        .expect("renderer");
        let t = transmittance_reference(&cam, sigma);
        let env = [0.25f32; 3];
        let cases = [
            ("MCS", RendererKind::Mcs, 0u32, false),
            ("MCM", RendererKind::Mcm, 0, false),
            ("MCM bounded", RendererKind::Mcm, 256, false),
            ("MCM next-flight", RendererKind::Mcm, 0, true),
        ];
        for (what, kind, budget, flight) in cases {
            let imgs = runs(ctx, &r, &emissive(kind, 0.0, env, budget, flight), &cam, 6, 4, SIZE);
            for (ch, (&c, &e)) in EMISSIVE_COLOR.iter().zip(&env).enumerate() {
                let le = f64::from(EMISSION) * f64::from(c);
                let want: Vec<f64> = t.iter().map(|t| le * (1.0 - t) + f64::from(e) * t).collect();
                compare_channel(&format!("{what}, albedo 0"), &imgs, &want, ch);
            }
        }
        let imgs = runs(ctx, &r, &emissive(RendererKind::Mcs, 1.0, [0.0; 3], 0, false), &cam, 6, 4, SIZE);
        for (ch, &c) in EMISSIVE_COLOR.iter().enumerate() {
            let c = f64::from(c);
            let want: Vec<f64> = t.iter().map(|t| (1.0 - c) * f64::from(EMISSION) * c * (1.0 - t)).collect();
            compare_channel("MCS, albedo 1, direct emission", &imgs, &want, ch);
        }
    });
}

#[test]
fn an_emitting_cloud_in_an_environment_of_its_own_radiance_is_in_equilibrium() {
    common::gpu_test(|ctx| {
        // Kirchhoff: where the environment's radiance equals the medium's Le everywhere, L ≡ Le
        // solves the transfer equation (−σt Le + σa Le + σs Le = 0) for any albedo, phase
        // function and density: every pixel must be Le, through a scattering heterogeneous cloud
        // (a ramp of constant colour: Le constant, extinction varying). Paths scatter up to 32
        // times (whole paths must stay under llvmpipe's loop limit), with roulette: the truncation
        // leaves at most 0.85^32 = 0.5 % of a path's weight, and only to the rare paths that
        // collide 32 times in a cloud of optical depth below 8.
        // Measured: with the emission counted twice it fails (a block 0.29 ± 0.011 above Le,
        // z = 25); without the (1 − albedo) factor in σa, 0.95 ± 0.031 above (z = 30).
        let cam = camera();
        let tf = TransferFunction::ramp(0.05, 0.6, EMISSIVE_COLOR, 8.0);
        let r = VolumeRenderer::new(ctx, &procedural::cloud([32, 32, 32], 3).expect("volume"), &tf).expect("renderer");
        let le = EMISSIVE_COLOR.map(|c| EMISSION * c);
        // Bounded work is left out: its frame is the mean of the paths completed, a ratio
        // estimator biased by O(1/N) where path values vary with length (the slab test covers its
        // emission, with a fixed number of paths per frame).
        for (what, budget, flight) in [("whole paths", 0u32, false), ("next-flight", 0, true)] {
            let mut s = emissive(RendererKind::Mcm, 0.85, le, budget, flight);
            s.mc.max_events = 32;
            let imgs = runs(ctx, &r, &s, &cam, 6, 4, SIZE);
            for (ch, &l) in le.iter().enumerate() {
                let want = vec![f64::from(l); (SIZE[0] * SIZE[1]) as usize];
                compare_channel(&format!("equilibrium, {what}"), &imgs, &want, ch);
            }
        }
    });
}

#[test]
fn monte_carlo_emission_without_scattering_matches_eam() {
    common::gpu_test(|ctx| {
        // A heterogeneous, non-scattering emissive volume (albedo 0): MC's source σa·S·c with
        // σa = σt is the same emission–absorption integral ∫ T σt c ds that EAM sums (EAM's colour
        // c, ×S), an independent deterministic renderer. Both filter exactly; EAM marches 1/512
        // steps without early termination. EAM's own error is estimated block by block as its
        // difference from a march at twice the step and added to MC's standard error.
        // Measured with the emission counted twice: fails (a block 0.318 ± 0.008 above EAM).
        let cam = camera();
        let tf = TransferFunction::OneD {
            points: vec![
                vkengine::volume::optics::tf::TfPoint { value: 0.0, color: [0.0; 3], extinction: 0.0 },
                vkengine::volume::optics::tf::TfPoint { value: 0.5, color: [1.0, 0.4, 0.1], extinction: 4.0 },
                vkengine::volume::optics::tf::TfPoint { value: 1.0, color: [0.3, 0.6, 1.0], extinction: 10.0 },
            ],
        };
        let r = VolumeRenderer::new(ctx, &procedural::smooth_sphere([32, 32, 32], 0.5).expect("volume"), &tf)
            .expect("renderer");
        let eam = |step: f32| {
            let s = RenderSettings {
                renderer: RendererKind::Eam,
                jitter: false,
                exact_filter: true,
                step: Some(step),
                termination: 0.0,
                background: [0.0; 3],
                ..Default::default()
            };
            runs(ctx, &r, &s, &cam, 1, 1, SIZE).remove(0)
        };
        let (fine, coarse) = (eam(1.0 / 512.0), eam(1.0 / 256.0));
        let mut mc = emissive(RendererKind::Mcm, 0.0, [0.0; 3], 0, false);
        mc.mc.emission = 1.0;
        mc.mc.max_events = 1; // albedo 0: every path ends at its first collision
        mc.exact_filter = true;
        let imgs = runs(ctx, &r, &mc, &cam, 6, 6, SIZE);
        let mut worst = 0.0f64;
        for ch in 0..3 {
            for by in 0..SIZE[1] / BLOCK {
                for bx in 0..SIZE[0] / BLOCK {
                    // Residuals of every run's pixel against EAM's pixel: their spread is MC's
                    // noise alone (the pixels' different means cancel).
                    let px: Vec<usize> = (by * BLOCK..(by + 1) * BLOCK)
                        .flat_map(|y| (bx * BLOCK..(bx + 1) * BLOCK).map(move |x| (y * SIZE[0] + x) as usize))
                        .collect();
                    let fine = &fine;
                    let res: Vec<f64> = imgs
                        .iter()
                        .flat_map(|img| px.iter().map(move |&i| f64::from(img[i][ch]) - f64::from(fine[i][ch])))
                        .collect();
                    let n = res.len() as f64;
                    let m = res.iter().sum::<f64>() / n;
                    let var = res.iter().map(|e| (e - m).powi(2)).sum::<f64>() / (n - 1.0) / n;
                    let d = px.iter().map(|&i| f64::from(fine[i][ch]) - f64::from(coarse[i][ch])).sum::<f64>()
                        / px.len() as f64;
                    let se = (var + d * d).sqrt();
                    let z = m / se.max(1e-300);
                    worst = worst.max(z.abs());
                    assert!(m.abs() <= 4.0 * se, "channel {ch}, block ({bx}, {by}): MC − EAM = {m:.5} ± {se:.5}");
                }
            }
        }
        eprintln!("MC vs EAM, non-scattering emission: worst block |z| = {worst:.2}");
    });
}

/// A temperature grid of `kelvin` everywhere.
fn kelvin_box(dims: [u32; 3], kelvin: f32) -> vkengine::volume::data::Volume {
    let mut v = procedural::homogeneous_box(dims, 1.0).expect("grid");
    v.data.iter_mut().for_each(|t| *t = kelvin);
    v
}

#[test]
fn a_box_at_one_temperature_glows_with_its_blackbody_radiance() {
    common::gpu_test(|ctx| {
        // A temperature grid of T0 kelvin on the box's grid, range [2000, 4550] K: its 256 table
        // texels are 10 K apart, so 3000 K sits on texel 100 and the filtered lookups are exact.
        // Albedo 0, no light: L = S·B(T0)·(1 − e^(−σd)), B normalised to luminance 1 at 4550 K
        // (`blackbody::radiance`, checked against the Planckian locus in tests/blackbody.rs).
        // Below the range (1900 K) nothing is emitted: every pixel exactly 0. Bad grids are
        // refused with one message each.
        // Measured: with the temperature ignored (the hottest texel read) it fails (z = 5.2);
        // emitting below the range (the coldest texel), the 1900 K case fails (z = 5.3).
        use vkengine::volume::optics::blackbody;
        let cam = camera();
        let sigma = 1.5f64;
        let mut r = VolumeRenderer::new(
            ctx,
            &procedural::homogeneous_box([8, 8, 8], 1.0).expect("volume"),
            &TransferFunction::constant(EMISSIVE_COLOR, sigma as f32),
        )
        .expect("renderer");
        let t = transmittance_reference(&cam, sigma);
        let range = [2000.0f32, 4550.0];
        for (kelvin, budget) in [(3000.0f32, 0u32), (3000.0, 256), (1900.0, 0)] {
            r.set_temperature(ctx, Some((&kelvin_box([8, 8, 8], kelvin), range))).expect("temperature");
            let imgs = runs(ctx, &r, &emissive(RendererKind::Mcm, 0.0, [0.0; 3], budget, false), &cam, 6, 4, SIZE);
            let b = if kelvin >= range[0] { blackbody::radiance(f64::from(kelvin), 4550.0) } else { [0.0; 3] };
            for (ch, &b) in b.iter().enumerate() {
                let le = f64::from(EMISSION) * b;
                let want: Vec<f64> = t.iter().map(|t| le * (1.0 - t)).collect();
                compare_channel(&format!("{kelvin} K, budget {budget}"), &imgs, &want, ch);
            }
        }
        // EAM with the grid: its colour is S·B(T0), so L = S·B(T0)·(1 − e^(−σd)), the
        // transmittance within 1e-5 (f32 ray geometry: entry and exit in f32 move a chord by a
        // few 1e-6 of the box, as in the clipped-box test), and exactly 0 below the range. With emission 0 the grid changes nothing, bit for bit.
        // Measured: with EAM's constant left off it fails (the colour stays the transfer
        // function's: pixel 792, red 0.0313 against 0.0067).
        let eam = |emission: f32| RenderSettings {
            renderer: RendererKind::Eam,
            jitter: false,
            exact_filter: true,
            termination: 0.0,
            background: [0.0; 3],
            mc: McSettings { emission, ..Default::default() },
            ..Default::default()
        };
        let mut worst = 0.0f64;
        for kelvin in [3000.0f32, 1900.0] {
            r.set_temperature(ctx, Some((&kelvin_box([8, 8, 8], kelvin), range))).expect("temperature");
            let img = runs(ctx, &r, &eam(EMISSION), &cam, 1, 1, SIZE).remove(0);
            let b = if kelvin >= range[0] { blackbody::radiance(f64::from(kelvin), 4550.0) } else { [0.0; 3] };
            for (i, (px, t)) in img.iter().zip(&t).enumerate() {
                for ch in 0..3 {
                    let want = f64::from(EMISSION) * b[ch] * (1.0 - t);
                    let got = f64::from(px[ch]);
                    let le = f64::from(EMISSION) * b[ch];
                    let err = (got - want).abs();
                    worst = worst.max(err / le.max(1e-30));
                    assert!(err <= 1e-5 * le, "EAM {kelvin} K, pixel {i}, channel {ch}: {got} against {want}");
                }
            }
        }
        eprintln!("EAM with a temperature grid against S·B(T0)·(1 − e^(−σd)): worst error {worst:.2e} of S·B(T0)");
        let plain = runs(ctx, &r, &eam(0.0), &cam, 1, 1, SIZE).remove(0);
        r.set_temperature(ctx, None).expect("no grid");
        let without = runs(ctx, &r, &eam(0.0), &cam, 1, 1, SIZE).remove(0);
        assert!(plain == without, "emission 0: a temperature grid must not change EAM");
        assert!(plain.iter().any(|p| p[0] > 0.1), "EAM image is empty");
        let mut msg = |grid: &vkengine::volume::data::Volume, range| match r.set_temperature(ctx, Some((grid, range))) {
            Err(vkengine::error::Error::Input(m)) => m,
            other => panic!("expected an input error, got {:?}", other.map(|_| ())),
        };
        let ok = kelvin_box([8, 8, 8], 1500.0);
        assert!(msg(&ok, [-1.0, 3000.0]).contains("temperature_range"));
        assert!(msg(&ok, [3000.0, 1000.0]).contains("temperature_range"));
        let other = kelvin_box([8, 8, 4], 1500.0);
        assert!(msg(&other, range).contains("[8, 8, 4]"));
        let mut nan = ok.clone();
        nan.data[3] = f32::NAN;
        assert!(msg(&nan, range).contains("voxel 3"));
    });
}
