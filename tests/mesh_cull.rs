//! Per-view triangle culling (`cull_triangles`, mesh/cull.comp) against drawing every triangle:
//! a frame must come out the same bit for bit — HDR image and all three RSM targets — through
//! every culled view (camera, sun cascades, a spot's perspective tile, the RSM, the LPV sky's
//! height map), on a scene built to reach each case of the test: triangles off screen, behind the
//! eye and crossing it, smaller than a pixel, back- and front-facing, single- and double-sided,
//! and coplanar twins whose draw order decides the image.
//! A consistency check of the optimisation (it has no analytic answer); it fails when the shader
//! drops a triangle that covers a sample (the bounding-box test's margin negative, the facing
//! test's sign flipped, a clip plane moved in, projected vertices behind the eye trusted) or
//! changes the survivors' order.

mod common;

use common::scenes::{boxed, camera, lambert, quad, scene, view_of};
use glam::Vec3;
use vkengine::lpv::settings::LpvSettings;
use vkengine::mesh::frame::{VIEW_CAMERA, VIEW_RSM, VIEW_SKY};
use vkengine::mesh::gpu_scene::GpuScene;
use vkengine::mesh::renderer::{render_frame, MeshRenderer, MeshSettings, MeshTargets};
use vkengine::scene::{Light, Mesh, Scene};

/// A mesh of `positions` with their `normals` (no texture coordinates or tangents to speak of).
fn mesh(name: &str, positions: Vec<[f32; 3]>, normals: Vec<[f32; 3]>, indices: Vec<u32>, material: usize) -> Mesh {
    let count = positions.len();
    Mesh {
        name: name.into(),
        positions,
        normals,
        uvs: vec![[0.0; 2]; count],
        tangents: vec![[1.0, 0.0, 0.0, 1.0]; count],
        indices,
        material,
    }
}

/// A grid of `n` × `n` quads over `[-h, h]²` at height y(x, z), every third quad wound the other
/// way (so both faces reach the facing test).
fn bumpy_grid(n: u32, h: f32, y: impl Fn(f32, f32) -> f32, material: usize) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (-h + 2.0 * h * i as f32 / n as f32, -h + 2.0 * h * j as f32 / n as f32);
            positions.push([x, y(x, z), z]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 2, a + n + 1);
            if (i + j * n).is_multiple_of(3) {
                indices.extend([a, b, c, a, c, d]);
            } else {
                indices.extend([a, c, b, a, d, c]);
            }
        }
    }
    let normals = vec![[0.0, 1.0, 0.0]; positions.len()];
    mesh("grid", positions, normals, indices, material)
}

/// A double-sided wall of `n` × `n` quads at x = `x`, from z0 to z1 and y = 0 to 3.
fn wall(x: f32, z0: f32, z1: f32, n: u32, material: usize) -> Mesh {
    let mut m = bumpy_grid(n, 1.0, |_, _| 0.0, material);
    for p in &mut m.positions {
        let (u, v) = (p[0] * 0.5 + 0.5, p[2] * 0.5 + 0.5);
        *p = [x, 3.0 * v, z0 + (z1 - z0) * u];
    }
    m.normals.iter_mut().for_each(|n| *n = [-1.0, 0.0, 0.0]);
    m
}

/// A UV sphere of `rings` × `segments` quads (outward-wound).
fn sphere(c: Vec3, r: f32, rings: u32, segments: u32, material: usize) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for j in 0..=rings {
        let theta = std::f32::consts::PI * j as f32 / rings as f32;
        for i in 0..=segments {
            let phi = std::f32::consts::TAU * i as f32 / segments as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            positions.push((c + r * n).to_array());
            normals.push(n.to_array());
        }
    }
    let mut indices = Vec::new();
    for j in 0..rings {
        for i in 0..segments {
            let a = j * (segments + 1) + i;
            let (b, cc, d) = (a + 1, a + segments + 2, a + segments + 1);
            indices.extend([a, cc, b, a, d, cc]);
        }
    }
    mesh("sphere", positions, normals, indices, material)
}

/// A patch of `n` × `n` quads at height `y`, each triangle drawn twice in a row at the same
/// place, first with the normal up, then tilted: depth ties that the first one drawn wins, so
/// the image shows the triangles' order.
fn twin_triangles(c: Vec3, h: f32, n: u32, material: usize) -> Mesh {
    let tilted = Vec3::new(0.6, 1.0, 0.2).normalize().to_array();
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let at = |di: u32, dj: u32| {
                let t = |k: u32| -h + 2.0 * h * k as f32 / n as f32;
                (c + Vec3::new(t(i + di), 0.0, t(j + dj))).to_array()
            };
            for tri in [[at(0, 0), at(1, 1), at(1, 0)], [at(0, 0), at(0, 1), at(1, 1)]] {
                for normal in [[0.0, 1.0, 0.0], tilted] {
                    indices.extend((0..3).map(|k| positions.len() as u32 + k));
                    positions.extend(tri);
                    normals.extend([normal; 3]);
                }
            }
        }
    }
    mesh("twins", positions, normals, indices, material)
}

/// The test scene: ~25k triangles, most of them culled by some view.
fn cull_scene() -> Scene {
    let mut meshes = vec![
        // Ground of small bumpy quads, larger than the view (off-screen and sub-pixel ones).
        bumpy_grid(64, 8.0, |x, z| 0.05 * (3.0 * x).sin() * (2.0 * z).cos(), 0),
        // A double-sided sphere and a single-sided one, and a far one smaller than a pixel.
        sphere(Vec3::new(0.0, 1.0, 0.0), 1.0, 32, 48, 1),
        sphere(Vec3::new(-2.5, 0.8, 1.5), 0.7, 24, 32, 0),
        sphere(Vec3::new(3.0, 0.4, -6.0), 0.04, 16, 24, 0),
        // A wall from behind the eye to beyond it, beside it: triangles cross the eye plane.
        wall(1.6, -3.0, 12.0, 24, 1),
        twin_triangles(Vec3::new(-1.5, 0.3, -1.5), 0.8, 12, 0),
        // A single-sided ceiling facing down, two triangles from behind the eye to far ahead:
        // seen from below, and with its back face up no light view draws it.
        quad(Vec3::new(0.0, 4.0, 1.0), Vec3::new(3.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 11.0), 0),
    ];
    meshes.extend(boxed(Vec3::new(1.5, 0.0, -2.0), Vec3::new(2.5, 1.5, -1.0), 0));
    // A fan of small spheres across and beyond the camera's view, one chunk each: whole chunks
    // outside a view, and chunks straddling its sides, for the chunks' box test.
    for k in 0..24 {
        let a = (k as f32 - 11.5) * 0.09;
        meshes.push(sphere(Vec3::new(6.0 * a.sin(), 1.2 + 0.3 * (k % 3) as f32, 7.0 - 6.0 * a.cos()), 0.35, 12, 16, 0));
    }
    let sun = Light::Directional { direction: [0.4, -1.0, 0.3], color: [1.0; 3], intensity: 3.0 };
    let spot = Light::Spot {
        position: [-1.0, 4.0, 2.0],
        direction: [0.2, -1.0, -0.3],
        color: [1.0, 0.8, 0.6],
        intensity: 20.0,
        inner_angle: 0.3,
        outer_angle: 0.6,
        range: 20.0,
    };
    let mut sc = scene(meshes, vec![sun, spot], camera([0.0, 2.5, 7.0], [0.0, 0.6, 0.0], [0.0, 1.0, 0.0], 55.0));
    let mut two_sided = lambert(0.7);
    two_sided.double_sided = true;
    sc.materials.push(two_sided);
    sc
}

/// One frame's HDR image and RSM targets as bits, and the triangles each culled view kept.
fn render(ctx: &vkengine::vk::Context, gpu: &GpuScene, sc: &Scene, cull_triangles: bool) -> (Vec<u32>, [u32; 11]) {
    let renderer = MeshRenderer::new(ctx).expect("renderer");
    let mut targets = MeshTargets::new(ctx, [160, 120], 64).expect("targets");
    let lpv = LpvSettings { enabled: true, cascades: 2, sky: 1.0, reuse: false, ..Default::default() };
    let settings =
        MeshSettings { shadow_tile: 256, cascades: 2, sky: [0.2, 0.3, 0.4], lpv, cull_triangles, ..Default::default() };
    render_frame(ctx, &renderer, gpu, &mut targets, &view_of(&sc.camera), &settings).expect("render");
    let mut bits: Vec<u32> = targets.read_hdr(ctx).expect("hdr").iter().flatten().map(|v| v.to_bits()).collect();
    for t in targets.read_rsm(ctx).expect("rsm") {
        bits.extend(t.iter().flatten().map(|v| v.to_bits()));
    }
    (bits, std::array::from_fn(|v| targets.cull_stats.kept(v as u32)))
}

#[test]
fn culled_views_render_the_same_frame_bit_for_bit() {
    common::gpu_test(|ctx| {
        let sc = cull_scene();
        let gpu = GpuScene::upload(ctx, &sc).expect("upload");
        let total = gpu.triangles as u32;
        let (all, _) = render(ctx, &gpu, &sc, false);
        let (culled, kept) = render(ctx, &gpu, &sc, true);
        eprintln!("{total} triangles; kept per view {kept:?}");
        // Every view culled something, and kept something: the comparison tests the culling.
        for v in [VIEW_CAMERA, 1, 2, 3, VIEW_RSM, VIEW_SKY] {
            let k = kept[v as usize];
            assert!(k > 0 && k < total, "view {v} kept {k} of {total} triangles");
        }
        assert!(kept[VIEW_CAMERA as usize] < total / 2, "the camera sees less than half: {kept:?}");
        let differ = all.iter().zip(&culled).filter(|(a, b)| a != b).count();
        assert_eq!(all.len(), culled.len());
        assert_eq!(differ, 0, "{differ} of {} values differ with culling on", all.len());
    });
}
