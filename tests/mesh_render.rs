//! Mesh renderer against analytic answers (lavapipe, validation + sync validation): lit and
//! shadowed ground under a box, Lambert radiance, RSM total flux for a sun and a spot light,
//! the built-in scenes rendering validation-clean, and the RSM pass existing only when asked for.

mod common;

use common::scenes::{boxed, camera, lambert, quad, scene, shaded_point, view_of};

use glam::{Vec3, Vec4Swizzles};
use vkengine::mesh::camera::View;
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::scene::{Aabb, Camera, Light, Mesh, Scene};

/// HDR radiance (red channel) at the pixel where world point `p` lands.
fn radiance_at(img: &[[f32; 4]], size: [u32; 2], view: &View, p: Vec3) -> f32 {
    let c = view.view_proj(size[0] as f32 / size[1] as f32) * p.extend(1.0);
    let ndc = c.xyz() / c.w;
    let px = (((ndc.x * 0.5 + 0.5) * size[0] as f32) as u32).min(size[0] - 1);
    let py = (((ndc.y * 0.5 + 0.5) * size[1] as f32) as u32).min(size[1] - 1);
    img[(py * size[0] + px) as usize][0]
}

/// Size of the top-down frame: ground at 12 m, a few cm per pixel.
const TOP_SIZE: [u32; 2] = [160, 160];

/// The sunlit scene both shadow tests share, rendered: the sun travels along (1, −2, 0) with
/// E = π, the camera looks straight down from y = 12, no ambient light, and the cascades end at
/// 15 m so a texel is a few cm, far below the tests' margins. Returns the HDR image, the view and
/// the passes that ran.
fn render_top_down(ctx: &vkengine::vk::Context, meshes: Vec<Mesh>, cull: bool) -> (Vec<[f32; 4]>, View, Vec<String>) {
    let camera = camera([0.0, 12.0, 0.0], [0.0; 3], [0.0, 0.0, -1.0], 50.0);
    let sun = Light::Directional { direction: [1.0, -2.0, 0.0], color: [1.0; 3], intensity: std::f32::consts::PI };
    let sc = scene(meshes, vec![sun], camera);
    let gpu = GpuScene::upload(ctx, &sc).expect("upload");
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let mut targets = MeshTargets::new(ctx, TOP_SIZE, 0).expect("targets");
    let settings = MeshSettings {
        ambient: [0.0; 3],
        shadow_tile: 512,
        cascades: 2,
        shadow_distance: 15.0,
        cull,
        ..Default::default()
    };
    let view = view_of(&camera);
    let run = render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
    let names = run.timings.iter().map(|t| t.name.clone()).collect();
    (targets.read_hdr(ctx).expect("readback"), view, names)
}

#[test]
fn ground_is_lit_where_the_sun_reaches_and_shadowed_behind_the_box() {
    common::gpu_test(|ctx| {
        // The box at height 2..2.5 over x, z in [-1, 1] shades the ground at x in [0, 2.25]. The
        // box top hides the ground only up to x ≈ 1.26: ground at x = 1.8 is visible and in shadow.
        let mut meshes = vec![quad(Vec3::ZERO, Vec3::Z * 6.0, Vec3::X * 6.0, 0)];
        meshes.extend(boxed(Vec3::new(-1.0, 2.0, -1.0), Vec3::new(1.0, 2.5, 1.0), 0));
        let (img, view, names) = render_top_down(ctx, meshes, true);
        assert!(!names.iter().any(|n| n == "rsm"), "no RSM requested, yet the graph ran one: {names:?}");
        let size = TOP_SIZE;
        // Lambert: L = ρ/π · E · cosθ with ρ = 0.5, E = π, cosθ = 2/√5 on the ground.
        let lit = 0.5 * 2.0 / 5f32.sqrt();
        for p in
            [Vec3::new(-2.5, 0.0, 0.0), Vec3::new(3.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 3.0), Vec3::new(0.5, 0.0, -3.0)]
        {
            let l = radiance_at(&img, size, &view, p);
            assert!((l - lit).abs() < 0.02 * lit, "ground at {p} should be lit: {l} vs {lit}");
        }
        for p in [Vec3::new(1.8, 0.0, 0.0), Vec3::new(1.6, 0.0, 0.6), Vec3::new(1.9, 0.0, -0.5)] {
            let l = radiance_at(&img, size, &view, p);
            assert!(l < 0.02 * lit, "ground at {p} should be in the box's shadow: {l}");
        }
        // The box top faces up: cosθ = 2/√5 as well, and nothing shades it.
        let top = radiance_at(&img, size, &view, Vec3::new(0.0, 2.5, 0.0));
        assert!((top - lit).abs() < 0.02 * lit, "box top {top} vs {lit}");
    });
}

fn rsm_total_flux(ctx: &vkengine::vk::Context, sc: &Scene, n: u32) -> ([f64; 3], usize) {
    let gpu = GpuScene::upload(ctx, sc).expect("upload");
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let mut targets = MeshTargets::new(ctx, [32, 32], n).expect("targets");
    let run = render_frame(ctx, &renderer, &gpu, &mut targets, &view_of(&sc.camera), &MeshSettings::default())
        .expect("render");
    assert!(run.timings.iter().any(|t| t.name == "rsm"), "RSM requested but not rendered");
    let [pos, _normal, flux] = targets.read_rsm(ctx).expect("read rsm");
    let mut total = [0.0f64; 3];
    for f in &flux {
        for k in 0..3 {
            total[k] += f[k] as f64;
        }
    }
    (total, pos.iter().filter(|p| p[3] > 0.0).count())
}

#[test]
fn rsm_flux_of_a_sunlit_quad_equals_albedo_times_irradiance_times_area() {
    common::gpu_test(|ctx| {
        let camera = Camera::framing(&Aabb { min: [-1.0, 0.0, -1.0], max: [1.0, 0.0, 1.0] }, 45.0);
        let e = 2.0f32;
        let sun = Light::Directional { direction: [0.0, -1.0, 0.0], color: [1.0; 3], intensity: e };
        let sc = scene(vec![quad(Vec3::ZERO, Vec3::Z, Vec3::X, 0)], vec![sun], camera);
        let (total, covered) = rsm_total_flux(ctx, &sc, 256);
        let want = 0.5 * e as f64 * 4.0;
        eprintln!("RSM flux {:.4} vs {want:.4} over {covered} texels", total[0]);
        assert!(covered > 1000, "the quad covers too few RSM texels ({covered})");
        assert!((total[0] - want).abs() < 0.02 * want, "total flux {} vs {want}", total[0]);
    });
}

#[test]
fn rsm_flux_of_a_spot_light_equals_its_intensity_integrated_over_the_cone() {
    common::gpu_test(|ctx| {
        // A spot 1 m above a floor far wider than its cone: every ray of the cone hits the floor.
        let (inner, outer) = (25f32.to_radians(), 35f32.to_radians());
        let intensity = 3.0f32;
        let spot = Light::Spot {
            position: [0.0, 1.0, 0.0],
            direction: [0.0, -1.0, 0.0],
            color: [1.0; 3],
            intensity,
            inner_angle: inner,
            outer_angle: outer,
            range: 10.0,
        };
        let camera = Camera::framing(&Aabb { min: [-5.0, 0.0, -5.0], max: [5.0, 0.0, 5.0] }, 45.0);
        let sc = scene(vec![quad(Vec3::ZERO, Vec3::Z * 5.0, Vec3::X * 5.0, 0)], vec![spot], camera);
        let (total, _) = rsm_total_flux(ctx, &sc, 256);
        // Φ = ρ · 2π I ∫ s(cosθ) dcosθ over [cos outer, 1], s = smoothstep(cos outer, cos inner, ·).
        let (co, ci) = (outer.cos() as f64, inner.cos() as f64);
        let steps = 100_000;
        let mut integral = 0.0;
        for i in 0..steps {
            let c = co + (1.0 - co) * (i as f64 + 0.5) / steps as f64;
            let t = ((c - co) / (ci - co)).clamp(0.0, 1.0);
            integral += t * t * (3.0 - 2.0 * t) * (1.0 - co) / steps as f64;
        }
        let want = 0.5 * 2.0 * std::f64::consts::PI * intensity as f64 * integral;
        eprintln!("spot RSM flux {:.4} vs {want:.4}", total[0]);
        assert!((total[0] - want).abs() < 0.02 * want, "total flux {} vs {want}", total[0]);
    });
}

#[test]
fn built_in_scenes_render_validation_clean() {
    common::gpu_test(|ctx| {
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        for name in ["cornell", "atrium"] {
            let sc = common::scenes::builtin_scene(name).expect("built-in scene");
            let gpu = GpuScene::upload(ctx, &sc).expect("upload");
            let mut targets = MeshTargets::new(ctx, [96, 64], 64).expect("targets");
            let settings = MeshSettings { shadow_tile: 256, ..Default::default() };
            render_frame(ctx, &renderer, &gpu, &mut targets, &view_of(&sc.camera), &settings).expect("render");
            let img = targets.read_hdr(ctx).expect("readback");
            assert!(img.iter().all(|p| p.iter().all(|v| v.is_finite())), "{name}: non-finite radiance");
            let mean = img.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / img.len() as f32;
            assert!(mean > 1e-3, "{name}: black image (mean {mean})");
            let [_, _, flux] = targets.read_rsm(ctx).expect("rsm");
            assert!(flux.iter().any(|f| f[0] > 0.0), "{name}: the RSM received no light");
        }
    });
}

#[test]
fn a_translucent_surface_reflects_only_the_light_it_does_not_let_in() {
    common::gpu_test(|ctx| {
        // Sun straight down, E = π, on a quad of albedo 0.4 letting in t = 0.25: L = (1 − t)·ρ/π·E,
        // with ρ and t as the 8-bit G-buffer stores them (102/255 = 0.4 and 64/255; 0.5 would be
        // 127.5, a rounding tie that devices break either way).
        let camera = Camera {
            position: [0.0, 4.0, 0.01],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 40.0,
            near: 0.1,
            far: 20.0,
        };
        let sun = Light::Directional { direction: [0.0, -1.0, 0.0], color: [1.0; 3], intensity: std::f32::consts::PI };
        let mut sc = scene(vec![quad(Vec3::ZERO, Vec3::Z * 3.0, Vec3::X * 3.0, 0)], vec![sun], camera);
        sc.materials[0] = lambert(0.4);
        sc.materials[0].translucency = 0.25;
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let size = [16, 16];
        let mut targets = MeshTargets::new(ctx, size, 0).expect("targets");
        let settings = MeshSettings { ambient: [0.0; 3], shadow_tile: 256, ..Default::default() };
        let view = view_of(&camera);
        render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
        let img = targets.read_hdr(ctx).expect("readback");
        let (rho, t) = (102.0f32 / 255.0, 64.0f32 / 255.0);
        let want = (1.0 - t) * rho;
        let got = radiance_at(&img, size, &view, Vec3::ZERO);
        assert!((got - want).abs() <= 1e-3 * want, "translucent ground: {got} vs (1 − t)·ρ = {want}");
    });
}

/// Red radiance at the image centre of a 32² frame of `sc` (no ambient light, black sky).
fn centre_radiance(ctx: &vkengine::vk::Context, sc: &Scene, settings: MeshSettings) -> f32 {
    let gpu = GpuScene::upload(ctx, sc).expect("upload");
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let size = [32, 32];
    let mut targets = MeshTargets::new(ctx, size, 0).expect("targets");
    let settings = MeshSettings { ambient: [0.0; 3], sky: [0.0; 3], shadow_tile: 256, ..settings };
    render_frame(ctx, &renderer, &gpu, &mut targets, &view_of(&sc.camera), &settings).expect("render");
    let img = targets.read_hdr(ctx).expect("readback");
    img[(16 * size[0] + 16) as usize][0]
}

#[test]
fn a_single_sided_quad_seen_from_behind_is_culled_unless_double_sided_or_culling_is_off() {
    common::gpu_test(|ctx| {
        // A quad facing +z, lit head-on by a sun of E = π on whichever side the camera is:
        // L = ρ/π·E = ρ (ρ = 0.4, which the 8-bit G-buffer stores exactly as 102/255; 0.5 would
        // sit on a rounding tie). The sky is black.
        let rho = 102.0f32 / 255.0;
        let view_from = |z: f32| {
            let camera = camera([0.0, 0.0, z], [0.0; 3], [0.0, 1.0, 0.0], 40.0);
            let sun =
                Light::Directional { direction: [0.0, 0.0, -z], color: [1.0; 3], intensity: std::f32::consts::PI };
            let mut sc = scene(vec![quad(Vec3::ZERO, Vec3::X, Vec3::Y, 0)], vec![sun], camera);
            sc.materials[0] = lambert(rho);
            sc
        };
        let front = centre_radiance(ctx, &view_from(4.0), MeshSettings::default());
        assert!((front - rho).abs() < 1e-3, "front face: {front} vs ρ = {rho}");
        let behind = view_from(-4.0);
        let culled = centre_radiance(ctx, &behind, MeshSettings::default());
        assert_eq!(culled, 0.0, "a single-sided quad seen from behind must show the black sky");
        let unculled = centre_radiance(ctx, &behind, MeshSettings { cull: false, ..Default::default() });
        assert!((unculled - rho).abs() < 1e-3, "cull=0: the back face is drawn and lit: {unculled} vs {rho}");
        let mut two_sided = behind.clone();
        two_sided.materials[0].double_sided = true;
        let drawn = centre_radiance(ctx, &two_sided, MeshSettings::default());
        assert!((drawn - rho).abs() < 1e-3, "double-sided: the back face is drawn and lit: {drawn} vs {rho}");
    });
}

#[test]
fn shadow_maps_cull_the_same_back_faces_as_the_camera() {
    common::gpu_test(|ctx| {
        // As in the box test (`render_top_down`): a quad at y = 2 over x, z in [−1, 1] shades
        // the ground at x in [0, 2]; ground at x = 1.7 is visible. Facing down, the sun sees the
        // quad's back: culled in the shadow map, no shadow.
        let ground = quad(Vec3::ZERO, Vec3::Z * 6.0, Vec3::X * 6.0, 0);
        let c = Vec3::new(0.0, 2.0, 0.0);
        let render = |occluder, cull| {
            let (img, view, _) = render_top_down(ctx, vec![ground.clone(), occluder], cull);
            radiance_at(&img, TOP_SIZE, &view, Vec3::new(1.7, 0.0, 0.0))
        };
        let lit = 0.5 * 2.0 / 5f32.sqrt();
        let facing_up = render(quad(c, Vec3::Z, Vec3::X, 0), true);
        assert!(facing_up < 0.02 * lit, "a quad facing the sun casts a shadow: {facing_up}");
        let facing_down = render(quad(c, Vec3::X, Vec3::Z, 0), true);
        assert!((facing_down - lit).abs() < 0.02 * lit, "a quad showing the sun its back casts none: {facing_down}");
        let unculled = render(quad(c, Vec3::X, Vec3::Z, 0), false);
        assert!(unculled < 0.02 * lit, "cull=0: the same quad casts a shadow: {unculled}");
    });
}

#[test]
fn a_bmp_texture_named_by_an_mtl_colours_the_rendered_surface() {
    common::gpu_test(|ctx| {
        // A unit quad facing +z, textured with a uniform sRGB (200, 60, 20) BMP and Kd 1, lit
        // head-on by E = π with no ambient: L = ρ, ρ the texture's linear colour.
        let dir = std::env::temp_dir().join(format!("vkengine-bmp-render-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let texel = [200u8, 60, 20];
        image::RgbImage::from_pixel(4, 4, image::Rgb(texel))
            .save_with_format(dir.join("t.bmp"), image::ImageFormat::Bmp)
            .expect("write bmp");
        std::fs::write(dir.join("m.mtl"), "newmtl t\nKd 1 1 1\nKs 0 0 0\nmap_Kd t.bmp\n").expect("mtl");
        let obj = dir.join("quad.obj");
        std::fs::write(
            &obj,
            "mtllib m.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n\
             usemtl t\nf 1/1/1 2/2/1 3/3/1 4/4/1\n",
        )
        .expect("obj");
        let mut sc = vkengine::scene::load_scene(&obj).expect("load");
        assert!(sc.warnings.iter().all(|w| !w.contains("texture")), "{:?}", sc.warnings);
        sc.camera = camera([0.0, 0.0, 4.0], [0.0; 3], [0.0, 1.0, 0.0], 40.0);
        let sun = Light::Directional { direction: [0.0, 0.0, -1.0], color: [1.0; 3], intensity: std::f32::consts::PI };
        sc.lights = vec![sun];
        let got = centre_radiance(ctx, &sc, MeshSettings::default());
        let srgb = |c: u8| {
            let c = c as f32 / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        };
        let want = srgb(texel[0]);
        // The 8-bit G-buffer rounds ρ to 1/255; the white fallback would give 1.
        assert!((got - want).abs() < 2.0 / 255.0, "textured red {got} vs the texture's {want}");
        let _ = std::fs::remove_dir_all(&dir);
    });
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|c| c / l)
}

/// Energy-normalised Blinn–Phong (`lighting.comp`'s header): f = ρ/π + ks·(s+8)/(8π)·(n·h)^s.
fn blinn_phong(rho: f64, ks: f64, s: f64, n_dot_h: f64) -> f64 {
    rho / std::f64::consts::PI + ks * (s + 8.0) / (8.0 * std::f64::consts::PI) * n_dot_h.max(0.0).powf(s)
}

#[test]
fn blinn_phong_lobe_of_a_sunlit_quad_matches_the_energy_normalised_formula() {
    common::gpu_test(|ctx| {
        // A 6 m quad facing up, lit by the sun from l = (1, 2, 0)/√5 (E = 2), seen from the
        // mirror direction (-1, 2, 0)/√5: the centre pixel sits on the lobe's peak (n·h = 1)
        // and the others sweep its sides (the view direction changes across the image). Every
        // pixel must show L = f(ρ, ks, s, n·h)·E·(n·l), evaluated here in f64 at the point the
        // pixel shades. ρ and ks are multiples of 1/255, which the 8-bit G-buffer stores exactly;
        // the shininess is stored in 8 bits as log2(s)/12, so the reference is the range of L
        // over s·2^(±6/255) (half a step), plus 1e-4 for f32 arithmetic.
        let size = [32u32, 32];
        let (rho, ks, e) = (128.0 / 255.0, 64.0 / 255.0, 2.0f64);
        let l = unit([1.0, 2.0, 0.0]);
        let r = unit([-1.0, 2.0, 0.0]);
        let camera = Camera {
            position: r.map(|c| (c * 3.0) as f32),
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 40.0,
            near: 0.1,
            far: 20.0,
        };
        let sun = Light::Directional { direction: l.map(|c| -c as f32), color: [1.0; 3], intensity: e as f32 };
        let settings = MeshSettings { ambient: [0.0; 3], sky: [0.0; 3], cascades: 0, ..Default::default() };
        let view = view_of(&camera);
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        for s in [5.0f64, 16.0, 100.0, 1000.0] {
            let mut sc = scene(vec![quad(Vec3::ZERO, Vec3::Z * 3.0, Vec3::X * 3.0, 0)], vec![sun.clone()], camera);
            sc.materials[0].base_color = [rho as f32, rho as f32, rho as f32, 1.0];
            sc.materials[0].specular = [ks as f32; 3];
            sc.materials[0].shininess = s as f32;
            let gpu = GpuScene::upload(ctx, &sc).expect("upload");
            let mut targets = MeshTargets::new(ctx, size, 0).expect("targets");
            render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
            let img = targets.read_hdr(ctx).expect("readback");
            let eye = view.position.map(f64::from);
            let (mut peak, mut checked) = (0.0f64, 0);
            for py in 0..size[1] {
                for px in 0..size[0] {
                    let Some(x) = shaded_point(&view, size, px, py, 0.0) else { continue };
                    if x[0].abs() > 2.9 || x[2].abs() > 2.9 {
                        continue;
                    }
                    let v = unit([eye[0] - x[0], eye[1] - x[1], eye[2] - x[2]]);
                    let n_dot_h = unit([v[0] + l[0], v[1] + l[1], v[2] + l[2]])[1];
                    let at = |s: f64| blinn_phong(rho, ks, s, n_dot_h) * e * l[1];
                    let step = 2f64.powf(6.0 / 255.0);
                    let (a, b) = (at(s / step), at(s * step));
                    let (lo, hi) = (a.min(b).min(at(s)), a.max(b).max(at(s)));
                    let got = f64::from(img[(py * size[0] + px) as usize][0]);
                    assert!(
                        got >= lo * (1.0 - 1e-4) && got <= hi * (1.0 + 1e-4),
                        "s = {s}: pixel ({px}, {py}) with n·h = {n_dot_h:.6} shows {got}, Blinn–Phong gives {:.6} (range {lo:.6}..{hi:.6})",
                        at(s)
                    );
                    peak = peak.max(n_dot_h);
                    checked += 1;
                }
            }
            assert!(
                checked > 600 && peak > 0.9999,
                "s = {s}: {checked} pixels checked, the lobe's peak missed ({peak})"
            );
        }
    });
}

/// A camera 5 m above the origin looking straight down (−z up in the image) and a sun shining
/// straight down with E = π (so a Lambert surface of albedo ρ shows L = ρ).
fn overhead_camera_and_sun() -> (Camera, Light) {
    let camera = Camera {
        position: [0.0, 5.0, 0.0],
        target: [0.0; 3],
        up: [0.0, 0.0, -1.0],
        fov_y_deg: 40.0,
        near: 0.1,
        far: 20.0,
    };
    (camera, Light::Directional { direction: [0.0, -1.0, 0.0], color: [1.0; 3], intensity: std::f32::consts::PI })
}

#[test]
fn normal_and_specular_maps_shade_as_their_texels_say() {
    common::gpu_test(|ctx| {
        // Two quads facing up (tangent +z, bitangent +x), lit straight down (E = π, no shadows),
        // seen from above, Lambert ρ = 0.6. The left one's normal map is one texel m (decoded
        // m = t·2 − 1) leaning the normal toward +z: L = ρ·m_z/|m|. The right one is specular
        // (ks = 1, s = 16; the mirror direction is the camera's) under a black specular map:
        // L = ρ exactly. The G-buffer has a variant without either lookup for materials with
        // neither map; both fail if it is used for these.
        let size = [32u32, 32];
        let (camera, sun) = overhead_camera_and_sun();
        let left = quad(Vec3::new(-0.6, 0.0, 0.0), Vec3::Z * 0.5, Vec3::X * 0.5, 0);
        let right = quad(Vec3::new(0.6, 0.0, 0.0), Vec3::Z * 0.5, Vec3::X * 0.5, 1);
        let mut sc = scene(vec![left, right], vec![sun], camera);
        let texel = [218u8, 128, 218, 255];
        sc.textures.push(vkengine::scene::Texture::from_rgba8("lean", 4, 4, false, texel.repeat(16)));
        sc.textures.push(vkengine::scene::Texture::from_rgba8("black", 4, 4, false, [0, 0, 0, 255].repeat(16)));
        sc.materials = vec![
            vkengine::scene::Material { normal_tex: Some(0), ..common::scenes::lambert(0.6) },
            vkengine::scene::Material {
                specular: [1.0; 3],
                shininess: 16.0,
                specular_tex: Some(1),
                ..common::scenes::lambert(0.6)
            },
        ];
        let m = texel.map(|t| f64::from(t) / 255.0 * 2.0 - 1.0);
        let leaned = 0.6 * m[2] / (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        let settings = MeshSettings { ambient: [0.0; 3], sky: [0.0; 3], cascades: 0, ..Default::default() };
        let view = view_of(&camera);
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let mut targets = MeshTargets::new(ctx, size, 0).expect("targets");
        render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
        let img = targets.read_hdr(ctx).expect("readback");
        let mut seen = [0; 2];
        for py in 0..size[1] {
            for px in 0..size[0] {
                let Some(x) = shaded_point(&view, size, px, py, 0.0) else { continue };
                if x[2].abs() > 0.4 || x[0].abs() < 0.2 || x[0].abs() > 1.0 {
                    continue;
                }
                let (side, want) = if x[0] < 0.0 { (0, leaned) } else { (1, 0.6) };
                let got = f64::from(img[(py * size[0] + px) as usize][0]);
                // The leaned normal passes through the 16-bit float G-buffer.
                assert!(
                    (got - want).abs() <= 2e-3 * want,
                    "pixel ({px}, {py}) on the {} quad: {got}, expected {want}",
                    ["normal-mapped", "specular-mapped"][side]
                );
                seen[side] += 1;
            }
        }
        assert!(seen.iter().all(|&n| n > 20), "too few pixels checked: {seen:?}");
    });
}

#[test]
fn an_alpha_masked_cutout_shows_what_lies_behind_it() {
    common::gpu_test(|ctx| {
        // A 2 m quad at y = 1 over a ground quad, both lit straight down (E = π, no shadows). Its
        // 8×8 texture is transparent (alpha 0) for u < 0.5 and opaque for u ≥ 0.5, with an alpha
        // cutoff of 0.5; u runs along +z. Seen from above: where z < -0.2 the cut-out shows the
        // ground (Lambert ρ = 0.2: L = 0.2), where z > 0.2 the quad itself (ρ = 0.6: L = 0.6);
        // the texel or so around u = 0.5 that bilinear filtering blends is left out. With sun
        // shadows on, the cut-out must let the sun through to the ground as well: the shadow
        // pass draws masked materials with a fragment stage, opaque ones with none.
        let size = [32u32, 32];
        let (camera, sun) = overhead_camera_and_sun();
        let ground = quad(Vec3::ZERO, Vec3::Z * 4.0, Vec3::X * 4.0, 0);
        let cutout = quad(Vec3::Y, Vec3::Z, Vec3::X, 1);
        let mut sc = scene(vec![ground, cutout], vec![sun], camera);
        sc.materials[0] = common::scenes::lambert(0.2);
        let pixels: Vec<u8> = (0..64).flat_map(|i| [255, 255, 255, if i % 8 < 4 { 0 } else { 255 }]).collect();
        sc.textures.push(vkengine::scene::Texture::from_rgba8("half transparent", 8, 8, true, pixels));
        sc.materials.push(vkengine::scene::Material {
            base_color_tex: Some(0),
            alpha_mode: vkengine::scene::AlphaMode::Mask(0.5),
            ..common::scenes::lambert(0.6)
        });
        let view = view_of(&camera);
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let renderer = MeshRenderer::new(ctx).expect("renderer");
        let mut targets = MeshTargets::new(ctx, size, 0).expect("targets");
        for cascades in [0, 1] {
            let settings = MeshSettings { ambient: [0.0; 3], sky: [0.0; 3], cascades, ..Default::default() };
            render_frame(ctx, &renderer, &gpu, &mut targets, &view, &settings).expect("render");
            let img = targets.read_hdr(ctx).expect("readback");
            let (mut cut, mut solid) = (0, 0);
            for py in 0..size[1] {
                for px in 0..size[0] {
                    let Some(x) = shaded_point(&view, size, px, py, 1.0) else { continue };
                    if x[0].abs() > 0.9 || x[2].abs() > 0.9 || x[2].abs() < 0.2 {
                        continue;
                    }
                    let want = if x[2] < 0.0 { 0.2 } else { 0.6 };
                    let got = f64::from(img[(py * size[0] + px) as usize][0]);
                    assert!(
                        (got - want).abs() <= 1e-4 * want,
                        "{cascades} shadow cascades: pixel ({px}, {py}) over z = {:.3}: {got}, expected {want}",
                        x[2]
                    );
                    if x[2] < 0.0 {
                        cut += 1;
                    } else {
                        solid += 1;
                    }
                }
            }
            assert!(cut > 30 && solid > 30, "too few pixels on either side: {cut} cut out, {solid} solid");
        }
    });
}
