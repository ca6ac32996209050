//! The CPU diffuse-lighting reference (engine/mesh/reference.rs) against brute force and analytic answers.

use std::f64::consts::PI;

use glam::{Vec3, Vec4};
use vkengine::lpv::bvh::{intersect_triangle, Bvh};
use vkengine::mesh::camera::View;
use vkengine::mesh::reference::{render, ReferenceImages, ReferenceSettings, Tracer};
use vkengine::scene::procedural::{add_box, add_quad, cornell_box};
use vkengine::scene::{Light, Material, Mesh, Scene};

fn diffuse(rgb: [f32; 3]) -> Material {
    Material { base_color: [rgb[0], rgb[1], rgb[2], 1.0], ..Material::default() }
}

fn quad(material: usize, corners: [[f32; 3]; 4]) -> Mesh {
    let mut m = Mesh { name: format!("quad{material}"), material, ..Mesh::default() };
    add_quad(&mut m, corners);
    m
}

/// A horizontal square at height `y`, centred on the origin, facing up (`up`) or down.
fn square(material: usize, half: f32, y: f32, up: bool) -> Mesh {
    let (a, b, c, d) = ([-half, y, -half], [-half, y, half], [half, y, half], [half, y, -half]);
    quad(material, if up { [a, b, c, d] } else { [a, d, c, b] })
}

fn scene(meshes: Vec<Mesh>, materials: Vec<Material>, lights: Vec<Light>) -> Scene {
    let mut s = Scene::from_parts(meshes, materials, Vec::new());
    s.lights = lights;
    s
}

fn sun(direction: Vec3, irradiance: f32) -> Light {
    Light::Directional { direction: direction.normalize().into(), color: [1.0; 3], intensity: irradiance }
}

fn settings(samples: u32) -> ReferenceSettings {
    ReferenceSettings { samples, seed: 1, ..ReferenceSettings::default() }
}

/// The pixel centre's camera ray, built the way the GPU's lighting pass unprojects it.
fn camera_ray(view: &View, size: [u32; 2], x: u32, y: u32) -> (Vec3, Vec3) {
    let inv = view.view_proj(size[0] as f32 / size[1] as f32).inverse();
    let ndc = [(x as f32 + 0.5) / size[0] as f32 * 2.0 - 1.0, (y as f32 + 0.5) / size[1] as f32 * 2.0 - 1.0];
    let w = inv * Vec4::new(ndc[0], ndc[1], 1.0, 1.0);
    let p = Vec3::from(view.position);
    (p, (w.truncate() / w.w - p).normalize())
}

/// Where the pixel's camera ray crosses the plane at height `h`.
fn on_plane(view: &View, size: [u32; 2], x: u32, y: u32, h: f32) -> Vec3 {
    let (o, d) = camera_ray(view, size, x, y);
    o + d * ((h - o.y) / d.y)
}

/// The pixel that sees world point `p`.
fn pixel_of(view: &View, size: [u32; 2], p: Vec3) -> usize {
    let c = view.view_proj(size[0] as f32 / size[1] as f32) * p.extend(1.0);
    let (x, y) = ((c.x / c.w * 0.5 + 0.5) * size[0] as f32, (c.y / c.w * 0.5 + 0.5) * size[1] as f32);
    assert!(x >= 0.0 && y >= 0.0 && x < size[0] as f32 && y < size[1] as f32, "{p} is off screen");
    y as usize * size[0] as usize + x as usize
}

/// xorshift64*: test inputs only.
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u32 << 24) as f32
    }

    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32()) * (hi - lo) + Vec3::splat(lo)
    }
}

#[test]
fn bvh_matches_brute_force() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let tris: Vec<[Vec3; 3]> = (0..400)
        .map(|_| {
            let c = rng.vec(-1.0, 1.0);
            [c + rng.vec(-0.3, 0.3), c + rng.vec(-0.3, 0.3), c + rng.vec(-0.3, 0.3)]
        })
        .collect();
    let bvh = Bvh::new(&tris);
    assert_eq!(bvh.len(), tris.len());
    let mut hits = 0;
    for _ in 0..1000 {
        let o = rng.vec(-2.0, 2.0);
        let d = (rng.vec(-1.0, 1.0) - o).normalize();
        let mut brute: Option<(f32, usize)> = None;
        for (i, t) in tris.iter().enumerate() {
            if let Some((t, _, _)) = intersect_triangle(*t, o, d, 0.0, brute.map_or(f32::INFINITY, |b| b.0)) {
                brute = Some((t, i));
            }
        }
        let got = bvh.closest_hit(o, d, 0.0, f32::INFINITY);
        match (brute, got) {
            (None, None) => assert!(!bvh.any_hit(o, d, 0.0, f32::INFINITY)),
            (Some((t, i)), Some(h)) => {
                hits += 1;
                assert_eq!(h.triangle as usize, i, "ray {o} {d}");
                assert!((h.t - t).abs() <= 1e-5 * t, "t {} vs brute force {t}", h.t);
                let p = tris[i][0] + h.u * (tris[i][1] - tris[i][0]) + h.v * (tris[i][2] - tris[i][0]);
                assert!((p - (o + d * t)).length() < 1e-5, "barycentrics give {p}");
                assert!(bvh.any_hit(o, d, 0.0, f32::INFINITY));
                // Nothing is nearer than the closest hit.
                assert!(!bvh.any_hit(o, d, 0.0, 0.999 * t));
            }
            (b, g) => panic!("ray {o} {d}: brute force {b:?}, BVH {g:?}"),
        }
    }
    // Most rays aim into the triangle cloud: the comparison must have been exercised.
    assert!(hits > 500, "only {hits} hits");
}

#[test]
fn direct_sun_lighting_and_shadow_are_analytic() {
    let dir = Vec3::new(1.0, -2.0, 0.0);
    let mut ground = square(0, 50.0, 0.0, true);
    add_box(&mut ground, [-1.0, 1.0, -1.0], [1.0, 2.0, 1.0]);
    let s = scene(vec![ground], vec![diffuse([0.5; 3])], vec![sun(dir, std::f32::consts::PI)]);
    let view = View::look_at(Vec3::new(0.0, 6.0, 8.0), Vec3::new(0.75, 0.0, 0.0), Vec3::Y, 60.0, 0.1, 100.0);
    let size = [64, 48];
    let img = render(&s, &view, size, &settings(0)).expect("render");
    // ρ/π · E · cosθ with E = π, cosθ = n·l = 2/√5.
    let expected = 0.5 * 2.0 / 5f32.sqrt();
    let lit = pixel_of(&view, size, Vec3::new(-2.0, 0.0, 2.0));
    assert!(img.hit[lit]);
    for c in &img.direct[lit][..3] {
        assert!((c - expected).abs() <= 1e-4 * expected, "lit ground reads {c}, expected {expected}");
    }
    // The box's shadow on the ground covers x ∈ [−0.5, 2] at z ∈ [−1, 1].
    let shadow = pixel_of(&view, size, Vec3::new(0.75, 0.0, 0.0));
    assert!(img.hit[shadow]);
    assert_eq!(img.direct[shadow], [0.0, 0.0, 0.0, 1.0]);
    assert!(img.indirect.iter().all(|c| *c == [0.0, 0.0, 0.0, 1.0]), "0 samples must give no indirect light");
}

/// Form factor from a point at height `h` above the origin to the parallel rectangle `[0, a] × [0, b]`,
/// odd in `a` and `b` so rectangles anywhere follow by inclusion–exclusion.
fn corner_form_factor(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

/// Cosine-weighted fraction of the hemisphere below `p` covered by the rectangle `[x0, x1] × [z0, z1]`
/// in the plane y = 0.
fn form_factor(p: Vec3, [x0, x1]: [f64; 2], [z0, z1]: [f64; 2]) -> f64 {
    let (px, pz, h) = (p.x as f64, p.z as f64, p.y as f64);
    let g = |x: f64, z: f64| corner_form_factor(x - px, z - pz, h);
    g(x1, z1) - g(x0, z1) - g(x1, z0) + g(x0, z0)
}

/// A 2 km sunlit ground and, 5 m above it, a 0.2 m quad; `wound_down` winds both so their front faces
/// point down (double-sided shading must not care).
fn one_bounce_scene(ground_albedo: f32, wound_down: bool) -> Scene {
    scene(
        vec![square(0, 1000.0, 0.0, !wound_down), square(1, 0.1, 5.0, !wound_down)],
        vec![diffuse([ground_albedo; 3]), diffuse([0.8; 3])],
        vec![sun(Vec3::NEG_Y, 2.0)],
    )
}

fn one_bounce_view() -> View {
    View::look_at(Vec3::new(0.0, 2.5, 0.0), Vec3::new(0.0, 5.0, 0.0), Vec3::Z, 8.0, 0.1, 100.0)
}

#[test]
fn one_bounce_under_a_sunlit_ground_is_analytic() {
    let (rho_g, rho_p, e) = (0.5f64, 0.8f64, 2.0f64);
    let view = one_bounce_view();
    let size = [16, 16];
    let lg = rho_g * e / PI;
    // Front faces down: the quad is seen from its front, the ground lit from its back. Then up: the
    // quad's underside is a back face whose normal must flip towards the camera (and away from the sun).
    for wound_down in [true, false] {
        let img = render(&one_bounce_scene(rho_g as f32, wound_down), &view, size, &settings(4096)).expect("render");
        // Per pixel: the estimate over ρp·Lg minus its expectation, the fraction of the hemisphere that
        // sees sunlit ground: all of the ground minus the quad's own shadow right below it.
        let mut residuals = Vec::new();
        for (i, (&hit, ind)) in img.hit.iter().zip(&img.indirect).enumerate() {
            if !hit {
                assert_eq!((img.direct[i], *ind), ([0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]));
                continue;
            }
            // The camera sees the underside; the sun lights the top: no direct light.
            assert_eq!(img.direct[i], [0.0, 0.0, 0.0, 1.0], "pixel {i}");
            assert!(ind[0] == ind[1] && ind[1] == ind[2]);
            let p = on_plane(&view, size, i as u32 % size[0], i as u32 / size[0], 5.0);
            let seen = form_factor(p, [-1000.0, 1000.0], [-1000.0, 1000.0]) - form_factor(p, [-0.1, 0.1], [-0.1, 0.1]);
            residuals.push(ind[0] as f64 / (rho_p * lg) - seen);
        }
        let n = residuals.len() as f64;
        assert!(n >= 50.0, "only {n} pixels see the quad");
        let mean = residuals.iter().sum::<f64>() / n;
        let var = residuals.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let se = (var / n).sqrt();
        assert!(mean.abs() <= 3.0 * se, "relative bias {mean:e} vs standard error {se:e} ({wound_down})");
        // The test resolves the shadow's ~5e-4 share of the hemisphere: ignoring it would fail.
        let shadow = form_factor(Vec3::new(0.0, 5.0, 0.0), [-0.1, 0.1], [-0.1, 0.1]);
        assert!(shadow > 6.0 * se, "shadow fraction {shadow:e} not resolved by standard error {se:e}");
    }

    // A black ground reflects nothing: the estimator has no other source of light.
    let lit = render(&one_bounce_scene(0.5, true), &view, size, &settings(64)).expect("render");
    let black = render(&one_bounce_scene(0.0, true), &view, size, &settings(64)).expect("render");
    assert_eq!(black.hit, lit.hit);
    assert!(lit.indirect.iter().zip(&lit.hit).all(|(c, &h)| !h || c[0] > 0.0));
    assert!(black.indirect.iter().all(|c| *c == [0.0, 0.0, 0.0, 1.0]));
}

#[test]
fn spot_light_is_analytic() {
    let (albedo, intensity) = (0.6f32, Vec3::new(4.0, 2.0, 1.0));
    let (inner, outer) = (20f32.to_radians(), 30f32.to_radians());
    let spot = Light::Spot {
        position: [0.0, 1.0, 0.0],
        direction: [0.0, -1.0, 0.0],
        color: [1.0, 0.5, 0.25],
        intensity: 4.0,
        inner_angle: inner,
        outer_angle: outer,
        range: 10.0,
    };
    let s = scene(vec![square(0, 10.0, 0.0, true)], vec![diffuse([albedo; 3])], vec![spot]);
    let view = View::look_at(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO, Vec3::Z, 60.0, 0.1, 100.0);
    let size = [33, 33];
    let img = render(&s, &view, size, &settings(0)).expect("render");
    // Odd size: the centre pixel's ray is the view axis, straight down onto the point under the spot.
    let centre = 16 * 33 + 16;
    let peak = intensity * (albedo / std::f32::consts::PI);
    for k in 0..3 {
        let c = img.direct[centre][k];
        assert!((c - peak[k]).abs() <= 1e-4 * peak[k], "under the spot: {c} vs {}", peak[k]);
    }
    let outside = pixel_of(&view, size, Vec3::new(40f32.to_radians().tan(), 0.0, 0.0));
    assert_eq!(img.direct[outside], [0.0, 0.0, 0.0, 1.0]);
    // Everywhere: ρ/π · I · smoothstep(cos outer, cos inner, cos α) · cos α / d², with cos α = 1/d.
    for (i, c) in img.direct.iter().enumerate() {
        let p = on_plane(&view, size, i as u32 % 33, i as u32 / 33, 0.0).as_dvec3();
        let d2 = 1.0 + p.x * p.x + p.z * p.z;
        let cos = 1.0 / d2.sqrt();
        let t = ((cos - (outer as f64).cos()) / ((inner as f64).cos() - (outer as f64).cos())).clamp(0.0, 1.0);
        let f = t * t * (3.0 - 2.0 * t) * cos / d2;
        for k in 0..3 {
            let expected = peak[k] as f64 * f;
            assert!((c[k] as f64 - expected).abs() <= 1e-4 * peak[k] as f64, "pixel {i}: {c:?} vs {expected}");
        }
    }
}

fn cornell(size: [u32; 2], samples: u32, threads: usize) -> (View, ReferenceImages) {
    let s = cornell_box();
    let c = s.camera;
    let view = View::look_at(c.position.into(), c.target.into(), c.up.into(), c.fov_y_deg, c.near, c.far);
    let settings = ReferenceSettings { samples, seed: 7, threads, ..ReferenceSettings::default() };
    (view, render(&s, &view, size, &settings).expect("render"))
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let (_, one) = cornell([24, 20], 8, 1);
    let (_, two) = cornell([24, 20], 8, 2);
    let bits = |img: &ReferenceImages| -> Vec<u32> {
        img.direct.iter().chain(&img.indirect).flatten().map(|v| v.to_bits()).collect()
    };
    assert_eq!(bits(&one), bits(&two));
    assert_eq!(one.hit, two.hit);
}

#[test]
fn bad_input_is_an_error() {
    let s = one_bounce_scene(0.5, true);
    let view = one_bounce_view();
    assert!(render(&s, &view, [0, 4], &settings(1)).is_err());
    assert!(render(&s, &view, [4, 0], &settings(1)).is_err());
    let empty = scene(Vec::new(), vec![diffuse([0.5; 3])], Vec::new());
    assert!(Tracer::new(&empty).is_err());
    let no_triangles =
        scene(vec![Mesh { positions: vec![[0.0; 3]; 2], ..Mesh::default() }], vec![diffuse([0.5; 3])], vec![]);
    assert!(Tracer::new(&no_triangles).is_err());
    let mut bad_index = one_bounce_scene(0.5, true);
    bad_index.meshes[0].indices[2] = 99;
    assert!(Tracer::new(&bad_index).is_err());
    let mut bad_material = one_bounce_scene(0.5, true);
    bad_material.meshes[1].material = 5;
    assert!(Tracer::new(&bad_material).is_err());
    let mut nan_camera = view;
    nan_camera.position[1] = f32::NAN;
    assert!(render(&s, &nan_camera, [4, 4], &settings(1)).is_err());
    let mut looking_along_up = view;
    looking_along_up.up = view.forward;
    assert!(render(&s, &looking_along_up, [4, 4], &settings(1)).is_err());
}

#[test]
fn cornell_box_bleeds_colour() {
    let size = [32, 32];
    let (view, img) = cornell(size, 16, 0);
    let hits = img.hit.iter().filter(|&&h| h).count();
    assert!(hits > 32 * 32 / 2, "{hits} hit pixels");
    for c in img.direct.iter().chain(&img.indirect) {
        assert!(c.iter().all(|v| v.is_finite() && *v >= 0.0) && c[3] == 1.0, "{c:?}");
    }
    let lit = img.indirect.iter().zip(&img.hit).filter(|(c, &h)| h && c[0] > 0.0).count();
    assert!(lit * 10 >= hits * 9, "indirect light on only {lit} of {hits} hit pixels");
    // Floor patches in front of the blocks, next to the red (x ≈ 0.55) and green (x = 0) walls.
    let floor_sum = |x: [f32; 2]| {
        let mut sum = [0f64; 3];
        let mut n = 0;
        for i in 0..img.hit.len() {
            let p = on_plane(&view, size, i as u32 % size[0], i as u32 / size[0], 0.0);
            if img.hit[i] && p.x > x[0] && p.x < x[1] && p.z > 0.0 && p.z < 0.2 {
                (0..3).for_each(|k| sum[k] += img.indirect[i][k] as f64);
                n += 1;
            }
        }
        assert!(n >= 4, "only {n} pixels on the floor patch {x:?}");
        sum
    };
    let by_red = floor_sum([0.4, 0.54]);
    let by_green = floor_sum([0.01, 0.07]);
    assert!(by_red[0] > by_red[1], "floor by the red wall: {by_red:?}");
    // The light is orange, so red > green holds anywhere; bleeding shows in the balance between walls.
    let (red_ratio, green_ratio) = (by_red[0] / by_red[1], by_green[0] / by_green[1]);
    assert!(red_ratio > 1.5 * green_ratio, "R/G by the red wall {red_ratio}, by the green wall {green_ratio}");
}

#[test]
fn sky_term_is_albedo_times_radiance_in_the_open_and_the_escaping_fraction_under_a_roof() {
    // Ground (albedo 0.5, half 2 m) at y = 0; in the second scene a 20 m roof at y = 1 above it.
    // Cosine-weighted directions from the ground's centre escape below the roof only within
    // the elevation atan(1/10) of the horizon: a fraction sin²(atan 0.1) of the samples.
    let sky = [0.2f32, 0.4, 0.8];
    let view = View::look_at(Vec3::new(0.0, 0.5, 1.0), Vec3::ZERO, Vec3::Y, 60.0, 0.05, 50.0);
    let size = [9, 9];
    let materials = vec![diffuse([0.5; 3])];
    let light = vec![sun(Vec3::new(0.0, -1.0, 0.0), 1.0)];
    let samples = 4096;
    let rs = ReferenceSettings { samples, seed: 3, sky, ..ReferenceSettings::default() };
    let open = render(&scene(vec![square(0, 2.0, 0.0, true)], materials.clone(), light.clone()), &view, size, &rs)
        .expect("open");
    let centre = pixel_of(&view, size, Vec3::ZERO);
    assert!(open.hit[centre]);
    for (ch, &l) in sky.iter().enumerate() {
        // Every upward sample escapes: no Monte Carlo noise at all.
        assert_eq!(open.sky[centre][ch], 0.5 * l, "open ground, channel {ch}");
    }
    let roofed = scene(vec![square(0, 2.0, 0.0, true), square(0, 10.0, 1.0, false)], materials, light);
    let covered = render(&roofed, &view, size, &rs).expect("roofed");
    let want = (0.1f64.atan().sin()).powi(2);
    let got = covered.sky[centre][0] as f64 / (0.5 * sky[0] as f64);
    let sigma = (want * (1.0 - want) / samples as f64).sqrt();
    assert!((got - want).abs() <= 4.0 * sigma, "escaping fraction {got} vs sin²(atan 0.1) = {want} (σ {sigma})");
}
