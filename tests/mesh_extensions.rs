//! The mesh renderer's LPV-issue extensions against exact or analytic answers (lavapipe,
//! validation + sync validation): soft shadows (PCSS), screen-space sun rays and glossy
//! reflections from the LPV. Each switch changes the frame graph by exactly its own passes;
//! PCSS with a point light equals PCF, leaves fully lit ground alone and widens a shadow edge
//! by the analytic penumbra; sun rays add exactly the decayed sum of sky samples and nothing
//! when no sky is seen or the intensity is 0; glossy adds nothing on a non-specular material
//! and, on a specular one, only adds, bounded by ks times the brightest radiance in the LPV.

mod common;

use common::scenes::{boxed, camera, quad, scene, view_of};

use glam::{Vec3, Vec4Swizzles};
use vkengine::graph::execute::GraphRun;
use vkengine::lpv::settings::LpvSettings;
use vkengine::lpv::sh;
use vkengine::mesh::camera::View;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::mesh::shadow;
use vkengine::scene::{Camera, Light, Scene};
use vkengine::vk::Context;

/// Sun travelling along (1, −2, 0) with irradiance π: lit ground has radiance ρ·E·cosθ/π =
/// 0.5·2/√5 (ρ = 0.5), the box at height 2..2.5 over x, z ∈ [−1, 1] shades x ∈ [0, 2.25].
const SUN_DIR: [f32; 3] = [1.0, -2.0, 0.0];

fn sun() -> Light {
    Light::Directional { direction: SUN_DIR, color: [1.0; 3], intensity: std::f32::consts::PI }
}

fn lit_ground() -> f32 {
    0.5 * 2.0 / 5f32.sqrt()
}

/// A 12 m ground quad and a box floating over it.
fn box_over_ground(lights: Vec<Light>, camera: Camera) -> Scene {
    let mut meshes = vec![quad(Vec3::ZERO, Vec3::Z * 6.0, Vec3::X * 6.0, 0)];
    meshes.extend(boxed(Vec3::new(-1.0, 2.0, -1.0), Vec3::new(1.0, 2.5, 1.0), 0));
    scene(meshes, lights, camera)
}

/// Looking straight down on the box and its shadow (the sun is behind this camera).
fn top_camera() -> Camera {
    camera([0.0, 12.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 50.0)
}

/// Looking along −x, slightly down, at the box, its shadow and the sky beyond the ground's edge;
/// the sun (towards (−1, 2, 0)) is in front of this camera, high above the view.
fn side_camera() -> Camera {
    camera([8.0, 4.0, 0.0], [-2.0, 1.5, 0.0], [0.0, 1.0, 0.0], 50.0)
}

struct Frame {
    img: Vec<[f32; 4]>,
    passes: Vec<String>,
    targets: MeshTargets,
}

fn render(ctx: &Context, sc: &Scene, view: &View, size: [u32; 2], rsm: u32, s: &MeshSettings) -> Frame {
    let gpu = GpuScene::upload(ctx, sc).expect("upload");
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let mut targets = MeshTargets::new(ctx, size, rsm).expect("targets");
    if s.lpv.enabled {
        targets.enable_lpv_readback(ctx, &s.lpv).expect("lpv readback");
    }
    let run: GraphRun = render_frame(ctx, &renderer, &gpu, &mut targets, view, s).expect("render");
    let img = targets.read_hdr(ctx).expect("readback");
    assert!(img.iter().all(|p| p.iter().all(|v| v.is_finite())), "non-finite radiance");
    Frame { img, passes: run.timings.iter().map(|t| t.name.clone()).collect(), targets }
}

/// The pixel where world point `p` lands.
fn pixel_of(size: [u32; 2], view: &View, p: Vec3) -> usize {
    let c = view.view_proj(size[0] as f32 / size[1] as f32) * p.extend(1.0);
    let ndc = c.xyz() / c.w;
    let px = (((ndc.x * 0.5 + 0.5) * size[0] as f32) as u32).min(size[0] - 1);
    let py = (((ndc.y * 0.5 + 0.5) * size[1] as f32) as u32).min(size[1] - 1);
    (py * size[0] + px) as usize
}

fn count_different(a: &[[f32; 4]], b: &[[f32; 4]]) -> usize {
    a.iter().zip(b).filter(|(x, y)| x != y).count()
}

fn energy(img: &[[f32; 4]]) -> f64 {
    img.iter().map(|p| f64::from(p[0] + p[1] + p[2])).sum()
}

fn lpv_on() -> LpvSettings {
    // Reuse off: every frame runs the same LPV passes, so pass lists compare one to one.
    LpvSettings { enabled: true, size: 16, steps: 4, reuse: false, ..Default::default() }
}

#[test]
fn each_switch_changes_the_frame_graph_by_exactly_its_passes() {
    common::gpu_test(|ctx| {
        let cam = side_camera();
        let mut sc = box_over_ground(vec![sun()], cam);
        sc.materials[0].specular = [0.5; 3];
        sc.materials[0].shininess = 32.0;
        let view = view_of(&cam);
        let base = MeshSettings { shadow_tile: 256, lpv: lpv_on(), ..Default::default() };
        let off = render(ctx, &sc, &view, [96, 64], 64, &base);
        assert!(off.passes.iter().any(|p| p.starts_with("lpv")), "the LPV should run: {:?}", off.passes);

        let soft = render(ctx, &sc, &view, [96, 64], 64, &MeshSettings { soft_shadows: true, sun_angle: 3.0, ..base });
        assert_eq!(soft.passes, off.passes, "soft shadows must add no pass");
        assert!(count_different(&soft.img, &off.img) > 0, "soft shadows changed no pixel");

        let glossy = render(ctx, &sc, &view, [96, 64], 64, &MeshSettings { lpv_glossy: true, ..base });
        assert_eq!(glossy.passes, off.passes, "glossy reflections must add no pass");
        assert!(count_different(&glossy.img, &off.img) > 0, "glossy reflections changed no pixel");

        let rays = render(ctx, &sc, &view, [96, 64], 64, &MeshSettings { sun_rays: true, ..base });
        let mut want = off.passes.clone();
        let at = want.iter().position(|p| p == "tonemap").expect("a tonemap pass");
        want.insert(at, "sun rays".into());
        assert_eq!(rays.passes, want, "sun rays must add exactly one pass, between lighting and tone mapping");
        assert!(count_different(&rays.img, &off.img) > 0, "sun rays changed no pixel");

        // Behind the camera the sun has no meaningful screen position: no pass at all.
        let top = top_camera();
        let behind = render(
            ctx,
            &box_over_ground(vec![sun()], top),
            &view_of(&top),
            [32, 32],
            0,
            &MeshSettings { sun_rays: true, shadow_tile: 128, ..Default::default() },
        );
        assert!(!behind.passes.iter().any(|p| p == "sun rays"), "sun behind the camera: {:?}", behind.passes);
    });
}

#[test]
fn pcss_with_a_point_light_equals_pcf() {
    common::gpu_test(|ctx| {
        // Sun and a spot, both casting the box's shadow onto the ground; PCF radius 2.
        let spot = Light::Spot {
            position: [-2.0, 6.0, 1.0],
            direction: [0.3, -1.0, -0.1],
            color: [1.0, 0.8, 0.6],
            intensity: 20.0,
            inner_angle: 0.5,
            outer_angle: 0.7,
            range: 20.0,
        };
        let cam = top_camera();
        let sc = box_over_ground(vec![sun(), spot], cam);
        let view = view_of(&cam);
        let pcf = MeshSettings { ambient: [0.0; 3], shadow_tile: 512, pcf_radius: 2, ..Default::default() };
        let hard = render(ctx, &sc, &view, [128, 128], 0, &pcf);
        let point = MeshSettings { soft_shadows: true, sun_angle: 0.0, spot_radius: 0.0, ..pcf };
        let soft = render(ctx, &sc, &view, [128, 128], 0, &point);
        // Same taps and weights; the overlaps are computed as differences of box edges instead
        // of 1 − f, so single-precision rounding may differ: 1e-5 of the brightest pixel.
        let peak = hard.img.iter().fold(0.0f32, |m, p| m.max(p[0]));
        let worst = hard.img.iter().zip(&soft.img).map(|(a, b)| (a[0] - b[0]).abs()).fold(0.0f32, f32::max);
        assert!(peak > 0.1, "the scene is not lit");
        assert!(worst <= 1e-5 * peak, "PCSS with a point light differs from PCF by {worst} (peak {peak})");
        // The scene has shadows to compare: some pixels are at most a tenth of the lit ground.
        assert!(hard.img.iter().filter(|p| p[0] < 0.1 * lit_ground()).count() > 100, "no shadow in view");
    });
}

#[test]
fn pcss_leaves_fully_lit_ground_unchanged_and_softens_the_edges() {
    common::gpu_test(|ctx| {
        let cam = top_camera();
        let sc = box_over_ground(vec![sun()], cam);
        let view = view_of(&cam);
        let size = [160, 160];
        let pcf = MeshSettings {
            ambient: [0.0; 3],
            shadow_tile: 512,
            cascades: 2,
            shadow_distance: 15.0,
            ..Default::default()
        };
        let hard = render(ctx, &sc, &view, size, 0, &pcf);
        let soft = render(ctx, &sc, &view, size, 0, &MeshSettings { soft_shadows: true, sun_angle: 3.0, ..pcf });
        // At least a metre from the shadow (x ∈ [0, 2.25], |z| ≤ 1.25): no blocker anywhere in
        // reach, so bit for bit the same radiance.
        for p in
            [Vec3::new(-2.5, 0.0, 0.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 3.5), Vec3::new(0.5, 0.0, -4.0)]
        {
            let i = pixel_of(size, &view, p);
            assert!((hard.img[i][0] - lit_ground()).abs() < 0.02 * lit_ground(), "ground at {p} should be lit");
            assert_eq!(hard.img[i], soft.img[i], "fully lit ground at {p} changed under PCSS");
        }
        assert!(count_different(&hard.img, &soft.img) > 0, "PCSS changed nothing");
    });
}

/// Visibility along the ground line z = 0 across the shadow edge at x = 2.25 (cast by the box
/// top's edge at x = 1, y = 2.5), seen from straight above: (x, radiance / lit radiance).
fn edge_profile(ctx: &Context, sun_angle: f32) -> (Vec<(f32, f32)>, f32) {
    let cam = camera([2.25, 12.0, 0.0], [2.25, 0.0, 0.0], [0.0, 0.0, -1.0], 10.0);
    let sc = box_over_ground(vec![sun()], cam);
    let view = view_of(&cam);
    let size = [256, 256];
    let s = MeshSettings {
        ambient: [0.0; 3],
        shadow_tile: 1024,
        cascades: 1,
        shadow_distance: 13.0,
        pcf_radius: 0,
        soft_shadows: true,
        sun_angle,
        ..Default::default()
    };
    let f = render(ctx, &sc, &view, size, 0, &s);
    let profile = (0..=200)
        .map(|i| {
            let x = 1.6 + 1.3 * i as f32 / 200.0;
            (x, f.img[pixel_of(size, &view, Vec3::new(x, 0.0, 0.0))][0] / lit_ground())
        })
        .collect();
    // The texel of the one cascade, exactly as the renderer fits it.
    let dir = Vec3::from(SUN_DIR).normalize();
    let far = shadow::cascade_splits(view.near, s.shadow_distance.min(view.far), 1, s.cascade_lambda)[0];
    let bounds = [Vec3::from(sc.bounds.min), Vec3::from(sc.bounds.max)];
    let texel = shadow::fit_cascade(&view, 1.0, view.near, far, dir, bounds, s.shadow_tile).texel;
    (profile, texel)
}

/// First x where the profile rises through `level` (linear between samples).
fn crossing(profile: &[(f32, f32)], level: f32) -> f32 {
    profile
        .windows(2)
        .find(|w| w[0].1 < level && w[1].1 >= level)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (level - w[0].1) / (w[1].1 - w[0].1))
        .unwrap_or(f32::NAN)
}

#[test]
fn pcss_penumbra_width_matches_the_light_size_and_blocker_distance() {
    common::gpu_test(|ctx| {
        // PCSS filters the hard shadow with a box of half-width (d_receiver − d_blocker)·tan(θ/2)
        // + half a texel, measured across the light: the visibility ramps linearly over the full
        // box, so it rises from 1/4 to 3/4 over half of it. The blocker edge is 2.5 m above the
        // ground, 2.5·√5/2 m along the light, and a metre across the light is √5/2 m on the
        // ground along x.
        let along = 2.5 * 5f32.sqrt() / 2.0;
        let stretch = 5f32.sqrt() / 2.0;
        let mut widths = Vec::new();
        for angle in [2.0f32, 4.0] {
            let (profile, texel) = edge_profile(ctx, angle);
            let box_width = 2.0 * along * (0.5 * angle).to_radians().tan() + texel;
            let want = 0.5 * box_width * stretch;
            let got = crossing(&profile, 0.75) - crossing(&profile, 0.25);
            eprintln!("sun {angle}°: 25–75 % width {got:.4} m, analytic {want:.4} m (texel {texel:.4} m)");
            // Pixels are 8 mm; wide boxes are evaluated in bins of up to 2 texels.
            assert!((got - want).abs() <= 0.1 * want + 0.01, "sun {angle}°: width {got} vs {want}");
            let mid = crossing(&profile, 0.5);
            assert!((mid - 2.25).abs() < 0.05, "sun {angle}°: the edge should stay at x = 2.25, found {mid}");
            widths.push(got);
        }
        assert!(widths[1] > 1.6 * widths[0], "a larger sun must widen the penumbra: {widths:?}");
    });
}

/// A sky-only view straight at the sun, with a ground quad behind the camera.
fn facing_the_sun(samples: u32, decay: f32, intensity: f32, wall: bool) -> (Scene, View, MeshSettings) {
    let to_sun = Vec3::new(1.0, 0.3, 0.0).normalize();
    let cam = camera([0.0, 1.0, 0.0], (Vec3::Y + to_sun).to_array(), [0.0, 1.0, 0.0], 50.0);
    let mut meshes = vec![quad(Vec3::new(-8.0, 0.0, 0.0), Vec3::Z * 2.0, Vec3::X * 2.0, 0)];
    if wall {
        // Facing the camera (normal −x; single-sided surfaces seen from behind are culled),
        // filling its view: no pixel sees the sky.
        meshes.push(quad(Vec3::new(3.0, 1.0, 0.0), Vec3::Z * 20.0, Vec3::Y * 20.0, 0));
    }
    let light = Light::Directional { direction: (-to_sun).to_array(), color: [1.0, 0.9, 0.7], intensity: 2.0 };
    let sc = scene(meshes, vec![light], cam);
    let s = MeshSettings {
        shadow_tile: 128,
        sun_rays: true,
        sun_rays_samples: samples,
        sun_rays_decay: decay,
        sun_rays_intensity: intensity,
        ..Default::default()
    };
    (sc, view_of(&cam), s)
}

#[test]
fn sun_rays_add_the_decayed_sum_of_sky_samples() {
    common::gpu_test(|ctx| {
        let (samples, decay, intensity) = (16u32, 0.9f32, 0.2f32);
        let (sc, view, s) = facing_the_sun(samples, decay, intensity, false);
        let on = render(ctx, &sc, &view, [64, 48], 0, &s);
        let off = render(ctx, &sc, &view, [64, 48], 0, &MeshSettings { sun_rays: false, ..s });
        // The sun sits at the centre of the screen and every sample between a pixel and it is
        // sky: each pixel gains I·E·Σ_{k<N} d^k / N exactly (the camera looks at the sun: no fade).
        let e = [2.0f32, 1.8, 1.4];
        let sum = (1.0 - decay.powi(samples as i32)) / (1.0 - decay);
        for (i, (a, b)) in on.img.iter().zip(&off.img).enumerate() {
            assert_eq!(b[0], s.sky[0], "pixel {i} should be sky");
            for ch in 0..3 {
                let want = intensity * e[ch] * sum / samples as f32;
                let got = a[ch] - b[ch];
                assert!((got - want).abs() <= 1e-5 * want, "pixel {i} channel {ch}: added {got}, want {want}");
            }
        }
    });
}

#[test]
fn sun_rays_add_nothing_at_zero_intensity_or_with_the_sky_hidden() {
    common::gpu_test(|ctx| {
        for (intensity, wall) in [(0.0, false), (0.5, true)] {
            let (sc, view, s) = facing_the_sun(32, 0.95, intensity, wall);
            let on = render(ctx, &sc, &view, [64, 48], 0, &s);
            let off = render(ctx, &sc, &view, [64, 48], 0, &MeshSettings { sun_rays: false, ..s });
            assert!(on.passes.iter().any(|p| p == "sun rays"), "the sun is in front: the pass must run");
            assert_eq!(count_different(&on.img, &off.img), 0, "intensity {intensity}, wall {wall}: image changed");
        }
    });
}

/// A small specular room lit through its open top, seen from inside: the LPV holds light
/// bounced off the sunlit floor.
fn specular_room(specular: f32) -> (Scene, View) {
    let cam = camera([-1.5, 1.5, -1.5], [1.0, 0.3, 1.0], [0.0, 1.0, 0.0], 70.0);
    let mut meshes = vec![quad(Vec3::ZERO, Vec3::Z * 2.0, Vec3::X * 2.0, 0)];
    meshes.push(quad(Vec3::new(2.0, 1.5, 0.0), Vec3::Y * 1.5, Vec3::Z * 2.0, 0));
    meshes.push(quad(Vec3::new(0.0, 1.5, 2.0), Vec3::X * 2.0, Vec3::Y * 1.5, 0));
    let light = Light::Directional { direction: [0.3, -1.0, 0.2], color: [1.0; 3], intensity: 3.0 };
    let mut sc = scene(meshes, vec![light], cam);
    sc.materials[0].specular = [specular; 3];
    sc.materials[0].shininess = 24.0;
    (sc, view_of(&cam))
}

#[test]
fn glossy_reflections_need_a_specular_material_and_only_add_bounded_light() {
    common::gpu_test(|ctx| {
        let base = MeshSettings { shadow_tile: 256, lpv: lpv_on(), ..Default::default() };
        let glossy = MeshSettings { lpv_glossy: true, ..base };
        let size = [80, 60];

        let (sc, view) = specular_room(0.0);
        let off = render(ctx, &sc, &view, size, 128, &base);
        let on = render(ctx, &sc, &view, size, 128, &glossy);
        assert_eq!(count_different(&on.img, &off.img), 0, "glossy on a zero specular colour changed the image");

        let ks = 0.5;
        let (sc, view) = specular_room(ks);
        let off = render(ctx, &sc, &view, size, 128, &base);
        let on = render(ctx, &sc, &view, size, 128, &glossy);
        // The largest radiance the LPV can return, from the grid the frame used: a cell's
        // intensity toward any direction is at most c0·Y0 + |c1..3|·Y1, over its cross-section.
        let [_, accum] = on.targets.lpv_grids().expect("lpv grids");
        let cell = on.targets.lpv_cascades[0].cell;
        let bound: f32 = (0..3)
            .map(|ch| {
                (0..accum.cells())
                    .map(|i| {
                        let c = accum.coeffs(ch, i);
                        let band1 = (c[1] * c[1] + c[2] * c[2] + c[3] * c[3]).sqrt();
                        (c[0].abs() * sh::Y0 as f32 + band1 * sh::Y1 as f32) / (cell * cell)
                    })
                    .fold(0.0f32, f32::max)
            })
            .fold(0.0f32, f32::max);
        assert!(bound > 0.0, "the LPV holds no light");
        let mut brighter = 0;
        for (i, (a, b)) in on.img.iter().zip(&off.img).enumerate() {
            for ch in 0..3 {
                let added = a[ch] - b[ch];
                assert!(added >= -1e-6 * b[ch].abs(), "pixel {i} channel {ch} got darker: {added}");
                assert!(
                    added <= ks * bound * (1.0 + 1e-4),
                    "pixel {i}: added {added} > ks·max radiance {}",
                    ks * bound
                );
            }
            brighter += usize::from(a[0] > b[0]);
        }
        let (e_on, e_off) = (energy(&on.img), energy(&off.img));
        eprintln!("glossy: energy {e_off:.3} → {e_on:.3}, {brighter} of {} pixels brighter", on.img.len());
        assert!(e_on > e_off * 1.001, "glossy reflections added no energy: {e_off} → {e_on}");
        assert!(brighter > on.img.len() / 10, "only {brighter} pixels gained light");
    });
}

#[test]
fn absurd_extension_settings_are_errors_naming_the_setting() {
    let set = |k: &str, v: &str| vec![(k.to_string(), v.to_string())];
    let empty = std::collections::BTreeMap::new();
    for (k, v) in [
        ("sun_angle", "-1"),
        ("sun_angle", "90"),
        ("sun_angle", "NaN"),
        ("spot_radius", "-0.1"),
        ("spot_radius", "1e9"),
        ("sun_rays_intensity", "-1"),
        ("sun_rays_intensity", "inf"),
        ("sun_rays_decay", "0"),
        ("sun_rays_decay", "1.5"),
        ("sun_rays_samples", "0"),
        ("sun_rays_samples", "100000"),
        ("sun_rays_samples", "-3"),
        ("soft_shadows", "yes"),
    ] {
        let err = common::scenes::mesh_settings(&empty, &set(k, v)).expect_err(&format!("{k}={v} accepted"));
        assert!(err.to_string().contains(k), "{k}={v}: the error does not name the setting: {err}");
    }
    let err = common::scenes::mesh_settings(&empty, &set("lpv_glossy", "1")).expect_err("glossy without LPV");
    assert!(err.to_string().contains("lpv_glossy"), "{err}");
    let ok = [("lpv", "1"), ("lpv_glossy", "1"), ("soft_shadows", "1"), ("sun_angle", "2"), ("sun_rays", "1")];
    let sets: Vec<(String, String)> = ok.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    let (s, _) = common::scenes::mesh_settings(&empty, &sets).expect("valid settings");
    assert!(s.lpv_glossy && s.soft_shadows && s.sun_rays && s.sun_angle == 2.0);
}
