//! Participating media in the mesh renderer (lavapipe, validation + sync validation): zero
//! density changes no pixel, the fog pass exists only when asked for, sky seen through fog matches
//! the closed form T·L_sky + α(L_amb + p_HG(μ)·E)(1 − T) at any step count, sun shadow maps
//! block the in-scattered sun, a bounded box matches an independent f64 quadrature, the LPV's
//! share of the in-scattering is the read-back grid's SH convolved with HG, and absurd settings
//! are errors naming the key.

mod common;

use common::scenes::{quad, scene, view_of};

use common::scenes::{builtin_scene, mesh_settings};
use glam::{Mat4, Vec3};
use std::collections::BTreeMap;
use vkengine::mesh::fog::{FogBounds, FogSettings};
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::scene::{Camera, Light, Scene};
use vkengine::vk::Context;

struct Frame {
    hdr: Vec<[f32; 4]>,
    passes: Vec<String>,
}

fn render(ctx: &Context, sc: &Scene, size: [u32; 2], settings: &MeshSettings, rsm: u32) -> Frame {
    let gpu = GpuScene::upload(ctx, sc).expect("upload");
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let mut targets = MeshTargets::new(ctx, size, rsm).expect("targets");
    let view = view_of(&sc.camera);
    let run = render_frame(ctx, &renderer, &gpu, &mut targets, &view, settings).expect("render");
    Frame { hdr: targets.read_hdr(ctx).expect("readback"), passes: run.timings.into_iter().map(|t| t.name).collect() }
}

/// Textbook Henyey–Greenstein (f64, written independently of the shaders' stable form).
fn hg(g: f64, mu: f64) -> f64 {
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5))
}

/// World-space ray of pixel (x, y) as the renderer casts it: from the eye to the far plane.
fn pixel_ray(view_proj: Mat4, eye: Vec3, size: [u32; 2], x: u32, y: u32) -> (Vec3, f64) {
    let ndc =
        Vec3::new((x as f32 + 0.5) / size[0] as f32 * 2.0 - 1.0, (y as f32 + 0.5) / size[1] as f32 * 2.0 - 1.0, 1.0);
    let far = view_proj.inverse().project_point3(ndc);
    let d = far - eye;
    (d.normalize(), f64::from(d.length()))
}

/// Open sky: the only mesh is a small quad behind the camera (the renderer needs geometry), the
/// camera looks along -z, the sun shines from ahead and above so forward scattering shows.
fn sky_scene(extra: Vec<vkengine::scene::Mesh>) -> (Scene, Vec3) {
    let mut meshes = vec![quad(Vec3::new(0.0, 0.0, 5.0), Vec3::X * 0.1, Vec3::Y * 0.1, 0)];
    meshes.extend(extra);
    let camera = Camera {
        position: [0.0, 0.0, 0.0],
        target: [0.0, 0.0, -1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 40.0,
        near: 0.1,
        far: 30.0,
    };
    let to_sun = Vec3::new(0.2, 0.3, -1.0).normalize();
    let sun = Light::Directional { direction: (-to_sun).into(), color: [1.0; 3], intensity: 2.0 };
    (scene(meshes, vec![sun], camera), to_sun)
}

fn fog(density: f32, albedo: f32, g: f32, steps: u32, bounds: FogBounds) -> FogSettings {
    FogSettings { enabled: true, density, albedo, g, steps, bounds }
}

#[test]
fn zero_density_fog_changes_no_pixel() {
    common::gpu_test(|ctx| {
        // The Cornell box with its spot light and the LPV (both in-scatter paths run), and the open
        // sky with a sun: σt = 0 gives T = 1 and σs = 0 exactly, so the images must be identical.
        let size = [64, 64];
        let cornell = builtin_scene("cornell").expect("cornell");
        let mut base = MeshSettings { shadow_tile: 256, ..Default::default() };
        base.lpv.enabled = true;
        base.lpv.size = 16;
        let (sky, _) = sky_scene(vec![]);
        let sky_base = MeshSettings { shadow_tile: 256, ..Default::default() };
        for (name, sc, s, rsm) in [("cornell + LPV", &cornell, base, 64), ("sky + sun", &sky, sky_base, 0)] {
            let off = render(ctx, sc, size, &s, rsm);
            let zero = MeshSettings { fog: fog(0.0, 0.9, 0.5, 16, FogBounds::Unbounded), ..s };
            let on = render(ctx, sc, size, &zero, rsm);
            assert!(on.passes.iter().any(|p| p == "fog"), "{name}: the fog pass did not run");
            let differ = off.hdr.iter().zip(&on.hdr).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "{name}: {differ} pixels changed with zero density");
        }
    });
}

#[test]
fn fog_adds_exactly_one_pass_and_none_when_off() {
    common::gpu_test(|ctx| {
        let cornell = builtin_scene("cornell").expect("cornell");
        for lpv in [false, true] {
            let mut s = MeshSettings { shadow_tile: 128, ..Default::default() };
            s.lpv.enabled = lpv;
            s.lpv.size = 16;
            let rsm = if lpv { 64 } else { 0 };
            let off = render(ctx, &cornell, [32, 32], &s, rsm);
            assert!(!off.passes.iter().any(|p| p.contains("fog")), "fog off, yet: {:?}", off.passes);
            let on = render(
                ctx,
                &cornell,
                [32, 32],
                &MeshSettings { fog: fog(2.0, 0.9, 0.3, 8, FogBounds::Scene), ..s },
                rsm,
            );
            let mut expected = off.passes.clone();
            // After the lighting, and its cascade blend where the LPV is on.
            let lit = |p: &String| p == "lighting" || p == "cascade blend";
            let at = expected.iter().rposition(lit).expect("lighting pass") + 1;
            expected.insert(at, "fog".into());
            assert_eq!(on.passes, expected, "lpv={lpv}: fog must add exactly one pass, after lighting");
            assert!(on.hdr.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)), "lpv={lpv}: bad radiance");
        }
    });
}

#[test]
fn sky_through_fog_matches_the_closed_form_at_any_step_count() {
    common::gpu_test(|ctx| {
        // Unbounded fog, no shadow cascades: along every sky ray the source is constant, so
        // L = T·L_sky + α(L_amb + p(μ)E)(1 − T), T = e^{-σt d}, d = eye → far plane. Exact per
        // segment integration gives this for one segment as for 64; a Riemann sum would not.
        let (sc, to_sun) = sky_scene(vec![]);
        let size = [48, 32];
        let (sigma, albedo, g, e, sky, amb) = (0.06f64, 0.8f64, 0.6f64, 2.0f64, 0.3f64, 0.05f64);
        let view = view_of(&sc.camera);
        let vp = view.view_proj(size[0] as f32 / size[1] as f32);
        let eye = Vec3::from(view.position);
        for steps in [1u32, 7, 64] {
            let s = MeshSettings {
                cascades: 0,
                sky: [sky as f32; 3],
                ambient: [amb as f32; 3],
                fog: fog(sigma as f32, albedo as f32, g as f32, steps, FogBounds::Unbounded),
                ..Default::default()
            };
            let img = render(ctx, &sc, size, &s, 0).hdr;
            let mut worst = 0.0f64;
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let (d, dist) = pixel_ray(vp, eye, size, x, y);
                    let t = (-sigma * dist).exp();
                    let mu = f64::from(d.dot(to_sun));
                    let want = sky * t + albedo * (amb + hg(g, mu) * e) * (1.0 - t);
                    let got = f64::from(img[(y * size[0] + x) as usize][0]);
                    worst = worst.max((got - want).abs() / want);
                }
            }
            eprintln!("{steps} segments: worst relative error {worst:.2e}");
            assert!(worst < 1e-3, "{steps} segments: relative error {worst} against the closed form");
        }
    });
}

#[test]
fn sun_shadow_maps_block_the_in_scattered_sun() {
    common::gpu_test(|ctx| {
        // A roof far above the view (never seen, y = 50 while the highest visible point is ~11 m)
        // shades every fog point from a nearly overhead sun: only sky and ambient remain. Without
        // cascades (no shadow test) the same frame has the full sun term: the control.
        let roof = quad(Vec3::new(0.0, 50.0, -10.0), Vec3::Z * 400.0, Vec3::X * 400.0, 0);
        let (mut sc, _) = sky_scene(vec![roof]);
        let to_sun = Vec3::new(0.1, 1.0, -0.2).normalize();
        sc.lights = vec![Light::Directional { direction: (-to_sun).into(), color: [1.0; 3], intensity: 2.0 }];
        let size = [48, 32];
        let (sigma, albedo, g, e, sky, amb) = (0.06f64, 0.8f64, 0.3f64, 2.0f64, 0.3f64, 0.05f64);
        let view = view_of(&sc.camera);
        let vp = view.view_proj(size[0] as f32 / size[1] as f32);
        let eye = Vec3::from(view.position);
        for cascades in [0u32, 3] {
            let s = MeshSettings {
                cascades,
                shadow_distance: 30.0,
                shadow_tile: 512,
                sky: [sky as f32; 3],
                ambient: [amb as f32; 3],
                fog: fog(sigma as f32, albedo as f32, g as f32, 32, FogBounds::Unbounded),
                ..Default::default()
            };
            let img = render(ctx, &sc, size, &s, 0).hdr;
            let mut worst = 0.0f64;
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let (d, dist) = pixel_ray(vp, eye, size, x, y);
                    let t = (-sigma * dist).exp();
                    let sun = albedo * hg(g, f64::from(d.dot(to_sun))) * e * (1.0 - t);
                    let rest = sky * t + albedo * amb * (1.0 - t);
                    let got = f64::from(img[(y * size[0] + x) as usize][0]);
                    // Fraction of the unshadowed sun term present in the pixel.
                    let seen = (got - rest) / sun;
                    let want = if cascades == 0 { 1.0 } else { 0.0 };
                    worst = worst.max((seen - want).abs());
                }
            }
            eprintln!("cascades {cascades}: worst deviation of the sun fraction {worst:.2e}");
            assert!(worst < 2e-3, "cascades={cascades}: sun fraction off by {worst}");
        }
    });
}

#[test]
fn bounded_fog_matches_an_f64_quadrature() {
    common::gpu_test(|ctx| {
        // A 2 m fog box seen from outside, lit by an unshadowed sun that the box itself attenuates:
        // the source varies along each ray (e^{-σt ℓ(x)}, ℓ the distance to the box's exit toward
        // the sun), so only the midpoint source is approximate. Reference: 20000 midpoint steps in
        // f64 of σs e^{-σt s} p(μ) E e^{-σt ℓ} plus the sky behind, T·L_sky.
        let (mut sc, _) = sky_scene(vec![]);
        sc.camera.position = [0.3, 0.2, 5.0];
        sc.camera.target = [0.0, 0.0, 0.0];
        let to_sun = Vec3::new(0.4, 0.8, 0.45).normalize();
        sc.lights = vec![Light::Directional { direction: (-to_sun).into(), color: [1.0; 3], intensity: 3.0 }];
        let size = [40, 40];
        let (sigma, albedo, g, e, sky) = (1.2f64, 0.8f64, 0.3f64, 3.0f64, 0.2f64);
        let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let s = MeshSettings {
            cascades: 0,
            sky: [sky as f32; 3],
            ambient: [0.0; 3],
            fog: fog(sigma as f32, albedo as f32, g as f32, 64, FogBounds::Box { min: lo.into(), max: hi.into() }),
            ..Default::default()
        };
        let img = render(ctx, &sc, size, &s, 0).hdr;
        let view = view_of(&sc.camera);
        let vp = view.view_proj(1.0);
        let eye = Vec3::from(view.position).as_dvec3();
        let slab = |o: glam::DVec3, d: glam::DVec3| {
            let (a, b) = ((lo.as_dvec3() - o) / d, (hi.as_dvec3() - o) / d);
            (a.min(b).max_element(), a.max(b).min_element())
        };
        let (mut worst, mut inside) = (0.0f64, 0);
        for y in 0..size[1] {
            for x in 0..size[0] {
                let (d, _) = pixel_ray(vp, Vec3::from(view.position), size, x, y);
                let d = d.as_dvec3();
                let (t0, t1) = slab(eye, d);
                let t0 = t0.max(0.0);
                let got = f64::from(img[(y * size[0] + x) as usize][0]);
                let want = if t1 > t0 {
                    inside += 1;
                    let n = 20000;
                    let dt = (t1 - t0) / n as f64;
                    let p = hg(g, d.dot(to_sun.as_dvec3()));
                    let mut sum = 0.0;
                    for i in 0..n {
                        let s = (i as f64 + 0.5) * dt;
                        let xi = eye + d * (t0 + s);
                        let exit = slab(xi, to_sun.as_dvec3()).1.max(0.0);
                        sum += albedo * sigma * (-sigma * s).exp() * p * e * (-sigma * exit).exp() * dt;
                    }
                    sky * (-sigma * (t1 - t0)).exp() + sum
                } else {
                    sky
                };
                worst = worst.max((got - want).abs() / want);
            }
        }
        eprintln!("{inside} pixels see the box; worst relative error {worst:.2e}");
        assert!(inside > 300 && inside < 1200, "the box should fill part of the view ({inside} pixels)");
        assert!(worst < 5e-3, "bounded fog vs f64 quadrature: relative error {worst}");
    });
}

/// The LPV's in-scattered radiance (red) at x toward propagation direction w for HG g, from the
/// read-back accumulated grid of one cascade: trilinear over cell centres (clamped to them, as
/// the shader's sampler coordinates are), SH band 1 scaled by g, over the cell's cross-section.
fn lpv_radiance(
    grid: &vkengine::lpv::grid::HostGrid,
    c: &vkengine::lpv::grid::Cascade,
    x: Vec3,
    w: Vec3,
    g: f64,
) -> f64 {
    let (y0, y1) = (0.282_094_791_77f64, 0.488_602_511_9f64);
    let w = w.as_dvec3();
    let basis = [y0, -y1 * w.y * g, y1 * w.z * g, -y1 * w.x * g];
    let n = c.n as f64;
    let s = f64::from(c.cell);
    let q = (x.as_dvec3() - Vec3::from(c.origin).as_dvec3()) / s;
    if q.min_element() < 0.0 || q.max_element() > n {
        return 0.0;
    }
    let q = q.clamp(glam::DVec3::splat(0.5), glam::DVec3::splat(n - 0.5));
    let b = (q - 0.5).floor();
    let f = q - 0.5 - b;
    let mut sum = 0.0;
    for corner in 0..8 {
        let o = glam::DVec3::new((corner & 1) as f64, ((corner >> 1) & 1) as f64, ((corner >> 2) & 1) as f64);
        let cell = (b + o).clamp(glam::DVec3::ZERO, glam::DVec3::splat(n - 1.0));
        let idx = (cell.x + n * (cell.y + n * cell.z)) as usize;
        let wgt = (0..3).map(|k| if o[k] == 1.0 { f[k] } else { 1.0 - f[k] }).product::<f64>();
        let co = grid.coeffs(0, idx);
        sum += wgt * (0..4).map(|k| f64::from(co[k]) * basis[k]).sum::<f64>();
    }
    sum.max(0.0) / (s * s)
}

#[test]
fn lpv_in_scattering_is_the_grids_sh_convolved_with_the_phase_function() {
    common::gpu_test(|ctx| {
        // A sunlit 1 m ground quad under a fog box; the camera looks level, so the upper half of
        // the image is sky seen through fog. There the fog with and without the LPV differ only
        // by the LPV's in-scattering (same sun, shadows, sky): Σ T_i w_i σs L_lpv(x_i), with
        // L_lpv from the read-back grid in direction -d (toward the camera). g = 0 checks band 0
        // (the isotropic mean), g = 0.6 also band 1 and its direction.
        let camera = Camera {
            position: [0.0, 0.6, 3.0],
            target: [0.0, 0.6, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 50.0,
            near: 0.05,
            far: 20.0,
        };
        let sun = Light::Directional { direction: [0.0, -1.0, 0.0], color: [1.0; 3], intensity: std::f32::consts::PI };
        let mut sc = scene(vec![quad(Vec3::ZERO, Vec3::Z * 0.5, Vec3::X * 0.5, 0)], vec![sun], camera);
        sc.bounds.min = [-2.0, -2.0, -2.0];
        sc.bounds.max = [2.0, 2.0, 2.0];
        let size = [48, 48];
        let (lo, hi) = (Vec3::new(-1.5, 0.05, -1.5), Vec3::new(1.5, 1.8, 1.5));
        let (sigma, albedo, steps) = (0.8f64, 0.9f64, 16u32);
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let view = view_of(&camera);
        let vp = view.view_proj(1.0);
        let eye = Vec3::from(view.position);
        for g in [0.0f64, 0.6] {
            let mut s = MeshSettings {
                shadow_tile: 256,
                ambient: [0.0; 3],
                sky: [0.0; 3],
                fog: fog(
                    sigma as f32,
                    albedo as f32,
                    g as f32,
                    steps,
                    FogBounds::Box { min: lo.into(), max: hi.into() },
                ),
                ..Default::default()
            };
            s.lpv.size = 16;
            let without = render(ctx, &sc, size, &s, 256).hdr;
            s.lpv.enabled = true;
            let mut targets = MeshTargets::new(ctx, size, 256).expect("targets");
            targets.enable_lpv_readback(ctx, &s.lpv).expect("readback");
            render_frame(ctx, &renderer, &gpu, &mut targets, &view, &s).expect("render");
            let with = targets.read_hdr(ctx).expect("readback");
            let [_, accum] = targets.lpv_grids().expect("grids");
            let cascade = targets.lpv_cascades[0];
            assert_eq!(targets.lpv_cascades.len(), 1, "one cascade holds the scene");
            let (mut worst, mut total, mut count) = (0.0f64, 0.0f64, 0);
            let mut rows = Vec::new();
            for y in 0..size[1] / 2 - 2 {
                for x in 0..size[0] {
                    let (d, dist) = pixel_ray(vp, eye, size, x, y);
                    assert!(d.y > 0.0, "pixel ({x}, {y}) should look up into the sky");
                    let (a, b) = ((lo - eye) / d, (hi - eye) / d);
                    let (t0, t1) = (a.min(b).max_element().max(0.0), a.max(b).min_element().min(dist as f32));
                    let got = f64::from(with[(y * size[0] + x) as usize][0] - without[(y * size[0] + x) as usize][0]);
                    let mut want = 0.0;
                    if t1 > t0 {
                        let dt = f64::from(t1 - t0) / f64::from(steps);
                        let seg_t = (-sigma * dt).exp();
                        let seg_w = (1.0 - seg_t) / sigma;
                        let mut t = 1.0;
                        for i in 0..steps {
                            let xi = eye + d * (t0 + (i as f32 + 0.5) * dt as f32);
                            want += t * seg_w * albedo * sigma * lpv_radiance(&accum, &cascade, xi, -d, g);
                            t *= seg_t;
                        }
                    }
                    rows.push((got, want));
                    total += want;
                    count += 1;
                }
            }
            let mean = total / count as f64;
            for (got, want) in rows {
                worst = worst.max((got - want).abs() / mean);
            }
            eprintln!("g = {g}: mean LPV in-scatter {mean:.3e}, worst deviation {worst:.2e} of the mean");
            assert!(mean > 1e-4, "g = {g}: the LPV should light the fog ({mean})");
            assert!(worst < 0.02, "g = {g}: LPV in-scattering off by {worst} of its mean");
        }
    });
}

#[test]
fn absurd_fog_settings_are_errors_naming_the_key() {
    let file = BTreeMap::new();
    let cases = [
        ("fog_density", "-1"),
        ("fog_density", "NaN"),
        ("fog_density", "inf"),
        ("fog_density", "1e9"),
        ("fog_albedo", "1.5"),
        ("fog_albedo", "NaN"),
        ("fog_g", "1"),
        ("fog_g", "NaN"),
        ("fog_steps", "0"),
        ("fog_steps", "100000"),
        ("fog_steps", "-3"),
        ("fog_bounds", "1,2,3"),
        ("fog_bounds", "0,0,0,0,1,1"),
        ("fog_bounds", "0,0,0,NaN,1,1"),
        ("fog_bounds", "everywhere"),
    ];
    for (k, v) in cases {
        // Fog off or on, a bad value is still bad input.
        for on in ["0", "1"] {
            let sets = vec![("fog".to_string(), on.to_string()), (k.to_string(), v.to_string())];
            match mesh_settings(&file, &sets) {
                Ok(_) => panic!("{k}={v} (fog={on}) was accepted"),
                Err(e) => assert!(e.to_string().contains(k), "{k}={v}: message does not name the key: {e}"),
            }
        }
    }
    let ok = vec![
        ("fog".to_string(), "1".to_string()),
        ("fog_density".to_string(), "0".to_string()),
        ("fog_bounds".to_string(), "-1,-1,-1,1,1,1".to_string()),
    ];
    let (s, _) = mesh_settings(&file, &ok).expect("valid fog settings");
    assert!(s.fog.enabled && s.fog.bounds == FogBounds::Box { min: [-1.0; 3], max: [1.0; 3] });
}
