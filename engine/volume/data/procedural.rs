//! Procedural test volumes with exact definitions, so renderer tests can compute analytic answers.
//!
//! All generators use spacing 1 and **normalized coordinates**: voxel `i` of an axis with `n` voxels has its
//! centre at `(i + 0.5) / n`, so the volume spans the unit cube and the centre is (0.5, 0.5, 0.5). Distances
//! `r` are Euclidean in these normalized coordinates (on non-cubic dims a "sphere" is an ellipsoid in voxel
//! space). Every value lies in [0, 1]. Dims go through the same checks as loaded volumes (non-zero, at most
//! 2^31 voxels in total).

use super::{check_dims, Volume, VolumeError};

fn source(name: &str, dims: [u32; 3], params: &str) -> String {
    format!("procedural:{name}({}x{}x{}{params})", dims[0], dims[1], dims[2])
}

fn bad(src: &str, message: String) -> VolumeError {
    VolumeError::BadParameter { file: src.to_owned(), message }
}

fn check_density(src: &str, density: f32) -> Result<(), VolumeError> {
    if !(0.0..=1.0).contains(&density) {
        return Err(bad(src, format!("density {density} must be in [0, 1]")));
    }
    Ok(())
}

fn check_radius(src: &str, radius: f32) -> Result<(), VolumeError> {
    if !(radius.is_finite() && radius > 0.0) {
        return Err(bad(src, format!("radius {radius} must be finite and > 0")));
    }
    Ok(())
}

/// Fills a volume by evaluating `f` at every voxel's normalized centre, x fastest.
fn generate(dims: [u32; 3], src: String, mut f: impl FnMut([u32; 3], [f32; 3]) -> f32) -> Result<Volume, VolumeError> {
    let count = check_dims(&src, dims.map(u64::from), u32::MAX)?;
    let mut data = Vec::new();
    data.try_reserve_exact(count as usize).map_err(|_| bad(&src, format!("cannot allocate {count} voxels")))?;
    let centre = |i: u32, n: u32| (i as f32 + 0.5) / n as f32;
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = [centre(x, dims[0]), centre(y, dims[1]), centre(z, dims[2])];
                data.push(f([x, y, z], p));
            }
        }
    }
    Volume::new(dims, [1.0; 3], data, src)
}

/// Distance of normalized point `p` from the volume centre (0.5, 0.5, 0.5).
pub fn radius_of(p: [f32; 3]) -> f32 {
    let [x, y, z] = p.map(|c| c - 0.5);
    (x * x + y * y + z * z).sqrt()
}

/// Every voxel equals `density` (a constant volume; see [`Volume::normalized_u16`] for how it uploads).
pub fn homogeneous_box(dims: [u32; 3], density: f32) -> Result<Volume, VolumeError> {
    let src = source("homogeneous_box", dims, &format!(", density={density}"));
    check_density(&src, density)?;
    generate(dims, src, |_, _| density)
}

/// `density` where the voxel centre lies inside the closed box `[lo, hi]` (normalized coordinates), else 0.
pub fn box_in_volume(dims: [u32; 3], lo: [f32; 3], hi: [f32; 3], density: f32) -> Result<Volume, VolumeError> {
    let src = source("box_in_volume", dims, &format!(", lo={lo:?}, hi={hi:?}, density={density}"));
    check_density(&src, density)?;
    if lo.iter().chain(&hi).any(|c| !c.is_finite()) || (0..3).any(|i| lo[i] > hi[i]) {
        return Err(bad(&src, "lo and hi must be finite with lo <= hi on every axis".into()));
    }
    generate(dims, src, |_, p| {
        let inside = (0..3).all(|i| p[i] >= lo[i] && p[i] <= hi[i]);
        if inside {
            density
        } else {
            0.0
        }
    })
}

/// `density` where the voxel centre's distance `r` from the centre is `<= radius` (normalized units), else 0.
pub fn sphere(dims: [u32; 3], radius: f32, density: f32) -> Result<Volume, VolumeError> {
    let src = source("sphere", dims, &format!(", radius={radius}, density={density}"));
    check_density(&src, density)?;
    check_radius(&src, radius)?;
    generate(dims, src, |_, p| if radius_of(p) <= radius { density } else { 0.0 })
}

/// `clamp(1 - r / radius, 0, 1)`: a linear radial ramp, 1 at the centre and 0 from `r = radius` outwards, so
/// iso-value `v` is crossed at `r = radius * (1 - v)`.
pub fn smooth_sphere(dims: [u32; 3], radius: f32) -> Result<Volume, VolumeError> {
    let src = source("smooth_sphere", dims, &format!(", radius={radius}"));
    check_radius(&src, radius)?;
    generate(dims, src, |_, p| (1.0 - radius_of(p) / radius).clamp(0.0, 1.0))
}

/// Hash of an integer lattice point and seed to [0, 1) (a small integer mix; stable across platforms).
fn lattice(x: i32, y: i32, z: i32, seed: u32) -> f32 {
    let mut h = seed.wrapping_mul(0x9E37_79B9)
        ^ (x as u32).wrapping_mul(0x85EB_CA6B)
        ^ (y as u32).wrapping_mul(0xC2B2_AE35)
        ^ (z as u32).wrapping_mul(0x27D4_EB2F);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297A_2D39);
    h ^= h >> 15;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

fn smoothstep(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// Value noise at `p` (lattice units): trilinear interpolation of hashed lattice values with smoothstep weights.
fn value_noise(p: [f32; 3], seed: u32) -> f32 {
    let i = p.map(|c| c.floor());
    let t = [0, 1, 2].map(|k| smoothstep(p[k] - i[k]));
    let [ix, iy, iz] = i.map(|c| c as i32);
    let mut acc = 0.0;
    for corner in 0..8 {
        let (dx, dy, dz) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        let w = |d: i32, t: f32| if d == 1 { t } else { 1.0 - t };
        acc += w(dx, t[0]) * w(dy, t[1]) * w(dz, t[2]) * lattice(ix + dx, iy + dy, iz + dz, seed);
    }
    acc
}

/// Cloud octaves; base lattice frequency (cells across the unit cube); and the soft sphere's inner/outer radii.
const CLOUD_OCTAVES: u32 = 4;
const CLOUD_FREQUENCY: f32 = 4.0;
const CLOUD_INNER: f32 = 0.25;
const CLOUD_OUTER: f32 = 0.45;

/// Fractal value noise shaped by a soft sphere; deterministic for `seed`, values in [0, 1].
///
/// `fbm(p) = Σ_{o<4} 0.5^o · noise(p · 4 · 2^o) / Σ 0.5^o` (hashed lattice, smoothstep interpolation);
/// `value = clamp((fbm - 0.35) / 0.4, 0, 1) · (1 - smoothstep((r - 0.25) / 0.2))` with the falloff argument clamped
/// to [0, 1], so everything at `r >= 0.45` is 0. Voxels on the outer layer (index 0 or n-1 on any axis) are
/// forced to 0 as well, so the border is exactly empty even for tiny dims.
pub fn cloud(dims: [u32; 3], seed: u32) -> Result<Volume, VolumeError> {
    let src = source("cloud", dims, &format!(", seed={seed}"));
    generate(dims, src, |idx, p| {
        if (0..3).any(|k| idx[k] == 0 || idx[k] + 1 == dims[k]) {
            return 0.0;
        }
        let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, CLOUD_FREQUENCY);
        for o in 0..CLOUD_OCTAVES {
            sum += amp * value_noise(p.map(|c| c * freq), seed.wrapping_add(o));
            norm += amp;
            amp *= 0.5;
            freq *= 2.0;
        }
        let fbm = sum / norm;
        let t = ((radius_of(p) - CLOUD_INNER) / (CLOUD_OUTER - CLOUD_INNER)).clamp(0.0, 1.0);
        (((fbm - 0.35) / 0.4).clamp(0.0, 1.0) * (1.0 - smoothstep(t))).clamp(0.0, 1.0)
    })
}

/// Number of puffs in [`sparse_clouds`]; the first is the dense one.
const PUFFS: u32 = 6;

/// A few small cloud puffs in a mostly empty box (about 6 % of the voxels are non-zero): one dense puff
/// (peak 1) and five thin ones (peaks 0.15–0.4). This is the case a majorant grid exists for — one global
/// majorant, set by the dense core, makes every thin or empty region pay for null collisions.
///
/// Puff `k` has centre `c_k` in [0.2, 0.8]³ and radius `r_k` in [0.09, 0.15] (hashed from `seed` and `k`);
/// `value = max_k peak_k · clamp((fbm(p) - 0.2) / 0.3, 0, 1) · (1 - smoothstep(|p - c_k| / r_k))` with the
/// falloff argument clamped to [0, 1], using the same fBm as [`cloud`].
pub fn sparse_clouds(dims: [u32; 3], seed: u32) -> Result<Volume, VolumeError> {
    let src = source("sparse_clouds", dims, &format!(", seed={seed}"));
    let h = |k: u32, j: i32| lattice(k as i32, j, 7, seed);
    let puffs: Vec<([f32; 3], f32, f32)> = (0..PUFFS)
        .map(|k| {
            let c = [0, 1, 2].map(|j| 0.2 + 0.6 * h(k, j));
            let r = 0.09 + 0.06 * h(k, 3);
            let peak = if k == 0 { 1.0 } else { 0.15 + 0.25 * h(k, 4) };
            (c, if k == 0 { 0.15 } else { r }, peak)
        })
        .collect();
    generate(dims, src, |_, p| {
        let mut best = 0.0f32;
        for &(c, r, peak) in &puffs {
            let d = (0..3).map(|j| (p[j] - c[j]).powi(2)).sum::<f32>().sqrt();
            if d < r {
                best = best.max(peak * (1.0 - smoothstep(d / r)));
            }
        }
        if best <= 0.0 {
            return 0.0;
        }
        let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, CLOUD_FREQUENCY * 2.0);
        for o in 0..CLOUD_OCTAVES {
            sum += amp * value_noise(p.map(|c| c * freq), seed.wrapping_add(o));
            norm += amp;
            amp *= 0.5;
            freq *= 2.0;
        }
        (best * ((sum / norm - 0.2) / 0.3).clamp(0.0, 1.0)).clamp(0.0, 1.0)
    })
}

/// Inner and outer radius of the [`checker_shell`] shell (normalized units).
pub const SHELL_RADII: [f32; 2] = [0.3, 0.45];

/// Stress volume: inside the shell `0.3 <= r <= 0.45`, voxel = 1 where `floor(x·cells) + floor(y·cells) +
/// floor(z·cells)` (normalized centre coordinates) is even and 0 where odd; 0 outside the shell.
pub fn checker_shell(dims: [u32; 3], cells: u32) -> Result<Volume, VolumeError> {
    let src = source("checker_shell", dims, &format!(", cells={cells}"));
    if cells == 0 {
        return Err(bad(&src, "cells must be >= 1".into()));
    }
    generate(dims, src, |_, p| {
        let r = radius_of(p);
        if !(SHELL_RADII[0]..=SHELL_RADII[1]).contains(&r) {
            return 0.0;
        }
        let parity = p.iter().map(|&c| (c * cells as f32).floor() as i64).sum::<i64>();
        if parity.rem_euclid(2) == 0 {
            1.0
        } else {
            0.0
        }
    })
}
