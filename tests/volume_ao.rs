//! LAO, DOS and the ray marchers' depth output against analytic answers and an independent CPU
//! evaluation of the LAO definition, on lavapipe under validation.

mod common;

use glam::{Mat4, Vec3};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{procedural, Volume};
use vkengine::volume::occlusion::OcclusionSettings;
use vkengine::volume::renderer::{render_frame, RenderSettings, RendererKind, Targets, VolumeRenderer};
use vkengine::volume::tf::TransferFunction;

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
        // and the discrete light factor rises back towards 1 (DOS at σ = 32 with 256 slices).
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
        for renderer in [RendererKind::Eam, RendererKind::Lao] {
            for threshold in [0.3f32, 0.7, 0.9] {
                let o_s = OcclusionSettings { depth_threshold: Some(threshold), ..Default::default() };
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
                        (got[0] - expect).abs() <= 0.5 * step,
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
        for (name, renderer, o) in [
            ("lao_samples", RendererKind::Lao, bad_lao),
            ("dos_slices", RendererKind::Dos, bad_dos),
            ("depth_threshold", RendererKind::Mip, depth_mip),
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
