//! LAO, DOS and the ray marchers' depth output against analytic answers and an independent CPU
//! evaluation of the LAO definition, on lavapipe under validation.

mod common;

use glam::{Mat4, Vec3};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{procedural, Volume};
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::occlusion::OcclusionSettings;
use vkengine::volume::render::renderer::{render_frame, RenderSettings, RendererKind, Targets, VolumeRenderer};

const SIZE: [u32; 2] = [32, 32];
const HEIGHT: f32 = 2.0;
const COLOR: [f32; 3] = [0.8, 0.5, 0.2];

/// Orthographic camera looking down -Z; the image spans `HEIGHT` world units, so the unit box
/// covers pixels 8..24.
fn ortho() -> Camera {
    Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: HEIGHT })
}

fn box_volume() -> Volume {
    procedural::homogeneous_box([16, 16, 16], 1.0).expect("procedural volume")
}

/// Renders one frame; returns (HDR, depth if requested).
fn render(ctx: &Context, sigma: f32, s: RenderSettings) -> (Vec<[f32; 4]>, Option<Vec<[f32; 4]>>) {
    let r = VolumeRenderer::new(ctx, &box_volume(), &TransferFunction::constant(COLOR, sigma)).expect("renderer");
    let mut t = Targets::new(ctx, SIZE).expect("targets");
    render_frame(ctx, &r, &mut t, &ortho(), &s, 0).expect("render");
    let depth = s.occlusion.depth_threshold.map(|_| t.read_depth(ctx).expect("depth readback"));
    (t.read_hdr(ctx).expect("readback"), depth)
}

fn settings(renderer: RendererKind) -> RenderSettings {
    RenderSettings {
        renderer,
        empty_space_skipping: false,
        termination: 0.0,
        step: Some(1.0 / 32.0),
        ..Default::default()
    }
}

fn px(img: &[[f32; 4]], x: u32, y: u32) -> [f32; 4] {
    img[(y * SIZE[0] + x) as usize]
}

/// Camera ray of pixel (x, y) as the shaders build it: near-plane origin, unit direction.
fn ray(inv: Mat4, x: u32, y: u32) -> (Vec3, Vec3) {
    let ndc = glam::Vec2::new(
        (x as f32 + 0.5) / SIZE[0] as f32 * 2.0 - 1.0,
        -((y as f32 + 0.5) / SIZE[1] as f32 * 2.0 - 1.0),
    );
    let o = inv.project_point3(ndc.extend(0.0));
    (o, (inv.project_point3(ndc.extend(1.0)) - o).normalize())
}

fn box_hit(o: Vec3, d: Vec3) -> (f32, f32) {
    let (t0, t1) = ((Vec3::splat(-0.5) - o) / d, (Vec3::splat(0.5) - o) / d);
    (t0.min(t1).max_element().max(0.0), t0.max(t1).min_element())
}

#[test]
fn empty_volume_is_unoccluded() {
    common::gpu_test(|ctx| {
        let bg = [0.3, 0.2, 0.1];
        let mut images = Vec::new();
        for renderer in [RendererKind::Eam, RendererKind::Lao, RendererKind::Dos] {
            let s = RenderSettings { background: bg, ..settings(renderer) };
            images.push(render(ctx, 0.0, s).0);
        }
        // Zero opacity: no occlusion at all, so every pixel is exactly the background and LAO/DOS
        // equal EAM bit for bit.
        for (img, name) in images.iter().zip(["eam", "lao", "dos"]) {
            for p in img {
                assert_eq!(p[..3], bg, "{name}: a pixel of the empty volume is not the background");
            }
        }
    });
}

/// LAO of the homogeneous unit box by direct evaluation of the definition in f64: the same
/// segment lattice, Fibonacci directions and midpoint occlusion samples as documented in
/// `lao.comp`, with extinction σ inside the box and 0 outside.
fn lao_reference(o: Vec3, d: Vec3, sigma: f64, step: f64, o_s: &OcclusionSettings) -> [f64; 3] {
    let (t0, t1) = box_hit(o, d);
    let (t0, t1) = (t0 as f64, t1 as f64);
    let inside = |p: [f64; 3]| p.iter().all(|c| c.abs() <= 0.5);
    let n_dirs = o_s.lao_samples as usize;
    let dirs: Vec<[f64; 3]> = (0..n_dirs)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n_dirs as f64;
            let rho = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f64::consts::PI * (3.0 - 5f64.sqrt()) * i as f64;
            [rho * phi.cos(), rho * phi.sin(), z]
        })
        .collect();
    let h = o_s.lao_radius as f64 / o_s.lao_steps as f64;
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let mut c = 0.0;
    let mut trans = 1.0;
    let n = ((t1 - t0) / step).ceil() as usize;
    for k in 0..n {
        let a = t0 + k as f64 * step;
        let b = (a + step).min(t1);
        let x = o + d * (0.5 * (a + b));
        let ao: f64 = dirs
            .iter()
            .map(|w| {
                let tau: f64 = (0..o_s.lao_steps)
                    .map(|j| {
                        let p = x + glam::DVec3::from(*w) * (h * (j as f64 + 0.5));
                        if inside(p.to_array()) {
                            sigma
                        } else {
                            0.0
                        }
                    })
                    .sum();
                (-tau * h).exp()
            })
            .sum::<f64>()
            / n_dirs as f64;
        let alpha = 1.0 - (-sigma * (b - a)).exp();
        c += trans * alpha * ao;
        trans *= 1.0 - alpha;
    }
    COLOR.map(|k| k as f64 * c)
}

#[test]
fn lao_matches_direct_evaluation_on_homogeneous_box() {
    common::gpu_test(|ctx| {
        let sigma = 3.0;
        // A radius whose occlusion samples never land exactly on the box's faces (0.2 puts some on
        // them, where f32 and f64 disagree about inside and outside).
        let o_s = OcclusionSettings { lao_radius: 0.17, lao_samples: 8, lao_steps: 4, ..Default::default() };
        let s = RenderSettings { occlusion: o_s, ..settings(RendererKind::Lao) };
        let (img, _) = render(ctx, sigma, s);
        let inv = ortho().inverse_view_projection(1.0);
        for (x, y) in [(16, 16), (9, 9), (22, 12), (12, 23)] {
            let (o, d) = ray(inv, x, y);
            let expect = lao_reference(o, d, sigma as f64, 1.0 / 32.0, &o_s);
            let got = px(&img, x, y);
            for i in 0..3 {
                // f32 shader arithmetic against f64: relative 1e-3 is far below the effect of
                // the occlusion itself (tens of per cent here).
                assert!(
                    (got[i] as f64 - expect[i]).abs() <= 1e-3 * expect[i].max(1e-3),
                    "LAO pixel ({x},{y}) ch {i}: {} vs reference {}",
                    got[i],
                    expect[i]
                );
            }
        }
    });
}

#[test]
fn occlusion_grows_with_density_and_stays_in_unit_range() {
    common::gpu_test(|ctx| {
        // While σΔz ≪ 1: past that the first slice/segment, which no occlusion reaches, dominates
        // and the discrete light factor rises back towards 1 (DOS at σ = 32 with 256 slices; the default is now 200).
        for renderer in [RendererKind::Lao, RendererKind::Dos] {
            let mut last = f32::INFINITY;
            for sigma in [0.25, 1.0, 4.0, 8.0] {
                let occluded = render(ctx, sigma, settings(renderer)).0;
                let eam = render(ctx, sigma, settings(RendererKind::Eam)).0;
                // Same colour everywhere, so occluded / unoccluded is the opacity-weighted mean
                // of the light factor (1 - occlusion) along the ray.
                let ratio = px(&occluded, 16, 16)[0] / px(&eam, 16, 16)[0];
                assert!((0.0..=1.0).contains(&ratio), "{renderer:?} σ={sigma}: light factor {ratio} outside [0,1]");
                assert!(ratio < last, "{renderer:?} σ={sigma}: light factor {ratio} did not fall (was {last})");
                last = ratio;
            }
        }
    });
}

#[test]
fn dos_matches_analytic_headlight_recurrence() {
    common::gpu_test(|ctx| {
        let slices = 128u32;
        let o_s = OcclusionSettings { dos_angle: 10.0, dos_slices: slices, ..Default::default() };
        for sigma in [1.0f64, 4.0] {
            let s = RenderSettings { occlusion: o_s, ..settings(RendererKind::Dos) };
            let (img, _) = render(ctx, sigma as f32, s);
            // Looking down -Z the slices tile the unit box exactly (Δz = 1/128). Far from the
            // box's silhouette (8 px away; the cone spreads 1·tan 10° = 2.8 px over the whole
            // depth) the occlusion is uniform across the cone, so slice k sees occlusion
            // 1 - (1-a)^k and transmittance (1-a)^k: C = c·a·Σ(1-a)^{2k}.
            let a = 1.0 - (-sigma / slices as f64).exp();
            let q = (1.0 - a) * (1.0 - a);
            let discrete = a * (1.0 - q.powi(slices as i32)) / (1.0 - q);
            // Its continuous limit: ∫σ e^{-2σz} dz = (1 - e^{-2σ}) / 2.
            let continuous = 0.5 * (1.0 - (-2.0 * sigma).exp());
            let got = px(&img, 16, 16);
            for i in 0..3 {
                let c = COLOR[i] as f64;
                assert!(
                    (got[i] as f64 - c * discrete).abs() < 1e-4,
                    "DOS σ={sigma} ch {i}: {} vs recurrence {}",
                    got[i],
                    c * discrete
                );
                // The discretisation error bound: relative σΔz/4 + O((σΔz)²).
                assert!((got[i] as f64 - c * continuous).abs() < c * continuous * sigma / slices as f64);
            }
        }
    });
}

#[test]
fn depth_of_homogeneous_box_is_analytic() {
    common::gpu_test(|ctx| {
        let sigma = 3.0f32;
        let step = 1.0 / 32.0;
        let inv = ortho().inverse_view_projection(1.0);
        let view_proj = inv.inverse();
        for renderer in [RendererKind::Eam, RendererKind::Lao, RendererKind::Dos] {
            // DOS: 200 slices tile the box's unit depth exactly (looking down -Z), so the
            // crossing is solved inside a slice of Δz = 1/200 and must land within half of it.
            let tol = if renderer == RendererKind::Dos { 0.5 / 200.0 } else { 0.5 * step };
            for threshold in [0.3f32, 0.7, 0.9] {
                let o_s = OcclusionSettings { depth_threshold: Some(threshold), dos_slices: 200, ..Default::default() };
                let s = RenderSettings { occlusion: o_s, ..settings(renderer) };
                let (_, depth) = render(ctx, sigma, s);
                let depth = depth.expect("depth image");
                // 1 - exp(-σ d) = t  →  d = -ln(1 - t) / σ past the entry point.
                let d = -(1.0 - threshold).ln() / sigma;
                for (x, y) in [(16, 16), (9, 9), (22, 12)] {
                    let (o, dir) = ray(inv, x, y);
                    let expect = box_hit(o, dir).0 + d;
                    let got = px(&depth, x, y);
                    assert_eq!(got[2], 1.0, "{renderer:?} t={threshold} ({x},{y}): not marked as a hit");
                    assert!(
                        (got[0] - expect).abs() <= tol,
                        "{renderer:?} t={threshold} ({x},{y}): depth {} vs analytic {expect}",
                        got[0]
                    );
                    let ndc = view_proj.project_point3(o + dir * expect).z;
                    assert!((got[1] - ndc).abs() < 1e-3, "NDC depth {} vs {ndc}", got[1]);
                }
                let miss = px(&depth, 0, 0);
                assert_eq!(miss[2], 0.0, "{renderer:?}: a pixel outside the box is marked as a hit");
            }
        }
    });
}

#[test]
fn bad_settings_name_themselves() {
    let good = OcclusionSettings::default();
    assert!(good.validate().is_ok());
    let cases: Vec<(&str, OcclusionSettings)> = vec![
        ("lao_radius", OcclusionSettings { lao_radius: 0.0, ..good }),
        ("lao_radius", OcclusionSettings { lao_radius: f32::NAN, ..good }),
        ("lao_radius", OcclusionSettings { lao_radius: 1e9, ..good }),
        ("lao_samples", OcclusionSettings { lao_samples: 0, ..good }),
        ("lao_samples", OcclusionSettings { lao_samples: 1_000_000, ..good }),
        ("lao_steps", OcclusionSettings { lao_steps: 0, ..good }),
        ("dos_angle", OcclusionSettings { dos_angle: 90.0, ..good }),
        ("dos_angle", OcclusionSettings { dos_angle: -1.0, ..good }),
        ("dos_slices", OcclusionSettings { dos_slices: 0, ..good }),
        ("dos_slices", OcclusionSettings { dos_slices: u32::MAX, ..good }),
        ("depth_threshold", OcclusionSettings { depth_threshold: Some(0.0), ..good }),
        ("depth_threshold", OcclusionSettings { depth_threshold: Some(1.0), ..good }),
        ("depth_threshold", OcclusionSettings { depth_threshold: Some(f32::INFINITY), ..good }),
        ("lao_light", OcclusionSettings { lao_light: -1.0, ..good }),
        ("lao_light", OcclusionSettings { lao_light: f32::NAN, ..good }),
        ("lao_light_pos", OcclusionSettings { lao_light_pos: [0.0, f32::INFINITY, 0.0], ..good }),
        ("lao_light_radius", OcclusionSettings { lao_light_radius: -0.1, ..good }),
        ("lao_light_radius", OcclusionSettings { lao_light_radius: 100.0, ..good }),
        ("lao_light_samples", OcclusionSettings { lao_light_samples: 0, ..good }),
        ("lao_light_samples", OcclusionSettings { lao_light_samples: 257, ..good }),
        ("lao_ambient", OcclusionSettings { lao_ambient: -1.0, ..good }),
    ];
    for (name, s) in cases {
        let e = s.validate().expect_err(name).to_string();
        assert!(e.contains(name), "error for bad {name} does not name it: {e}");
    }
}

#[test]
fn bad_settings_fail_the_frame_not_the_process() {
    common::gpu_test(|ctx| {
        let r = VolumeRenderer::new(ctx, &box_volume(), &TransferFunction::constant(COLOR, 1.0)).expect("renderer");
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        let bad_lao = OcclusionSettings { lao_samples: 0, ..Default::default() };
        let bad_dos = OcclusionSettings { dos_slices: 100_000, ..Default::default() };
        let depth_mip = OcclusionSettings { depth_threshold: Some(0.5), ..Default::default() };
        let bad_light = OcclusionSettings { lao_light: 1.0, lao_light_radius: -0.1, ..Default::default() };
        for (name, renderer, o) in [
            ("lao_samples", RendererKind::Lao, bad_lao),
            ("dos_slices", RendererKind::Dos, bad_dos),
            ("depth_threshold", RendererKind::Mip, depth_mip),
            ("lao_light_radius", RendererKind::Lao, bad_light),
        ] {
            let s = RenderSettings { renderer, occlusion: o, ..Default::default() };
            let e = render_frame(ctx, &r, &mut t, &ortho(), &s, 0).err().map(|e| e.to_string());
            assert!(
                e.as_deref().is_some_and(|e| e.contains(name)),
                "{renderer:?}: expected an error naming {name}, got {e:?}"
            );
        }
        // Off costs nothing: without a threshold no depth target is made.
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        render_frame(ctx, &r, &mut t, &ortho(), &settings(RendererKind::Lao), 0).expect("render");
        assert!(t.depth.is_none(), "depth target created with depth output off");
        assert_eq!(RendererKind::parse("lao").ok(), Some(RendererKind::Lao));
        assert_eq!(RendererKind::parse("dos").ok(), Some(RendererKind::Dos));
        assert!(RendererKind::parse("dso").is_err());
    });
}

// ---- LAO's spherical light (`--set lao_light=… lao_light_radius=…`) ----

/// Renders one frame of `volume` with `tf` at `size`, the orthographic camera of `ortho()`.
fn render_with(
    ctx: &Context,
    volume: &Volume,
    tf: &TransferFunction,
    size: [u32; 2],
    s: RenderSettings,
) -> Vec<[f32; 4]> {
    let r = VolumeRenderer::new(ctx, volume, tf).expect("renderer");
    let mut t = Targets::new(ctx, size).expect("targets");
    render_frame(ctx, &r, &mut t, &ortho(), &s, 0).expect("render");
    t.read_hdr(ctx).expect("readback")
}

/// Camera ray of pixel (x, y) of an image of `size` (as `ray`).
fn ray_sized(inv: Mat4, size: [u32; 2], x: u32, y: u32) -> (glam::DVec3, glam::DVec3) {
    let ndc = glam::Vec2::new(
        (x as f32 + 0.5) / size[0] as f32 * 2.0 - 1.0,
        -((y as f32 + 0.5) / size[1] as f32 * 2.0 - 1.0),
    );
    let o = inv.project_point3(ndc.extend(0.0));
    (o.as_dvec3(), (inv.project_point3(ndc.extend(1.0)) - o).normalize().as_dvec3())
}

/// Length of the segment `p + d·[0, len]` inside the axis-aligned box [lo, hi] (f64).
fn length_inside(p: glam::DVec3, d: glam::DVec3, len: f64, lo: glam::DVec3, hi: glam::DVec3) -> f64 {
    let (mut t0, mut t1) = (0.0f64, len);
    for i in 0..3 {
        if d[i].abs() < 1e-300 {
            if p[i] < lo[i] || p[i] > hi[i] {
                return 0.0;
            }
            continue;
        }
        let (a, b) = ((lo[i] - p[i]) / d[i], (hi[i] - p[i]) / d[i]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t1 - t0).max(0.0)
}

/// The shader's shadow-ray directions towards a sphere (centre `c`, radius `r`) from `x`, each
/// with its length to the sphere: cos θ stratified in [cos θmax, 1], golden-angle azimuths, the
/// same orthonormal basis (Duff et al. 2017). Radius 0 is the single ray to the centre.
fn light_rays(x: glam::DVec3, c: glam::DVec3, r: f64, n: u32) -> Vec<(glam::DVec3, f64)> {
    let to = c - x;
    let dist = to.length();
    let w = to / dist;
    if r == 0.0 {
        return vec![(w, dist)];
    }
    let cos_max = (1.0 - (r / dist).powi(2)).max(0.0).sqrt();
    let sgn = if w.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sgn + w.z);
    let b = w.x * w.y * a;
    let u = glam::DVec3::new(1.0 + sgn * w.x * w.x * a, sgn * b, -sgn * w.x);
    let v = glam::DVec3::new(b, sgn + w.y * w.y * a, -w.y);
    (0..n)
        .map(|i| {
            let ct = 1.0 - (1.0 - cos_max) * (i as f64 + 0.5) / n as f64;
            let st = (1.0 - ct * ct).max(0.0).sqrt();
            let phi = std::f64::consts::PI * (3.0 - 5f64.sqrt()) * i as f64;
            let d = u * (st * phi.cos()) + v * (st * phi.sin()) + w * ct;
            let bd = to.dot(d);
            (d, bd - (bd * bd - (dist * dist - r * r)).max(0.0).sqrt())
        })
        .collect()
}

/// Light-only LAO (ambient weight 0) of a pixel by direct f64 evaluation: the camera ray's
/// segment lattice with extinction `sigma(x)` at each midpoint, each sample lit by `intensity`
/// times the mean over `light_rays` of exp(-∫σ) (`optical_depth` of a ray from x).
fn lit_pixel(
    o: glam::DVec3,
    d: glam::DVec3,
    step: f64,
    sigma: &dyn Fn(glam::DVec3) -> f64,
    visibility: &dyn Fn(glam::DVec3) -> f64,
) -> f64 {
    let (t0, t1) = box_hit(o.as_vec3(), d.as_vec3());
    let (t0, t1) = (t0 as f64, t1 as f64);
    let (mut c, mut trans) = (0.0, 1.0);
    let n = ((t1 - t0) / step).ceil() as usize;
    for k in 0..n {
        let a = t0 + k as f64 * step;
        let b = (a + step).min(t1);
        let x = o + d * (0.5 * (a + b));
        let s = sigma(x);
        if s <= 0.0 {
            continue;
        }
        let alpha = 1.0 - (-s * (b - a)).exp();
        c += trans * alpha * visibility(x);
        trans *= 1.0 - alpha;
    }
    c
}

fn light_settings(intensity: f32, pos: [f32; 3], radius: f32, samples: u32) -> RenderSettings {
    let o = OcclusionSettings {
        lao_light: intensity,
        lao_light_pos: pos,
        lao_light_radius: radius,
        lao_light_samples: samples,
        lao_ambient: 0.0,
        ..Default::default()
    };
    RenderSettings { occlusion: o, ..settings(RendererKind::Lao) }
}

#[test]
fn lao_light_default_is_off_and_unchanged() {
    // The defaults select the plain shader (images bit-identical to before the light existed).
    let d = OcclusionSettings::default();
    assert!(!d.lao_light_variant());
    assert_eq!((d.lao_light_radius, d.lao_light_samples), (0.19, 10), "vpt's LAORenderer.js defaults");
    common::gpu_test(|ctx| {
        // Ambient weight 1 and light 0 through the light variant equals the plain shader.
        let plain = render(ctx, 3.0, settings(RendererKind::Lao)).0;
        let o = OcclusionSettings { lao_ambient: 1.0 + f32::EPSILON, ..Default::default() };
        assert!(o.lao_light_variant());
        let variant = render(ctx, 3.0, RenderSettings { occlusion: o, ..settings(RendererKind::Lao) }).0;
        for (a, b) in plain.iter().zip(&variant) {
            for i in 0..3 {
                assert!((a[i] - b[i]).abs() <= 4.0 * f32::EPSILON * a[i].abs().max(1e-6), "{a:?} vs {b:?}");
            }
        }
    });
}

#[test]
fn lao_light_through_empty_medium_is_fully_lit() {
    common::gpu_test(|ctx| {
        let bg = [0.3, 0.2, 0.1];
        // An empty volume stays exactly the background with the light on.
        for radius in [0.0, 0.3] {
            let s = RenderSettings { background: bg, ..light_settings(2.0, [0.3, 1.2, 0.7], radius, 16) };
            for p in render(ctx, 0.0, s).0 {
                assert_eq!(p[..3], bg, "radius {radius}: empty volume with the light is not the background");
            }
        }
        // A nearly clear medium: every shadow ray's transmittance lies in [e^{-σ·√3}, 1] (no
        // chord through the unit box is longer than √3), so LAO lit by intensity I with no
        // ambient term is I × EAM to within that factor, at every pixel, for any radius.
        let (sigma, intensity) = (1e-3f32, 2.0f32);
        let eam = render(ctx, sigma, settings(RendererKind::Eam)).0;
        let lo = (-(sigma as f64) * 3f64.sqrt()).exp();
        for radius in [0.0, 0.3, 2.0] {
            let lit = render(ctx, sigma, light_settings(intensity, [0.3, 1.2, 0.7], radius, 16)).0;
            let mut hits = 0;
            for (l, e) in lit.iter().zip(&eam) {
                if e[0] <= 0.0 {
                    continue;
                }
                hits += 1;
                let v = l[0] as f64 / (intensity as f64 * e[0] as f64);
                assert!(v >= lo - 1e-5 && v <= 1.0 + 1e-5, "radius {radius}: visibility {v} outside [{lo}, 1]");
            }
            assert!(hits > 100, "the box covers too few pixels ({hits})");
        }
    });
}

#[test]
fn lao_hard_and_soft_shadows_match_direct_evaluation_on_homogeneous_box() {
    common::gpu_test(|ctx| {
        let sigma = 3.0f64;
        let (c, i_l) = (glam::DVec3::new(0.3, 1.2, 0.7), 1.5f64);
        let inv = ortho().inverse_view_projection(1.0);
        let (lo, hi) = (glam::DVec3::splat(-0.5), glam::DVec3::splat(0.5));
        let inside = |p: glam::DVec3| p.abs().max_element() <= 0.5;
        for (radius, samples) in [(0.0f32, 10u32), (0.4, 10), (0.4, 37)] {
            let s = light_settings(i_l as f32, c.as_vec3().to_array(), radius, samples);
            let (img, _) = render(ctx, sigma as f32, s);
            // Homogeneous box: each shadow ray's optical depth is σ × its chord inside the box
            // (midpoint samples of a constant medium are exact), analytic in f64.
            let vis = |x: glam::DVec3| {
                let rays = light_rays(x, c, radius as f64, samples);
                rays.iter().map(|(d, len)| (-sigma * length_inside(x, *d, *len, lo, hi)).exp()).sum::<f64>()
                    / rays.len() as f64
            };
            let sig = |x: glam::DVec3| if inside(x) { sigma } else { 0.0 };
            let mut spread = (f64::INFINITY, 0.0f64);
            for (x, y) in [(16, 16), (9, 9), (22, 12), (12, 23), (9, 22), (22, 22)] {
                let (o, d) = ray_sized(inv, SIZE, x, y);
                let expect = i_l * lit_pixel(o, d, 1.0 / 32.0, &sig, &vis);
                spread = (spread.0.min(expect), spread.1.max(expect));
                let got = px(&img, x, y);
                for ch in 0..3 {
                    let e = COLOR[ch] as f64 * expect;
                    // f32 against f64 over 32 samples × ≤ 37 rays: 1e-4 relative is ~100× the
                    // rounding and far below the shadow's own contrast (checked below).
                    assert!(
                        (got[ch] as f64 - e).abs() <= 1e-4 * e.max(1e-4),
                        "radius {radius} n={samples} pixel ({x},{y}) ch {ch}: {} vs f64 {e}",
                        got[ch]
                    );
                }
            }
            assert!(spread.1 > 1.5 * spread.0, "radius {radius}: too little shadow contrast to test {spread:?}");
        }
    });
}

#[test]
fn lao_penumbra_of_an_edge_matches_analytic_extent() {
    common::gpu_test(|ctx| {
        // 32³ volume: an emitting "screen" slab x < -0.25 of low extinction, and an opaque
        // occluder x > 0.25, y < 0 whose edge (the line y = 0) casts a shadow from a spherical
        // light at (2, 0, 0) onto the screen. The camera looks down -Z at the screen.
        let n = 32u32;
        let mut data = vec![0.0f32; (n * n * n) as usize];
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let c = |v: u32| -0.5 + (v as f32 + 0.5) / n as f32;
                    let idx = ((k * n + j) * n + i) as usize;
                    if c(i) < -0.25 {
                        data[idx] = 0.5;
                    } else if c(i) > 0.25 && c(j) < 0.0 {
                        data[idx] = 1.0;
                    }
                }
            }
        }
        let volume = Volume::new([n; 3], [1.0; 3], data, "penumbra test").expect("volume");
        let (sigma_s, sigma_o) = (0.5f64, 400.0f64);
        let p =
            |value: f32, e: f64| vkengine::volume::optics::tf::TfPoint { value, color: COLOR, extinction: e as f32 };
        let tf = TransferFunction::OneD {
            points: vec![p(0.0, 0.0), p(0.4, sigma_s), p(0.6, sigma_s), p(0.8, sigma_o), p(1.0, sigma_o)],
        };
        let size = [128u32, 128];
        let inv = ortho().inverse_view_projection(1.0);
        let light = glam::DVec3::new(2.0, 0.0, 0.0);
        let screen = (glam::DVec3::new(-0.5, -0.5, -0.5), glam::DVec3::new(-0.25, 0.5, 0.5));
        let occluder = (glam::DVec3::new(0.25, -0.5, -0.5), glam::DVec3::new(0.5, 0.0, 0.5));
        let sig = |x: glam::DVec3| if x.x < -0.25 && x.abs().max_element() <= 0.5 { sigma_s } else { 0.0 };
        // One screen column (pixel x = 40 → world x ≈ -0.367); rows spanning y ∈ [-0.45, 0.45].
        let col = 40u32;
        let rows: Vec<u32> = (35..93).collect();
        // Half a voxel: the trilinear texture blurs the occluder's edge by ±1/64; one voxel of
        // slack for that and for the midpoint sampling of grazing shadow rays.
        let delta = 1.0 / 32.0;
        let mut widths = Vec::new();
        for radius in [0.0f64, 0.15, 0.3] {
            let samples = 32;
            let img =
                render_with(ctx, &volume, &tf, size, light_settings(1.0, [2.0, 0.0, 0.0], radius as f32, samples));
            let vis = |x: glam::DVec3| {
                let rays = light_rays(x, light, radius, samples);
                rays.iter()
                    .map(|(d, len)| {
                        let tau = sigma_s * length_inside(x, *d, *len, screen.0, screen.1)
                            + sigma_o * length_inside(x, *d, *len, occluder.0, occluder.1);
                        (-tau).exp()
                    })
                    .sum::<f64>()
                    / rays.len() as f64
            };
            let reference = |o: glam::DVec3, d: glam::DVec3, dy: f64| {
                let shift = glam::DVec3::new(0.0, dy, 0.0);
                lit_pixel(o + shift, d, 1.0 / 32.0, &sig, &|x| vis(x)) * COLOR[0] as f64
            };
            // Unshadowed level: the top row, far above the penumbra.
            let (o_top, d_top) = ray_sized(inv, size, col, rows[0]);
            let lit = reference(o_top, d_top, 0.0);
            let eps = 0.01 * lit;
            let mut profile = Vec::new();
            for &row in &rows {
                let (o, d) = ray_sized(inv, size, col, row);
                let got = img[(row * size[0] + col) as usize][0] as f64;
                // The edge model is exact up to the blur: the GPU value lies between the
                // reference moved down and up by delta (visibility grows with y).
                let (lo, hi) = (reference(o, d, -delta), reference(o, d, delta));
                assert!(
                    got >= lo.min(hi) - eps && got <= lo.max(hi) + eps,
                    "radius {radius} y={:.4}: {got} outside [{lo}, {hi}] ± {eps}",
                    o.y
                );
                profile.push((o.y, got));
            }
            // Monotone in y (rows go top to bottom: y falls), fully lit above and dark below.
            for w in profile.windows(2) {
                assert!(w[1].1 <= w[0].1 + 1e-3 * lit, "radius {radius}: not monotone at y={:.4}", w[1].0);
            }
            // Analytic extent of the penumbra for a screen point at depth z = 0 (the camera
            // ray's centre; the z offset changes slopes by < 1 %): with slope s = dy/dx of a
            // ray, the point is lit iff y + (0.25 - x)s >= 0 and y + (0.5 - x)s >= 0, and the
            // light's cone spans slopes s0 ± tan θ, s0 = -y/(2 - x), sin θ = R/dist.
            let x = o_top.x; // the column's world x, -0.3671875
            let th = (radius / (2.0 - x)).asin().tan();
            // Fully lit when y + (0.5 - x)(s0 - tan θ) >= 0, solved for y.
            let y_full = th * (0.5 - x) / (1.0 - (0.5 - x) / (2.0 - x));
            // Fully dark when y + (0.25 - x)(s0 + tan θ) < 0.
            let y_dark = -th * (0.25 - x) / (1.0 - (0.25 - x) / (2.0 - x));
            let level = |y: f64| profile.iter().min_by(|a, b| (a.0 - y).abs().total_cmp(&(b.0 - y).abs())).map(|p| p.1);
            if let (Some(top), Some(bottom)) = (level(y_full + 2.0 * delta), level(y_dark - 2.0 * delta)) {
                assert!(top >= 0.97 * lit, "radius {radius}: {top} not fully lit above y={y_full:.4} (lit {lit})");
                assert!(bottom <= 0.01 * lit, "radius {radius}: {bottom} not dark below y={y_dark:.4}");
            }
            // Measured 10–90 % width of the profile.
            let cross = |f: f64| profile.iter().find(|p| p.1 < f * lit).map(|p| p.0).unwrap_or(f64::NAN);
            let width = cross(0.9) - cross(0.1);
            // The analytic 0–100 % extent bounds the 10–90 % width from above (plus the blur).
            assert!(
                width <= y_full - y_dark + 2.0 * delta,
                "radius {radius}: width {width} > analytic {}",
                y_full - y_dark
            );
            widths.push(width);
        }
        // Wider light, wider penumbra.
        assert!(widths[0] < widths[1] && widths[1] < widths[2], "penumbra widths {widths:?} do not grow with radius");
        eprintln!("penumbra 10–90 % widths for radius 0, 0.15, 0.3: {widths:?}");
    });
}

#[test]
fn lao_split_over_dispatches_is_bit_identical_to_one_dispatch() {
    common::gpu_test(|ctx| {
        // The spherical light and a depth output, the march split into 3-sample dispatches
        // (`lao_chunk`) or run whole: the state carried between dispatches (colour, T, depth) must
        // leave every value unchanged, with and without early termination.
        let vol = procedural::smooth_sphere([16, 16, 16], 0.4).expect("volume");
        let tf = TransferFunction::ramp(0.1, 0.8, COLOR, 12.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        for termination in [0.0, 0.2] {
            let occlusion = OcclusionSettings {
                lao_light: 2.0,
                lao_light_samples: 3,
                depth_threshold: Some(0.5),
                ..Default::default()
            };
            let base = RenderSettings { termination, occlusion, ..settings(RendererKind::Lao) };
            let split = RenderSettings { occlusion: OcclusionSettings { lao_chunk: 3, ..occlusion }, ..base };
            let mut out = Vec::new();
            for s in [base, split] {
                let mut t = Targets::new(ctx, SIZE).expect("targets");
                let run = render_frame(ctx, &r, &mut t, &ortho(), &s, 0).expect("render");
                let lao_passes = run.timings.iter().filter(|p| p.name.starts_with("lao")).count();
                out.push((t.read_hdr(ctx).expect("hdr"), t.read_depth(ctx).expect("depth"), lao_passes));
            }
            assert_eq!(out[0].2, 1, "whole: one dispatch");
            assert!(out[1].2 > 4, "split: {} dispatches", out[1].2);
            let bits = |v: &[[f32; 4]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&out[0].0), bits(&out[1].0), "termination {termination}: HDR differs");
            assert_eq!(bits(&out[0].1), bits(&out[1].1), "termination {termination}: depth differs");
            assert!(out[0].0.iter().any(|p| p[0] > 0.01), "the volume is visible");
        }
    });
}
