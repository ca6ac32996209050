//! The LPV propagation step in f64 on the CPU (no geometry volume): the twin of
//! `shaders_glsl/lpv/propagate.comp`, used to check the GPU grids and to measure how far the
//! scheme itself is from free-space transport (`lpv_bench --sweep transport`).
//!
//! One channel; a grid is `n³` cells of 2-band SH coefficients, cell index `x + n·(y + n·z)`.

use super::sh;
use std::f64::consts::PI;

/// Solid angle of the face opposite the source cell's centre (REFERENCE.md).
pub const FRONT: f64 = 0.400_669_684_6;
/// Solid angle of each side face, (2π/3 − FRONT)/4 (REFERENCE.md prints 0.4234413544, a digit
/// off from its own identity; a midpoint quadrature gives 0.423431).
pub const SIDE: f64 = 0.423_431_354_4;

const DIRS: [[i32; 3]; 6] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

/// One face a source lights: direction evaluated from the source, normal of the re-emitted
/// lobe, solid angle.
type Face = ([f64; 3], [f64; 3], f64);

/// The five faces a source lights in its neighbour at offset `d`.
fn faces(d: [i32; 3]) -> Vec<Face> {
    let dn = d.map(f64::from);
    let mut out = vec![(dn, dn, FRONT)];
    for axis in (0..3).filter(|&a| d[a] == 0) {
        for sign in [1.0, -1.0] {
            let mut side = [0.0; 3];
            side[axis] = sign;
            let w = normalize([dn[0] + 0.5 * side[0], dn[1] + 0.5 * side[1], dn[2] + 0.5 * side[2]]);
            out.push((w, side, SIDE));
        }
    }
    out
}

/// One gather propagation step of an `n³` grid: every cell receives from its six neighbours;
/// light leaving the grid is gone.
pub fn propagate(src: &[[f64; 4]], n: usize) -> Vec<[f64; 4]> {
    let transfers: Vec<(Vec<Face>, [i32; 3])> = DIRS.iter().map(|&d| (faces(d), d)).collect();
    let mut dst = vec![[0.0; 4]; n * n * n];
    let ni = n as i32;
    for z in 0..ni {
        for y in 0..ni {
            for x in 0..ni {
                let mut o = [0.0; 4];
                for (faces, d) in &transfers {
                    let (sx, sy, sz) = (x - d[0], y - d[1], z - d[2]);
                    if [sx, sy, sz].iter().any(|&c| c < 0 || c >= ni) {
                        continue;
                    }
                    let s = src[(sx + ni * (sy + ni * sz)) as usize];
                    for &(w, face_n, solid) in faces {
                        let flux = sh::eval(s, w) * solid / PI;
                        let lobe = sh::cosine_lobe(face_n);
                        for k in 0..4 {
                            o[k] += flux * lobe[k];
                        }
                    }
                }
                dst[(x + ni * (y + ni * z)) as usize] = o;
            }
        }
    }
    dst
}

/// The injected grid plus `steps` propagated ones, summed (what shading reads).
pub fn accumulate(injected: &[[f64; 4]], n: usize, steps: u32) -> Vec<[f64; 4]> {
    let mut acc = injected.to_vec();
    let mut cur = injected.to_vec();
    for _ in 0..steps {
        cur = propagate(&cur, n);
        for (a, c) in acc.iter_mut().zip(&cur) {
            for k in 0..4 {
                a[k] += c[k];
            }
        }
    }
    acc
}

/// Free-space test of the scheme: an isotropic point source of unit flux in the centre cell of
/// an `n³` grid of unit cells, propagated `steps` times. Returns, per distance r (in cells)
/// along the axis, the face diagonal and the body diagonal, the accumulated irradiance on a
/// surface facing the source divided by the exact `1/(4πr²)`.
pub fn point_source_irradiance(n: usize, steps: u32) -> Vec<(&'static str, f64, f64)> {
    let c = n / 2;
    let mut grid = vec![[0.0; 4]; n * n * n];
    // I(ω) = 1/(4π): band 0 only, Y00·∫I = (1/(2√π))·1.
    grid[c + n * (c + n * c)] = [sh::Y0, 0.0, 0.0, 0.0];
    let acc = accumulate(&grid, n, steps);
    let mut out = Vec::new();
    for (name, dir) in [("axis", [1i32, 0, 0]), ("face diagonal", [1, 1, 0]), ("body diagonal", [1, 1, 1])] {
        let len = f64::from(dir.iter().map(|d| d * d).sum::<i32>()).sqrt();
        for k in 1..=(n / 2 - 1) as i32 {
            let cell = dir.map(|d| (c as i32 + k * d) as usize);
            let r = f64::from(k) * len;
            let toward = normalize(dir.map(|d| -f64::from(d)));
            let e = sh::cosine_integral(acc[cell[0] + n * (cell[1] + n * cell[2])], toward);
            out.push((name, r, e / (1.0 / (4.0 * PI * r * r))));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn face_solid_angles_cover_the_sphere() {
        let total = 6.0 * (FRONT + 4.0 * SIDE);
        assert!((total - 4.0 * PI).abs() < 1e-8, "{total}");
    }

    #[test]
    fn a_step_conserves_flux_and_moves_a_lobe_forward() {
        let n = 9;
        let mut g = vec![[0.0; 4]; n * n * n];
        let c = 4 + n * (4 + n * 4);
        // A cosine lobe of unit flux along +x.
        g[c] = sh::cosine_lobe([1.0, 0.0, 0.0]).map(|v| v / PI);
        let flux = |g: &[[f64; 4]]| g.iter().map(|&c| sh::integral(c)).sum::<f64>();
        let next = propagate(&g, n);
        assert!((flux(&next) - flux(&g)).abs() < 1e-9 * flux(&g));
        let ahead = sh::integral(next[c + 1]);
        let behind = sh::integral(next[c - 1]);
        assert!(ahead > 0.4 && behind < 0.0, "ahead {ahead}, behind {behind}");
    }
}
