//! Two-band spherical harmonics as the LPV uses them (REFERENCE.md, thesis eq. 4.2–4.3), in f64
//! on the CPU: the twin of `shaders_glsl/lpv/sh.glsl`, for tests and for checking grids.
//!
//! Coefficient order: `[Y00, Y1-1, Y10, Y11]` with `Y00 = 1/(2√π)`, `Y1-1 = -(√3/(2√π))·y`,
//! `Y10 = (√3/(2√π))·z`, `Y11 = -(√3/(2√π))·x`.

/// `1 / (2√π)`.
pub const Y0: f64 = 0.282_094_791_773_878_14;
/// `√3 / (2√π)`.
pub const Y1: f64 = 0.488_602_511_902_919_9;
/// Band-0 coefficient of the clamped cosine lobe, `√π / 2`.
pub const COS0: f64 = 0.886_226_925_452_758;
/// Band-1 magnitude of the clamped cosine lobe, `√(π/3)`.
pub const COS1: f64 = 1.023_326_707_946_488_5;

/// The basis evaluated at unit direction `d`.
pub fn basis(d: [f64; 3]) -> [f64; 4] {
    [Y0, -Y1 * d[1], Y1 * d[2], -Y1 * d[0]]
}

/// Coefficients of the clamped cosine lobe `max(0, n·ω)` around unit `n`.
pub fn cosine_lobe(n: [f64; 3]) -> [f64; 4] {
    [COS0, -COS1 * n[1], COS1 * n[2], -COS1 * n[0]]
}

/// Value of the function with coefficients `c` in direction `d`.
pub fn eval(c: [f64; 4], d: [f64; 3]) -> f64 {
    basis(d).iter().zip(c).map(|(b, c)| b * c).sum()
}

/// `∫ f(ω) max(0, m·ω) dω` for `f` with coefficients `c`: the dot product with the lobe's
/// coefficients (the basis is orthonormal).
pub fn cosine_integral(c: [f64; 4], m: [f64; 3]) -> f64 {
    cosine_lobe(m).iter().zip(c).map(|(l, c)| l * c).sum()
}

/// `∫ f(ω) dω` over the sphere: only band 0 survives, `c0 · √(4π)`.
pub fn integral(c: [f64; 4]) -> f64 {
    c[0] * (4.0 * std::f64::consts::PI).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Numerical projection of `f` onto the basis by a midpoint rule in (cosθ, φ).
    fn project(f: impl Fn([f64; 3]) -> f64) -> [f64; 4] {
        let (nt, np) = (400, 800);
        let mut c = [0.0; 4];
        for i in 0..nt {
            let z = -1.0 + 2.0 * (i as f64 + 0.5) / nt as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let d = [r * phi.cos(), r * phi.sin(), z];
                let w = (2.0 / nt as f64) * (2.0 * PI / np as f64);
                let v = f(d);
                for (k, b) in basis(d).iter().enumerate() {
                    c[k] += v * b * w;
                }
            }
        }
        c
    }

    #[test]
    fn clamped_cosine_projects_to_the_reference_constants() {
        for n in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.6, 0.0, 0.8]] {
            let numeric = project(|d| (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]).max(0.0));
            let closed = cosine_lobe(n);
            for k in 0..4 {
                assert!((numeric[k] - closed[k]).abs() < 1e-4, "n={n:?} k={k}: {} vs {}", numeric[k], closed[k]);
            }
        }
    }

    #[test]
    fn a_linear_function_is_reproduced_exactly() {
        // f(ω) = 2 + 3x - y + 0.5z lies in the span of the two bands.
        let f = |d: [f64; 3]| 2.0 + 3.0 * d[0] - d[1] + 0.5 * d[2];
        let c = project(f);
        for d in [[0.0, 0.0, 1.0], [0.6, 0.8, 0.0], [-0.48, 0.6, 0.64]] {
            assert!((eval(c, d) - f(d)).abs() < 1e-4, "{d:?}");
        }
        assert!((integral(c) - 8.0 * PI).abs() < 1e-3);
    }

    #[test]
    fn lobe_flux_and_irradiance_identities() {
        // A Lambertian emitter of flux Φ has intensity Φ/π·cos: its SH integrates back to Φ.
        let phi = 5.0;
        let lobe = cosine_lobe([0.0, 1.0, 0.0]).map(|c| c * phi / PI);
        assert!((integral(lobe) - phi).abs() < 1e-12);
        // Irradiance from a uniform radiance L over the hemisphere is πL.
        let l = 1.7;
        let uniform = [l / Y0, 0.0, 0.0, 0.0];
        assert!((eval(uniform, [0.3, 0.4, -0.866]) - l).abs() < 1e-12);
        assert!((cosine_integral(uniform, [0.0, 0.0, 1.0]) - PI * l).abs() < 1e-12);
    }
}
