//! View-dependent residency over the brick pyramid (`volume::data::bricks::residency`): on a
//! volume whose level-0 bricks do not fit the budget, an orbit keeps the faced part of the
//! volume at level 0 in every view, never uploads more than the per-frame budget in a frame and
//! never holds more than the device budget. Host side only: no device is needed.

use glam::{Mat4, Vec3};
use vkengine::volume::data::bricks::residency::{choose, Node, Pyramid, Streamer, View, BRICK_BYTES};

const N: u32 = 128;

/// A noisy ball of radius 60 voxels in a zero 128³ box: most bricks inside it vary.
fn voxel(p: [u32; 3]) -> u16 {
    let c = N as f32 / 2.0;
    let r2: f32 = p.iter().map(|&v| (v as f32 + 0.5 - c).powi(2)).sum();
    if r2 > 60.0 * 60.0 {
        return 0;
    }
    let h = p[0].wrapping_mul(73856093) ^ p[1].wrapping_mul(19349663) ^ p[2].wrapping_mul(83492791);
    1000 + (h.wrapping_mul(2654435761) >> 16) as u16 % 30000
}

/// Each level-0 brick's range over voxels 8b − 1 ..= 8b + 8 (clamped), x fastest: written
/// here from the voxels, not taken from the loader.
fn ranges() -> Vec<[u16; 2]> {
    let g = N / 8;
    let mut out = Vec::new();
    for bz in 0..g {
        for by in 0..g {
            for bx in 0..g {
                let span = |b: u32| (8 * b).saturating_sub(1)..=(8 * b + 8).min(N - 1);
                let mut r = [u16::MAX, 0];
                for z in span(bz) {
                    for y in span(by) {
                        for x in span(bx) {
                            let v = voxel([x, y, z]);
                            r = [r[0].min(v), r[1].max(v)];
                        }
                    }
                }
                out.push(r);
            }
        }
    }
    out
}

/// The orbit's view `i` of 36 (10° apart around the box's y axis, 3 half-sizes from its
/// centre, the whole box in a 75° frustum) and the direction from the centre to the eye.
fn view(i: u32) -> (View, Vec3) {
    let c = Vec3::splat(N as f32 / 2.0);
    let a = (i as f32 * 10.0).to_radians();
    let dir = Vec3::new(a.sin(), 0.0, a.cos());
    let eye = c + dir * 1.5 * N as f32;
    let vp = Mat4::perspective_rh(75f32.to_radians(), 1.0, 1.0, 1000.0) * Mat4::look_at_rh(eye, c, Vec3::Y);
    (View::from_view_projection(vp.to_cols_array_2d(), eye.to_array()), dir)
}

/// Level-0 bricks of the region the camera faces (whose centres lie in the quarter of the box
/// nearest the eye: a slab, independent of how residency ranks bricks) that show a coarser
/// level by `level_of`.
fn faced_coarse(dir: Vec3, level_of: impl Fn([u32; 3]) -> u32) -> (u32, u32) {
    let c = Vec3::splat(N as f32 / 2.0);
    let (mut faced, mut coarse) = (0, 0);
    for i in 0..(N / 8).pow(3) {
        let b = [i % 16, i / 16 % 16, i / 256];
        let centre = Vec3::new(b[0] as f32, b[1] as f32, b[2] as f32) * 8.0 + Vec3::splat(4.0);
        if (centre - c).dot(dir) >= N as f32 / 4.0 {
            faced += 1;
            coarse += u32::from(level_of(b) > 0);
        }
    }
    (faced, coarse)
}

/// The level each level-0 brick takes in `cut`.
fn cut_level(cut: &[Node], b: [u32; 3]) -> u32 {
    cut.iter().find(|n| (0..3).all(|a| b[a] >> n.level == n.brick[a])).map_or(u32::MAX, |n| n.level)
}

#[test]
fn an_orbit_keeps_the_faced_region_at_level_0_within_both_budgets() {
    let p = Pyramid::from_ranges(&ranges(), [N; 3]).expect("pyramid");
    assert_eq!(p.top(), 4);
    let full = p.level_bytes(0);
    // Half of what level 0 takes: the volume cannot be resident whole at full resolution.
    let budget = full / 2;
    let upload = 256 << 10;
    let mut s = Streamer::new(&p, budget, upload).expect("streamer");
    let (mut frames, mut most, mut total) = (0u32, 0u64, 0u64);
    let mut settle = Vec::new();
    for i in 0..36 {
        let (v, dir) = view(i);
        let cut = choose(&p, &v, budget);
        // Every level-0 brick under exactly one node of the cut.
        let covered: u64 = cut
            .iter()
            .map(|n| {
                let g = p.grid(0);
                (0..3)
                    .map(|a| u64::from(((n.brick[a] + 1) << n.level).min(g[a]) - (n.brick[a] << n.level).min(g[a])))
                    .product::<u64>()
            })
            .sum();
        assert_eq!(covered, u64::from((N / 8).pow(3)), "view {i}: the cut covers the grid once");
        let mut k = 0;
        loop {
            let f = s.frame(&p, &v, &cut);
            k += 1;
            frames += 1;
            total += f.bytes;
            most = most.max(f.bytes);
            assert!(f.bytes <= upload, "view {i} frame {k}: {} bytes uploaded, budget {upload}", f.bytes);
            assert!(s.resident_bytes() <= budget, "view {i} frame {k}: {} bytes resident", s.resident_bytes());
            if !f.changed && f.pending == 0 {
                break;
            }
            assert!(k < 40, "view {i} does not settle: {f:?}");
        }
        settle.push(k);
        let (faced, coarse) = faced_coarse(dir, |b| s.level_of(&p, b));
        assert!(faced > 300, "view {i}: {faced} faced bricks");
        assert_eq!(coarse, 0, "view {i}: {coarse} of the {faced} faced bricks are not at level 0");
        // The rest of the volume is coarser: level 0 does not fit.
        let counts = s.shown_counts(&p);
        assert!(counts[0] < u64::from((N / 8).pow(3)) && counts[1..].iter().sum::<u64>() > 0, "view {i}: {counts:?}");
    }
    eprintln!(
        "level 0 {full} B, budget {budget} B, upload {upload} B/frame: {frames} frames, at most {most} B a frame, {total} B in all; frames to settle per view {settle:?}; final shown per level {:?}, resident per level {:?}",
        s.shown_counts(&p),
        s.resident_counts(&p)
    );
}

#[test]
fn a_residency_that_ignores_the_view_leaves_the_faced_region_coarse() {
    // The check above can fail: the cut chosen for view 0 kept while the camera is at view 18
    // (the opposite side) leaves the region it faces coarse.
    let p = Pyramid::from_ranges(&ranges(), [N; 3]).expect("pyramid");
    let budget = p.level_bytes(0) / 2;
    let (v0, d0) = view(0);
    let cut = choose(&p, &v0, budget);
    let (faced, coarse) = faced_coarse(d0, |b| cut_level(&cut, b));
    assert_eq!(coarse, 0, "view 0 in its own cut: {coarse} of {faced}");
    let (_, d18) = view(18);
    let (faced, coarse) = faced_coarse(d18, |b| cut_level(&cut, b));
    assert!(coarse * 2 > faced, "view 18 in view 0's cut: only {coarse} of {faced} faced bricks coarse");
}

#[test]
fn a_volume_that_fits_is_resident_whole_at_level_0() {
    let p = Pyramid::from_ranges(&ranges(), [N; 3]).expect("pyramid");
    let bricks = u64::from((N / 8).pow(3));
    let budget = p.level_bytes(0) + BRICK_BYTES;
    let (v, _) = view(3);
    let cut = choose(&p, &v, budget);
    assert_eq!(cut.len() as u64, bricks);
    assert!(cut.iter().all(|n| n.level == 0));
    let mut s = Streamer::new(&p, budget, u64::MAX).expect("streamer");
    let f = s.frame(&p, &v, &cut);
    assert_eq!((f.pending, f.brick_bytes), (0, p.level_bytes(0)));
    assert_eq!(s.shown_counts(&p)[0], bricks);
    // The next frame has nothing to do: Monte Carlo's mean goes on.
    assert!(!s.frame(&p, &v, &cut).changed);
}

#[test]
fn bricks_behind_the_camera_stay_coarse() {
    // The eye inside the box looking along +x: the half behind it (x < 56) is outside the
    // frustum and stays at the coarsest levels, however large the budget.
    let p = Pyramid::from_ranges(&ranges(), [N; 3]).expect("pyramid");
    let eye = Vec3::new(64.0, 64.0, 64.0);
    let vp = Mat4::perspective_rh(60f32.to_radians(), 1.0, 1.0, 1000.0) * Mat4::look_at_rh(eye, eye + Vec3::X, Vec3::Y);
    let v = View::from_view_projection(vp.to_cols_array_2d(), eye.to_array());
    let cut = choose(&p, &v, u64::MAX);
    for x in 0..7u32 {
        assert!(
            cut_level(&cut, [x, 8, 8]) >= 3,
            "brick ({x}, 8, 8) behind the eye at level {}",
            cut_level(&cut, [x, 8, 8])
        );
    }
    assert_eq!(cut_level(&cut, [10, 8, 8]), 0, "ahead of the eye");
}
