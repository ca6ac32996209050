//! View-dependent residency through the renderer, on lavapipe under validation: a 64³ volume
//! whose level-0 bricks are twice the device budget. A settled mixed cut renders (MIP) as the
//! volume at each shown level does: pixels whose rays meet only level-0 bricks match a render of
//! the level-0 volume, pixels whose rays meet only level-L bricks (and the level-L bricks before
//! them) match a render of the volume halved L times by block means in this file (an independent
//! halving, rendered as its own volume). An orbit of 36 views stays within the per-frame upload
//! budget, writes no more than it budgets, and shows the region each camera faces at level 0.

mod common;

use glam::{Vec3, Vec4};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::bricks::residency::BRICK_BYTES;
use vkengine::volume::data::Volume;
use vkengine::volume::device::layout::VolumeLayout;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{render_frame, RenderSettings, RendererKind, Targets, VolumeRenderer};

const N: u32 = 64;
const G: u32 = N / 8;
const SIZE: [u32; 2] = [48, 48];

/// Normalized level-0 voxels: a smooth pattern with hashed noise (every brick varies), an 8³
/// block of 65535 and one of 0 at opposite corners (so every level spans the same [0, 1] and
/// normalizes alike).
fn voxels() -> Vec<u16> {
    let mut out = Vec::with_capacity((N * N * N) as usize);
    for z in 0..N {
        for y in 0..N {
            for x in 0..N {
                let v = if x < 8 && y < 8 && z < 8 {
                    65535
                } else if x >= N - 8 && y >= N - 8 && z >= N - 8 {
                    0
                } else {
                    let (fx, fy, fz) = (x as f32, y as f32, z as f32);
                    let smooth = 0.45 + 0.3 * (0.41 * fx + 0.3 * fz).sin() * (0.33 * fy - 0.2 * fz).sin();
                    let h = x.wrapping_mul(73856093) ^ y.wrapping_mul(19349663) ^ z.wrapping_mul(83492791);
                    let noise = (h.wrapping_mul(2654435761) >> 16) as f32 / 65536.0;
                    ((smooth + 0.15 * noise).clamp(0.0, 0.99) * 65535.0).round() as u16
                };
                out.push(v);
            }
        }
    }
    out
}

/// `v` (n³) halved: each voxel the mean of its 2³ block, rounded to nearest (halves up).
fn halve(v: &[u16], n: u32) -> Vec<u16> {
    let (n, m) = (n as usize, n as usize / 2);
    let mut out = Vec::with_capacity(m * m * m);
    for z in 0..m {
        for y in 0..m {
            for x in 0..m {
                let mut s = 0u32;
                for (dx, dy, dz) in (0..8).map(|i| (i % 2, i / 2 % 2, i / 4)) {
                    s += u32::from(v[((2 * z + dz) * n + 2 * y + dy) * n + 2 * x + dx]);
                }
                out.push((f64::from(s) / 8.0).round() as u16);
            }
        }
    }
    out
}

fn volume(v: &[u16], n: u32, name: &str) -> Volume {
    let spacing = (N / n) as f32;
    let data = v.iter().map(|&x| f32::from(x) / 65535.0).collect();
    Volume::new([n; 3], [spacing; 3], data, name).expect("volume")
}

fn mip() -> RenderSettings {
    // One step for every render: the default follows the voxel count, which differs by level.
    RenderSettings { renderer: RendererKind::Mip, empty_space_skipping: true, step: Some(0.004), ..Default::default() }
}

fn render(ctx: &Context, r: &VolumeRenderer, cam: &Camera) -> Vec<[f32; 4]> {
    render_with(ctx, r, cam, &mip())
}

fn render_with(ctx: &Context, r: &VolumeRenderer, cam: &Camera, s: &RenderSettings) -> Vec<[f32; 4]> {
    let mut t = Targets::new(ctx, SIZE).expect("targets");
    render_frame(ctx, r, &mut t, cam, s, 0).expect("render");
    t.read_hdr(ctx).expect("readback")
}

/// Streams `cam`'s view until nothing changes and nothing is pending; checks every frame's
/// bytes. Returns the frames taken.
fn settle(ctx: &Context, r: &mut VolumeRenderer, cam: &Camera, upload: u64, what: &str) -> u32 {
    for k in 1..=80 {
        let rep = r.stream(ctx, cam, 1.0).expect("stream").expect("residency");
        let f = rep.upload;
        assert!(f.bytes <= upload, "{what} frame {k}: {} bytes budgeted, per-frame budget {upload}", f.bytes);
        assert!(
            rep.written_bytes <= f.bytes,
            "{what} frame {k}: {} bytes written to the device, {} budgeted",
            rep.written_bytes,
            f.bytes
        );
        if !f.changed && f.pending == 0 {
            return k;
        }
    }
    panic!("{what} does not settle in 80 frames");
}

/// Voxel coordinates of world point `w` in a box of half-extent `half`.
fn to_voxel(w: Vec3, half: Vec3) -> Vec3 {
    (w + half) / (2.0 * half) * N as f32
}

/// The level-0 bricks pixel `p`'s ray (as `volume/common.glsl`'s `camera_ray` casts it) meets,
/// each sample point widened by a voxel along every axis.
fn bricks_met(cam: &Camera, half: Vec3, p: [u32; 2]) -> Vec<[u32; 3]> {
    let inv = cam.inverse_view_projection(SIZE[0] as f32 / SIZE[1] as f32);
    let ndc = [(p[0] as f32 + 0.5) / SIZE[0] as f32 * 2.0 - 1.0, 1.0 - (p[1] as f32 + 0.5) / SIZE[1] as f32 * 2.0];
    let at = |d: f32| {
        let h = inv * Vec4::new(ndc[0], ndc[1], d, 1.0);
        to_voxel(h.truncate() / h.w, half)
    };
    let (o, f) = (at(0.0), at(1.0));
    let d = (f - o).normalize();
    let mut out = Vec::new();
    let mut t = 0.0;
    while t < (f - o).length() {
        let x = o + d * t;
        t += 0.25;
        if (0..3).any(|a| x[a] < -1.0 || x[a] > N as f32 + 1.0) {
            continue;
        }
        for c in 0..27 {
            let q = x + Vec3::new((c % 3) as f32 - 1.0, (c / 3 % 3) as f32 - 1.0, (c / 9) as f32 - 1.0);
            let b = [0, 1, 2].map(|a| ((q[a].clamp(0.5, N as f32 - 0.5) - 0.5) / 8.0).floor() as u32);
            if !out.contains(&b) {
                out.push(b);
            }
        }
    }
    out
}

/// The level every brick `bricks` names and the level-L bricks before each shows, when one.
fn one_level(levels: &[u32], bricks: &[[u32; 3]]) -> Option<u32> {
    let level = |b: [u32; 3]| levels[((b[2] * G + b[1]) * G + b[0]) as usize];
    let l = level(*bricks.first()?);
    let s = 1 << l;
    let all = bricks.iter().all(|&b| {
        (0..8u32).all(|c| {
            let q = [0, 1, 2].map(|a| if c >> a & 1 == 1 { b[a].saturating_sub(s) } else { b[a] });
            level(q) == l
        })
    });
    all.then_some(l)
}

/// Largest difference between neighbouring voxels of `v` (n³, normalized).
fn largest_step(v: &[u16], n: u32) -> f32 {
    let n = n as usize;
    let mut m = 0u16;
    for i in 0..v.len() {
        for d in [1, n, n * n] {
            if i + d < v.len() {
                m = m.max(v[i].abs_diff(v[i + d]));
            }
        }
    }
    f32::from(m) / 65535.0
}

#[test]
fn a_settled_mixed_cut_renders_as_each_shown_level() {
    common::gpu_test(|ctx| {
        let v0 = voxels();
        let vol = volume(&v0, N, "residency");
        let tf = TransferFunction::preset("cloud").expect("tf");
        let full = u64::from(G * G * G) * BRICK_BYTES;
        let (budget, upload) = (full / 2, 64 << 10);
        let mut r = VolumeRenderer::with_residency(ctx, &vol, &tf, budget, upload).expect("resident");
        // Streamed for a camera close to one face, rendered across it: levels vary along the
        // rows of the image, and columns of one level exist.
        let near = Camera::orbit(0.9, 0.0, 0.0, Projection::Perspective { fov_y: 70f32.to_radians() });
        let frames = settle(ctx, &mut r, &near, upload, "near view");
        let levels = r.shown_levels().expect("levels");
        let counts: Vec<usize> = (0..4).map(|l| levels.iter().filter(|&&x| x == l).count()).collect();
        eprintln!("settled in {frames} frames; level-0 bricks per shown level {counts:?}");
        assert!(counts[0] > 0 && counts[0] < levels.len(), "{counts:?}: not a mixed cut");
        let side = Camera::orbit(2.5, std::f32::consts::FRAC_PI_2, 0.0, Projection::Orthographic { height: 1.2 });
        let mut refs = Vec::new();
        let (mut v, mut n) = (v0.clone(), N);
        for _ in 0..4 {
            let rl = VolumeRenderer::with_layout(ctx, &volume(&v, n, "level"), &tf, VolumeLayout::Dense).expect("ref");
            // Positions agree to f32 rounding at atlas scale (≤ 512 texels × 2⁻²³ < 1e-4 texel).
            refs.push((rl, largest_step(&v, n)));
            if n > 8 {
                v = halve(&v, n);
                n /= 2;
            }
        }
        // Hardware filtering through the atlas, and `filter=exact` (texel fetches at the mapped
        // position, `trilinear_exact`). A texture unit that quantizes its weights may round the
        // atlas's and the plain texture's fractions differently: one weight step per axis's lerp
        // (0 on llvmpipe, which filters in f32).
        let q = common::quantized_filter_step(ctx);
        for (name, s) in [("mip", mip()), ("mip exact", RenderSettings { exact_filter: true, ..mip() })] {
            let weights = if s.exact_filter { 0.0 } else { 3.0 * q };
            let got = render_with(ctx, &r, &side, &s);
            let want: Vec<Vec<[f32; 4]>> = refs.iter().map(|(rl, _)| render_with(ctx, rl, &side, &s)).collect();
            let half = r.box_half();
            let mut checked = [0u32; 4];
            let mut worst = [0f32; 4];
            for py in 0..SIZE[1] {
                for px in 0..SIZE[0] {
                    let met = bricks_met(&side, half, [px, py]);
                    let Some(l) = one_level(&levels, &met) else { continue };
                    let i = (py * SIZE[0] + px) as usize;
                    let (want, tol) = (&want[l as usize][i], refs[l as usize].1 * (1e-4 + weights));
                    let d = (0..3).map(|c| (got[i][c] - want[c]).abs()).fold(0.0, f32::max);
                    assert!(
                        d <= tol,
                        "{name}: pixel ({px}, {py}) at level {l}: {:?}, the level's own {want:?}",
                        got[i]
                    );
                    checked[l as usize] += 1;
                    worst[l as usize] = worst[l as usize].max(d);
                }
            }
            eprintln!("{name}: pixels checked per level {checked:?}, largest differences {worst:?}");
            assert!(checked[0] >= 20 && checked[1..].iter().sum::<u32>() >= 20, "{name}: {checked:?}");
        }
    });
}

#[test]
fn an_orbit_stays_within_the_upload_budget_and_keeps_the_faced_region_at_level_0() {
    common::gpu_test(|ctx| {
        let vol = volume(&voxels(), N, "residency");
        let tf = TransferFunction::preset("cloud").expect("tf");
        let full = u64::from(G * G * G) * BRICK_BYTES;
        let (budget, upload) = (full / 2, 64 << 10);
        let mut r = VolumeRenderer::with_residency(ctx, &vol, &tf, budget, upload).expect("resident");
        let c = Vec3::splat(N as f32 / 2.0);
        let (mut frames, mut total) = (Vec::new(), 0u64);
        for i in 0..36 {
            let yaw = (i as f32 * 10.0).to_radians();
            let cam = Camera::orbit(1.5, yaw, 0.0, Projection::Perspective { fov_y: 75f32.to_radians() });
            frames.push(settle(ctx, &mut r, &cam, upload, &format!("view {i}")));
            assert!(r.resident_bytes().expect("residency") <= budget, "view {i}: past the device budget");
            // The quarter of the box nearest the eye (brick centres), whatever residency ranks.
            let dir = (to_voxel(cam.eye_forward().0, r.box_half()) - c).normalize();
            let levels = r.shown_levels().expect("levels");
            let (mut faced, mut coarse) = (0, 0);
            for (k, &l) in levels.iter().enumerate() {
                let b = [k as u32 % G, k as u32 / G % G, k as u32 / (G * G)];
                let centre = Vec3::new(b[0] as f32, b[1] as f32, b[2] as f32) * 8.0 + Vec3::splat(4.0);
                if (centre - c).dot(dir) >= N as f32 / 4.0 {
                    faced += 1;
                    coarse += u32::from(l > 0);
                }
            }
            assert!(faced >= 64, "view {i}: {faced} faced bricks");
            assert_eq!(coarse, 0, "view {i}: {coarse} of the {faced} faced bricks are coarser than level 0");
            assert!(levels.iter().any(|&l| l > 0), "view {i}: all at level 0, yet level 0 does not fit");
            let img = render(ctx, &r, &cam);
            total += img.len() as u64;
        }
        eprintln!("frames to settle per view {frames:?} ({total} pixels rendered)");
    });
}
