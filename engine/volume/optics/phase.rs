//! Phase functions for volumetric path tracing: the CPU reference of `shaders_glsl/volume/phase.glsl`.
//!
//! Convention (REFERENCE.md): `μ = wi·wo` with `wi` the direction light travels before scattering
//! and `wo` the direction after, so `g > 0` scatters forward and the mean sampled `μ` of
//! Henyey–Greenstein is `g`. Every `eval` is a density over the sphere of directions
//! (`∫ 2π p(μ) dμ = 1`). Parameters are `f32` because they are what the GPU sees; the maths is
//! `f64` so the CPU serves as the reference for the shader.

use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Largest `|g|` (and Schlick `|k|`) used; `g = ±1` is a delta and would give `0/0`.
pub const G_MAX: f32 = 0.999;

/// `Phase.kind` of the isotropic phase function.
pub const KIND_ISOTROPIC: u32 = 0;
/// `Phase.kind` of Henyey–Greenstein.
pub const KIND_HG: u32 = 1;
/// `Phase.kind` of Schlick (the GPU struct holds `k`, not `g`).
pub const KIND_SCHLICK: u32 = 2;
/// `Phase.kind` of Rayleigh.
pub const KIND_RAYLEIGH: u32 = 3;
/// `Phase.kind` of a two-lobe Henyey–Greenstein mixture.
pub const KIND_HG_MIX: u32 = 4;
/// `Phase.kind` of a two-lobe Schlick mixture (the thesis' hazy/murky approximations).
pub const KIND_SCHLICK_MIX: u32 = 5;

/// A phase function; mixtures are `w · lobe(g1) + (1 - w) · lobe(g2)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum PhaseFunction {
    /// `p = 1/(4π)`.
    Isotropic,
    /// Henyey–Greenstein with asymmetry `g` (clamped to `±G_MAX`).
    HenyeyGreenstein {
        /// Asymmetry parameter (mean cosine).
        g: f32,
    },
    /// Schlick's approximation of HG with `k = 1.55g - 0.55g³` (clamped to `±G_MAX`).
    Schlick {
        /// HG-equivalent asymmetry parameter.
        g: f32,
    },
    /// Rayleigh `p = 3/(16π) (1 + μ²)`.
    Rayleigh,
    /// Two HG lobes.
    HgMixture {
        /// Asymmetry of lobe 1.
        g1: f32,
        /// Asymmetry of lobe 2.
        g2: f32,
        /// Weight of lobe 1 in `[0, 1]`.
        w: f32,
    },
    /// Two Schlick lobes.
    SchlickMixture {
        /// HG-equivalent asymmetry of lobe 1.
        g1: f32,
        /// HG-equivalent asymmetry of lobe 2.
        g2: f32,
        /// Weight of lobe 1 in `[0, 1]`.
        w: f32,
    },
}

/// Clamps an asymmetry to `±G_MAX`; NaN becomes 0 so a bad input cannot poison a whole render.
pub fn clamp_g(g: f32) -> f32 {
    if g.is_nan() {
        0.0
    } else {
        g.clamp(-G_MAX, G_MAX)
    }
}

/// Schlick's `k = 1.55g - 0.55g³`, clamped to `±G_MAX` (it exceeds 1 for g in ~(0.94, 1)).
///
/// Rounded to `f32` once here so CPU and GPU use bit-identical `k`.
pub fn schlick_k(g: f32) -> f32 {
    let g = clamp_g(g) as f64;
    clamp_g((1.55 * g - 0.55 * g * g * g) as f32)
}

fn clamp_w(w: f32) -> f64 {
    if w.is_nan() {
        0.5
    } else {
        w.clamp(0.0, 1.0) as f64
    }
}

/// `(|g|, t = 1 - sign(g)·μ)`: the lobe's strength and the distance from its peak.
fn lobe_frame(g: f64, mu: f64) -> (f64, f64) {
    (g.abs(), 1.0 - if g < 0.0 { -mu } else { mu })
}

/// HG density at `mu` for an already clamped `g`, in the cancellation-free form of the shader.
pub fn hg_eval(g: f64, mu: f64) -> f64 {
    let (a, t) = lobe_frame(g, mu);
    let d = (1.0 - a) * (1.0 - a) + 2.0 * a * t;
    (1.0 - a) * (1.0 + a) / (4.0 * PI * d * d.sqrt())
}

/// Schlick density at `mu` for an already clamped `k`.
pub fn schlick_eval(k: f64, mu: f64) -> f64 {
    let (a, t) = lobe_frame(k, mu);
    let q = (1.0 - a) + a * t;
    (1.0 - a) * (1.0 + a) / (4.0 * PI * q * q)
}

/// HG inverse CDF as `t = 1 - sign(g)·μ` (see `phase_hg_sample_t` in the shader for the derivation).
fn hg_sample_t(g: f64, xi: f64) -> f64 {
    let a = g.abs();
    let x = if g < 0.0 { 1.0 - xi } else { xi };
    let den = 1.0 - a + 2.0 * a * x;
    2.0 * (1.0 - a) * (1.0 - a) * (1.0 - x) * (1.0 + a * x) / (den * den)
}

/// Schlick inverse CDF as `t = 1 - sign(k)·μ`.
fn schlick_sample_t(k: f64, xi: f64) -> f64 {
    let a = k.abs();
    let x = if k < 0.0 { 1.0 - xi } else { xi };
    2.0 * (1.0 - a) * (1.0 - x) / (1.0 - a + 2.0 * a * x)
}

/// Rayleigh inverse CDF: the real root of `μ³ + 3μ = 4(2ξ - 1)` as `sign(s)(u - 1/u)`.
fn rayleigh_sample_mu(xi: f64) -> f64 {
    let s = 2.0 * (2.0 * xi - 1.0);
    let u = (s.abs() + (s * s + 1.0).sqrt()).cbrt();
    (s.signum() * (u - 1.0 / u)).clamp(-1.0, 1.0)
}

/// Mean cosine of a Schlick lobe: `1/k - (1 - k²) atanh(k) / k²` (series near 0, where it cancels).
fn schlick_mean(k: f64) -> f64 {
    if k.abs() < 1e-3 {
        2.0 * k / 3.0 + 2.0 * k.powi(3) / 15.0
    } else {
        1.0 / k - (1.0 - k * k) * k.atanh() / (k * k)
    }
}

/// One lobe (after mixture selection): kind and clamped parameter.
#[derive(Clone, Copy)]
enum Lobe {
    Iso,
    Hg(f64),
    Schlick(f64),
    Rayleigh,
}

impl Lobe {
    /// Inverse CDF: `(μ, sin θ)`, `sin θ` taken from the distance to the peak (narrow lobes).
    fn sample(self, xi: f64) -> (f64, f64) {
        let (g, t) = match self {
            Lobe::Hg(g) => (g, hg_sample_t(g, xi)),
            Lobe::Schlick(k) => (k, schlick_sample_t(k, xi)),
            Lobe::Iso | Lobe::Rayleigh => {
                let mu = if matches!(self, Lobe::Rayleigh) { rayleigh_sample_mu(xi) } else { 2.0 * xi - 1.0 };
                return (mu, ((1.0 - mu) * (1.0 + mu)).max(0.0).sqrt());
            }
        };
        let t = t.clamp(0.0, 2.0);
        let mu = if g < 0.0 { t - 1.0 } else { 1.0 - t };
        (mu, (t * (2.0 - t)).max(0.0).sqrt())
    }
}

impl PhaseFunction {
    /// The lobes with their weights (`w` of the first; single lobes have `w = 1`).
    fn lobes(&self) -> (Lobe, Lobe, f64) {
        let hg = |g: f32| Lobe::Hg(clamp_g(g) as f64);
        let sch = |g: f32| Lobe::Schlick(schlick_k(g) as f64);
        match *self {
            PhaseFunction::Isotropic => (Lobe::Iso, Lobe::Iso, 1.0),
            PhaseFunction::HenyeyGreenstein { g } => (hg(g), hg(g), 1.0),
            PhaseFunction::Schlick { g } => (sch(g), sch(g), 1.0),
            PhaseFunction::Rayleigh => (Lobe::Rayleigh, Lobe::Rayleigh, 1.0),
            PhaseFunction::HgMixture { g1, g2, w } => (hg(g1), hg(g2), clamp_w(w)),
            PhaseFunction::SchlickMixture { g1, g2, w } => (sch(g1), sch(g2), clamp_w(w)),
        }
    }

    /// Density over the sphere of directions at cosine `mu` (clamped to `[-1, 1]`).
    pub fn eval(&self, mu: f64) -> f64 {
        let mu = mu.clamp(-1.0, 1.0);
        let lobe = |l: Lobe| match l {
            Lobe::Iso => 1.0 / (4.0 * PI),
            Lobe::Hg(g) => hg_eval(g, mu),
            Lobe::Schlick(k) => schlick_eval(k, mu),
            Lobe::Rayleigh => 3.0 / (16.0 * PI) * (1.0 + mu * mu),
        };
        let (l1, l2, w) = self.lobes();
        if w >= 1.0 {
            lobe(l1)
        } else {
            w * lobe(l1) + (1.0 - w) * lobe(l2)
        }
    }

    /// Density of scattering light travelling along unit `wi` into unit `wo`.
    pub fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        self.eval(wi.dot(wo))
    }

    /// Samples `μ` from `xi ∈ [0, 1]` by inverse CDF (mixtures: lobe 1 if `xi < w`, `xi` rescaled).
    pub fn sample_mu(&self, xi: f64) -> f64 {
        self.sample_mu_sin(xi).0
    }

    /// `(μ, sin θ)` as the shader's `phase_sample_mu` computes them.
    fn sample_mu_sin(&self, xi: f64) -> (f64, f64) {
        let (l1, l2, w) = self.lobes();
        if w >= 1.0 {
            return l1.sample(xi);
        }
        if xi < w {
            l1.sample((xi / w).clamp(0.0, 1.0))
        } else {
            l2.sample(((xi - w) / (1.0 - w)).clamp(0.0, 1.0))
        }
    }

    /// Samples `wo` for light travelling along unit `wi`; returns `(wo, pdf)` like `phase_sample`.
    pub fn sample(&self, wi: DVec3, xi: [f64; 2]) -> (DVec3, f64) {
        let (mu, sin_theta) = self.sample_mu_sin(xi[0]);
        let (t, b) = orthonormal_basis(wi);
        let phi = 2.0 * PI * xi[1];
        (mu * wi + sin_theta * (phi.cos() * t + phi.sin() * b), self.eval(mu))
    }

    /// Mean cosine `E[μ]` (analytic for every kind; HG gives `g` up to the `G_MAX` clamp).
    pub fn mean_cosine(&self) -> f64 {
        let mean = |l: Lobe| match l {
            Lobe::Iso | Lobe::Rayleigh => 0.0,
            Lobe::Hg(g) => g,
            Lobe::Schlick(k) => schlick_mean(k),
        };
        let (l1, l2, w) = self.lobes();
        w * mean(l1) + (1.0 - w) * mean(l2)
    }

    /// The `Phase` struct of `phase.glsl` as words: `[kind, g, g2, w]` (f32 bits; Schlick kinds hold `k`).
    pub fn to_gpu(&self) -> [u32; 4] {
        let (kind, g, g2, w) = match *self {
            PhaseFunction::Isotropic => (KIND_ISOTROPIC, 0.0, 0.0, 1.0),
            PhaseFunction::HenyeyGreenstein { g } => (KIND_HG, clamp_g(g), 0.0, 1.0),
            PhaseFunction::Schlick { g } => (KIND_SCHLICK, schlick_k(g), 0.0, 1.0),
            PhaseFunction::Rayleigh => (KIND_RAYLEIGH, 0.0, 0.0, 1.0),
            PhaseFunction::HgMixture { g1, g2, w } => (KIND_HG_MIX, clamp_g(g1), clamp_g(g2), clamp_w(w) as f32),
            PhaseFunction::SchlickMixture { g1, g2, w } => {
                (KIND_SCHLICK_MIX, schlick_k(g1), schlick_k(g2), clamp_w(w) as f32)
            }
        };
        [kind, f32::to_bits(g), f32::to_bits(g2), f32::to_bits(w)]
    }
}

/// Orthonormal `(t, b)` with `(t, b, n)` right-handed for unit `n` (Duff et al. 2017), as `phase_frame`.
pub fn orthonormal_basis(n: DVec3) -> (DVec3, DVec3) {
    let s = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + n.z);
    let c = n.x * n.y * a;
    (DVec3::new(1.0 + s * n.x * n.x * a, s * c, -s * n.x), DVec3::new(c, s + n.y * n.y * a, -n.y))
}
