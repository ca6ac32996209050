//! Phase functions: CPU reference (`vkengine::volume::optics::phase`) against the maths, and the GLSL
//! (`shaders_glsl/volume/phase.glsl`, `random.glsl`) against the CPU reference on lavapipe.

mod common;

use glam::DVec3;
use std::f64::consts::PI;
use vkengine::shaders;
use vkengine::vk::{pipeline::push_words, vk, Binding, Buffer, Descriptor, MemoryLocation, Pipeline};
use vkengine::volume::optics::phase::{orthonormal_basis, schlick_k, PhaseFunction, G_MAX, KIND_HG, KIND_SCHLICK};

/// The asymmetries the brief asks for: both extremes, the isotropic limit and a tiny `g`.
const GS: [f32; 8] = [-0.999, -0.9, -0.5, 0.0, 1e-4, 0.3, 0.9, 0.999];

/// Every kind, every `g` for the `g`-bearing ones, and a few mixtures.
fn cases() -> Vec<PhaseFunction> {
    let mut v = vec![PhaseFunction::Isotropic, PhaseFunction::Rayleigh];
    for g in GS {
        v.push(PhaseFunction::HenyeyGreenstein { g });
        v.push(PhaseFunction::Schlick { g });
    }
    v.push(PhaseFunction::HgMixture { g1: 0.8, g2: -0.3, w: 0.7 });
    v.push(PhaseFunction::HgMixture { g1: 0.999, g2: -0.999, w: 0.5 });
    v.push(PhaseFunction::SchlickMixture { g1: 0.9, g2: -0.2, w: 0.6 });
    v.push(PhaseFunction::SchlickMixture { g1: -0.5, g2: 0.3, w: 0.25 });
    v
}

/// The `g`-bearing kinds built from one `g` (mixtures: both lobes lean the same way).
fn g_kinds(g: f32) -> [PhaseFunction; 4] {
    [
        PhaseFunction::HenyeyGreenstein { g },
        PhaseFunction::Schlick { g },
        PhaseFunction::HgMixture { g1: g, g2: g * 0.5, w: 0.4 },
        PhaseFunction::SchlickMixture { g1: g, g2: g * 0.25, w: 0.7 },
    ]
}

/// splitmix64: deterministic test randomness, uniform in the open interval (0,1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
}

/// Adaptive Simpson quadrature to absolute tolerance `eps` (peaks sit at interval ends, so they
/// are always sampled).
fn quad(f: &dyn Fn(f64) -> f64, a: f64, b: f64, eps: f64) -> f64 {
    /// One Simpson panel: ends, midpoint values and its estimate.
    struct Panel {
        a: f64,
        b: f64,
        fa: f64,
        fm: f64,
        fb: f64,
        whole: f64,
    }
    fn rec(f: &dyn Fn(f64) -> f64, p: Panel, eps: f64, depth: u32) -> f64 {
        let m = 0.5 * (p.a + p.b);
        let (flm, frm) = (f(0.5 * (p.a + m)), f(0.5 * (m + p.b)));
        let left =
            Panel { a: p.a, b: m, fa: p.fa, fm: flm, fb: p.fm, whole: (m - p.a) / 6.0 * (p.fa + 4.0 * flm + p.fm) };
        let right =
            Panel { a: m, b: p.b, fa: p.fm, fm: frm, fb: p.fb, whole: (p.b - m) / 6.0 * (p.fm + 4.0 * frm + p.fb) };
        let delta = left.whole + right.whole - p.whole;
        // The relative floor stops the halving tolerance from outrunning f64 rounding.
        if depth == 0 || delta.abs() <= 15.0 * eps.max(1e-15 * (left.whole + right.whole).abs()) {
            left.whole + right.whole + delta / 15.0
        } else {
            rec(f, left, eps / 2.0, depth - 1) + rec(f, right, eps / 2.0, depth - 1)
        }
    }
    let (fa, fm, fb) = (f(a), f(0.5 * (a + b)), f(b));
    rec(f, Panel { a, b, fa, fm, fb, whole: (b - a) / 6.0 * (fa + 4.0 * fm + fb) }, eps, 60)
}

/// Probability of `μ ∈ [a, b]` by quadrature of the density (independent of the sampler).
fn mass(pf: &PhaseFunction, a: f64, b: f64) -> f64 {
    quad(&|mu| 2.0 * PI * pf.eval(mu), a, b, 1e-13)
}

/// Bin edges in `μ` with equal probability under `pf` (bisection on the quadrature CDF), then
/// merged so no bin is narrower than `min_width` (f32 `μ` near ±1 is quantized at ~6e-8).
fn equiprobable_edges(pf: &PhaseFunction, bins: usize, min_width: f64) -> Vec<f64> {
    let mut edges = vec![-1.0];
    let mut cdf_at_last = 0.0;
    for k in 1..bins {
        let target = k as f64 / bins as f64;
        let last = *edges.last().expect("non-empty");
        let (mut lo, mut hi) = (last, 1.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if cdf_at_last + mass(pf, last, mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let e = 0.5 * (lo + hi);
        cdf_at_last += mass(pf, last, e);
        edges.push(e);
    }
    edges.push(1.0);
    let mut kept = vec![-1.0];
    for &e in &edges[1..edges.len() - 1] {
        if e - kept.last().expect("non-empty") >= min_width && 1.0 - e >= min_width {
            kept.push(e);
        }
    }
    kept.push(1.0);
    kept
}

/// Pearson chi-square of `mus` against `pf` on equiprobable bins (pooled to expected ≥ 5);
/// returns `(statistic, critical value at p = 0.001)`.
fn chi_square(pf: &PhaseFunction, mus: &[f64], min_width: f64) -> (f64, f64) {
    let edges = equiprobable_edges(pf, 64, min_width);
    let n = mus.len() as f64;
    let mut counts = vec![0.0f64; edges.len() - 1];
    for &mu in mus {
        let i = edges[1..edges.len() - 1].partition_point(|&e| e <= mu);
        counts[i] += 1.0;
    }
    let expected: Vec<f64> = edges.windows(2).map(|w| n * mass(pf, w[0], w[1])).collect();
    let (mut stat, mut bins, mut acc_o, mut acc_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in counts.iter().zip(&expected) {
        acc_o += o;
        acc_e += e;
        if acc_e >= 5.0 {
            stat += (acc_o - acc_e).powi(2) / acc_e;
            bins += 1;
            acc_o = 0.0;
            acc_e = 0.0;
        }
    }
    // A short tail is folded into the last complete bin's statistic as its own term.
    if acc_e > 0.0 {
        stat += (acc_o - acc_e).powi(2) / acc_e.max(5.0);
    }
    assert!(bins >= 2, "{pf:?}: too few bins for a chi-square test");
    let df = (bins - 1) as f64;
    // Wilson–Hilferty approximation of the chi-square quantile; z = Φ⁻¹(0.999).
    let z = 3.090_232;
    let h = 2.0 / (9.0 * df);
    (stat, df * (1.0 - h + z * h.sqrt()).powi(3))
}

/// Mean and standard error of a sample.
fn mean_se(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

#[test]
fn every_pdf_integrates_to_one() {
    for pf in cases() {
        let total = mass(&pf, -1.0, 1.0);
        assert!((total - 1.0).abs() < 1e-3, "{pf:?}: ∫ 2π p dμ = {total}");
    }
}

#[test]
fn no_nan_or_inf_at_extreme_xi_and_g() {
    let xis = [0.0, f64::MIN_POSITIVE, 1e-300, 1e-16, 2f64.powi(-24), 0.5, 1.0 - 2f64.powi(-24), 1.0 - 1e-16, 1.0];
    let mut all = cases();
    for g in [-1.0, 1.0, -G_MAX, G_MAX] {
        all.extend(g_kinds(g));
    }
    let wi = DVec3::new(0.3, -0.5, 0.8).normalize();
    for pf in all {
        assert!(pf.mean_cosine().is_finite(), "{pf:?}");
        for &xi in &xis {
            let mu = pf.sample_mu(xi);
            assert!(mu.is_finite() && (-1.0..=1.0).contains(&mu), "{pf:?} xi={xi}: mu={mu}");
            let p = pf.eval(mu);
            assert!(p.is_finite() && p > 0.0, "{pf:?} xi={xi}: p({mu})={p}");
            let (wo, pdf) = pf.sample(wi, [xi, xi]);
            assert!(wo.is_finite() && pdf.is_finite() && pdf > 0.0, "{pf:?} xi={xi}: {wo} {pdf}");
            assert!((wo.length() - 1.0).abs() < 1e-12, "{pf:?} xi={xi}: |wo|={}", wo.length());
        }
        for mu in [-1.0, -1.0 + 1e-12, 0.0, 1.0 - 1e-12, 1.0] {
            let p = pf.eval(mu);
            assert!(p.is_finite() && p > 0.0, "{pf:?}: p({mu})={p}");
        }
    }
}

#[test]
fn sample_mu_is_the_inverse_cdf() {
    // Single lobes only: mixtures pick a lobe first (so μ(ξ) is not monotone); their
    // distribution is covered by the chi-square tests.
    let single =
        |pf: &PhaseFunction| !matches!(pf, PhaseFunction::HgMixture { .. } | PhaseFunction::SchlickMixture { .. });
    for pf in cases().into_iter().filter(single) {
        let mut prev = -1.0;
        for i in 0..=200 {
            let xi = i as f64 / 200.0;
            let mu = pf.sample_mu(xi);
            assert!(mu >= prev, "{pf:?}: sample_mu not increasing at xi={xi}");
            prev = mu;
            let cdf = mass(&pf, -1.0, mu);
            assert!((cdf - xi).abs() < 1e-7, "{pf:?}: CDF(sample_mu({xi})) = {cdf}");
        }
    }
}

#[test]
fn rearranged_samplers_equal_textbook_formulas() {
    let xis: Vec<f64> = (1..100).map(|i| i as f64 / 100.0).collect();
    for g in [-0.9f32, -0.5, 0.3, 0.9] {
        let gd = g as f64;
        let hg = PhaseFunction::HenyeyGreenstein { g };
        let k = schlick_k(g) as f64;
        let sch = PhaseFunction::Schlick { g };
        for &xi in &xis {
            let s = (1.0 - gd * gd) / (1.0 - gd + 2.0 * gd * xi);
            let textbook = (1.0 + gd * gd - s * s) / (2.0 * gd);
            assert!((hg.sample_mu(xi) - textbook).abs() < 1e-12, "HG g={g} xi={xi}");
            let textbook = (2.0 * xi + k - 1.0) / (2.0 * k * xi - k + 1.0);
            assert!((sch.sample_mu(xi) - textbook).abs() < 1e-12, "Schlick g={g} xi={xi}");
        }
    }
    for &xi in &xis {
        let s = 2.0 * (2.0 * xi - 1.0);
        let r = (s * s + 1.0).sqrt();
        let cardano = (s + r).cbrt() + (s - r).cbrt();
        let mu = PhaseFunction::Rayleigh.sample_mu(xi);
        assert!((mu - cardano).abs() < 1e-12, "Rayleigh xi={xi}: {mu} vs {cardano}");
        assert!((mu.powi(3) + 3.0 * mu - 4.0 * (2.0 * xi - 1.0)).abs() < 1e-12, "cubic residual xi={xi}");
    }
}

#[test]
fn schlick_k_is_clamped_below_one() {
    // k(g) = 1.55g - 0.55g³ peaks at 1.0015 near g = 0.969: without the clamp p would go negative.
    let raw = |g: f64| 1.55 * g - 0.55 * g * g * g;
    assert!(raw(0.969) > 1.0);
    for g in [0.95f32, 0.969, 0.99, 1.0, -0.969, -1.0] {
        let k = schlick_k(g);
        assert!(k.abs() <= G_MAX, "g={g}: k={k}");
        assert!(PhaseFunction::Schlick { g }.eval(-1.0) > 0.0);
    }
    assert!((schlick_k(0.5) as f64 - raw(0.5)).abs() < 1e-7);
}

/// Henyey–Greenstein as printed in Henyey & Greenstein (1941), written out here so the checks
/// below do not lean on the library's own definition.
fn hg_textbook(g: f64, mu: f64) -> f64 {
    (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * mu).powf(1.5))
}

#[test]
fn hg_integrates_to_one_over_the_sphere_with_mean_cosine_g() {
    for g in GS {
        let gd = g as f64;
        let pf = PhaseFunction::HenyeyGreenstein { g };
        // The library's density is the textbook one (to f64 rounding) at μ in [-1, 1].
        for i in 0..=400 {
            let mu = -1.0 + i as f64 / 200.0;
            let (got, want) = (pf.eval(mu), hg_textbook(gd, mu));
            assert!((got - want).abs() <= 1e-9 * want, "g={g} μ={mu}: eval {got}, textbook {want}");
        }
        // Over the sphere, ∫ p(cos θ) dω = 2π ∫ p(cos θ) sin θ dθ = 1 (azimuthal symmetry about
        // wi), and the mean cosine 2π ∫ cos θ p sin θ dθ is g: integrated in θ, not μ, from the
        // library's eval, so a wrong normalisation or lobe width fails here.
        // Panels shrink geometrically towards the poles, where a lobe of g = ±0.999 is ~1e-3 wide.
        let mut cuts: Vec<f64> = (0..30).map(|k| PI * 0.5f64.powi(k + 1)).collect();
        cuts.extend((0..30).map(|k| PI - PI * 0.5f64.powi(k + 1)));
        cuts.extend([0.0, PI]);
        cuts.sort_by(f64::total_cmp);
        cuts.dedup();
        let sphere = |f: &dyn Fn(f64) -> f64| -> f64 {
            2.0 * PI * cuts.windows(2).map(|w| quad(&|t: f64| f(t) * t.sin(), w[0], w[1], 1e-11)).sum::<f64>()
        };
        let total = sphere(&|t| pf.eval(t.cos()));
        let mean = sphere(&|t| t.cos() * pf.eval(t.cos()));
        assert!((total - 1.0).abs() < 1e-6, "g={g}: ∫ p dω = {total}");
        assert!((mean - gd).abs() < 1e-6, "g={g}: ∫ cos θ p dω = {mean}, want g");
    }
}

#[test]
fn hg_sampled_mean_equals_g() {
    let mut rng = Rng(7);
    for g in GS {
        let pf = PhaseFunction::HenyeyGreenstein { g };
        let mus: Vec<f64> = (0..1 << 17).map(|_| pf.sample_mu(rng.next())).collect();
        let (m, se) = mean_se(&mus);
        // Against the literal g, not the library's mean_cosine (which simply returns g).
        assert!((m - g as f64).abs() <= 4.0 * se + 1e-12, "g={g}: mean {m} ± {se}");
        // And the histogram against the textbook density by chi-square.
        let (stat, crit) = chi_square(&PhaseFunction::HenyeyGreenstein { g }, &mus, 0.0);
        assert!(stat < crit, "g={g}: chi² {stat} ≥ {crit}");
    }
}

#[test]
fn analytic_mean_cosine_matches_samples() {
    let mut rng = Rng(11);
    for pf in cases() {
        let mus: Vec<f64> = (0..1 << 17).map(|_| pf.sample_mu(rng.next())).collect();
        let (m, se) = mean_se(&mus);
        let want = pf.mean_cosine();
        assert!((m - want).abs() <= 4.0 * se + 1e-12, "{pf:?}: sampled {m} ± {se}, analytic {want}");
        let by_quad = quad(&|mu| 2.0 * PI * mu * pf.eval(mu), -1.0, 1.0, 1e-13);
        assert!((by_quad - want).abs() < 1e-7, "{pf:?}: ∫ μ p = {by_quad}, analytic {want}");
    }
}

#[test]
fn chi_square_cpu_samples_vs_pdf() {
    let mut rng = Rng(3);
    for pf in cases() {
        let mus: Vec<f64> = (0..1 << 17).map(|_| pf.sample_mu(rng.next())).collect();
        let (stat, crit) = chi_square(&pf, &mus, 0.0);
        assert!(stat < crit, "{pf:?}: chi² {stat} ≥ {crit}");
    }
}

#[test]
fn chi_square_rejects_a_wrong_sampler() {
    // Guards the guard: HG(0.3) samples must fail against HG(0.35) and against the flipped lobe.
    let mut rng = Rng(5);
    let pf = PhaseFunction::HenyeyGreenstein { g: 0.3 };
    let mus: Vec<f64> = (0..1 << 17).map(|_| pf.sample_mu(rng.next())).collect();
    let (stat, crit) = chi_square(&PhaseFunction::HenyeyGreenstein { g: 0.35 }, &mus, 0.0);
    assert!(stat > crit, "chi² {stat} < {crit}");
    let flipped: Vec<f64> = mus.iter().map(|m| -m).collect();
    let (stat, crit) = chi_square(&pf, &flipped, 0.0);
    assert!(stat > crit, "chi² {stat} < {crit}");
}

#[test]
fn positive_g_scatters_forward_negative_backward() {
    // Stratified inverse-CDF mean: deterministic, accurate enough to resolve g = 1e-4.
    let n = 1 << 20;
    for g in GS.into_iter().filter(|&g| g != 0.0) {
        for pf in g_kinds(g) {
            let mean = (0..n).map(|i| pf.sample_mu((i as f64 + 0.5) / n as f64)).sum::<f64>() / n as f64;
            assert!(mean * g as f64 > 0.0, "{pf:?}: mean μ {mean} has the wrong sign");
            assert!((mean - pf.mean_cosine()).abs() < 1e-6, "{pf:?}: {mean} vs {}", pf.mean_cosine());
            assert!((pf.eval(0.9) - pf.eval(-0.9)) * g as f64 > 0.0, "{pf:?}: peak on the wrong side");
        }
    }
}

#[test]
fn sampled_directions_are_unit_with_the_sampled_cosine() {
    let mut rng = Rng(9);
    let pf = PhaseFunction::HgMixture { g1: 0.7, g2: -0.4, w: 0.6 };
    for wi in [DVec3::Z, -DVec3::Z, DVec3::X, DVec3::new(1e-9, 0.0, -1.0).normalize(), DVec3::new(0.3, -0.5, 0.8)] {
        let wi = wi.normalize();
        let (t, b) = orthonormal_basis(wi);
        assert!(t.dot(b).abs() < 1e-12 && t.dot(wi).abs() < 1e-12 && b.dot(wi).abs() < 1e-12, "{wi}");
        assert!((t.cross(b) - wi).length() < 1e-12, "basis not right-handed around {wi}");
        let mut sum = DVec3::ZERO;
        let n = 1 << 16;
        for _ in 0..n {
            let xi = [rng.next(), rng.next()];
            let (wo, pdf) = pf.sample(wi, xi);
            assert!((wo.length() - 1.0).abs() < 1e-12);
            assert!((wo.dot(wi) - pf.sample_mu(xi[0])).abs() < 1e-12);
            assert!((pdf - pf.pdf(wi, wo)).abs() <= 1e-9 * pdf);
            sum += wo;
        }
        // Uniform azimuth: the mean direction is mean_cosine·wi (transverse parts cancel).
        let mean = sum / n as f64;
        assert!((mean - pf.mean_cosine() * wi).length() < 0.02, "{wi}: mean wo {mean}");
    }
}

#[test]
fn gpu_packing_and_serde() {
    let w = PhaseFunction::HenyeyGreenstein { g: 0.5 }.to_gpu();
    assert_eq!(w, [KIND_HG, 0.5f32.to_bits(), 0f32.to_bits(), 1f32.to_bits()]);
    let w = PhaseFunction::HenyeyGreenstein { g: 1.0 }.to_gpu();
    assert_eq!(f32::from_bits(w[1]), G_MAX);
    let w = PhaseFunction::Schlick { g: 0.5 }.to_gpu();
    assert_eq!(w, [KIND_SCHLICK, schlick_k(0.5).to_bits(), 0, 1f32.to_bits()]);
    let w = PhaseFunction::SchlickMixture { g1: 0.9, g2: -0.2, w: 0.6 }.to_gpu();
    assert_eq!(w, [5, schlick_k(0.9).to_bits(), schlick_k(-0.2).to_bits(), 0.6f32.to_bits()]);
    for pf in cases() {
        let json = serde_json::to_string(&pf).expect("serialize");
        let back: PhaseFunction = serde_json::from_str(&json).expect("deserialize");
        assert_eq!(back, pf, "{json}");
    }
    let pf: PhaseFunction = serde_json::from_str(r#"{"kind":"henyey_greenstein","g":0.25}"#).expect("parse");
    assert_eq!(pf, PhaseFunction::HenyeyGreenstein { g: 0.25 });
}

// ---------------------------------------------------------------------------------------------
// GPU

/// CPU twin of `pcg_hash` (`shaders_glsl/common/hash.glsl`).
fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

/// CPU twin of `rng_state` (`shaders_glsl/volume/random.glsl`).
fn rng_state(px: u32, py: u32, frame: u32, stream: u32) -> u32 {
    pcg_hash(px.wrapping_add(pcg_hash(py.wrapping_add(pcg_hash(frame.wrapping_add(pcg_hash(stream)))))))
}

/// CPU twin of `rand01`.
fn rand01(s: &mut u32) -> f32 {
    *s = s.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((*s >> ((*s >> 28) + 4)) ^ *s).wrapping_mul(277803737);
    u32_to_open01((word >> 22) ^ word)
}

/// CPU twin of `u32_to_open01`.
fn u32_to_open01(x: u32) -> f32 {
    ((x >> 9) as f32 + 0.5) * (1.0 / 8388608.0)
}

const FLOATS: usize = 12;

/// Runs `test/phase_sample.comp` and returns its `count × 12` floats.
fn run(ctx: &vkengine::vk::Context, pf: &PhaseFunction, count: u32, frame: u32, mode: u32, wi: [f32; 3]) -> Vec<f32> {
    let bindings = [Binding::new(0, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::COMPUTE)];
    let pipe = Pipeline::compute(ctx, &shaders::TEST_PHASE_SAMPLE_COMP, &bindings, 48).expect("pipeline");
    let buf = Buffer::new(
        ctx,
        "phase samples",
        (count as usize * FLOATS * 4) as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )
    .expect("buffer");
    let p = pf.to_gpu();
    let push = [p[0], p[1], p[2], p[3], count, frame, mode, 0, wi[0].to_bits(), wi[1].to_bits(), wi[2].to_bits(), 0];
    ctx.one_shot(|cmd| {
        pipe.bind(cmd, &[Descriptor::StorageBuffer(buf.raw)], &push_words(&push))?;
        // SAFETY: pipeline bound with its only descriptor and all push constants.
        unsafe { ctx.device.cmd_dispatch(cmd, count.div_ceil(64), 1, 1) };
        Ok(())
    })
    .expect("dispatch");
    let bytes = ctx.read_buffer(&buf).expect("readback");
    bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// Checks one GPU run of `pf` against the CPU reference.
fn check_gpu_samples(pf: &PhaseFunction, out: &[f32], wi: DVec3) {
    let n = out.len() / FLOATS;
    let mut mus = Vec::with_capacity(n);
    let mut wo_sum = DVec3::ZERO;
    for (i, r) in out.chunks_exact(FLOATS).enumerate() {
        assert!(r.iter().all(|v| v.is_finite()), "{pf:?} #{i}: non-finite output {r:?}");
        let mu = r[0] as f64;
        let want = pf.eval(mu);
        assert!(
            (r[1] as f64 - want).abs() <= 1e-4 * want,
            "{pf:?} #{i}: GPU phase_eval({mu}) = {} vs CPU {want}",
            r[1]
        );
        // phase_pdf(wi, wo) and the sampled pdf against the CPU density at the direction the
        // shader returned, in f64. Their only honest difference is where that direction is: the
        // shader's wi and wo are f32 vectors whose components and lengths are off by up to
        // EPS = 4e-7 (a few ulps), so the chord c = |wi ∓ wo| to the nearer pole moves by up to
        // EPS and t = c²/2 = 1 ∓ μ by up to c·EPS + EPS². The tolerance is the CPU density's
        // change over that t, plus 1e-4 relative for the f32 formula. A density taken at the f32
        // dot(wi, wo) instead is off by ~1e-7 in t, which at g = −0.999 (a lobe ~5e-7 wide) was
        // 159,079 against 96,517 on an H200.
        const EPS: f64 = 4e-7;
        let wo = DVec3::new(r[4] as f64, r[5] as f64, r[6] as f64).normalize();
        let mu_cpu = wi.dot(wo).clamp(-1.0, 1.0);
        let want_pdf = pf.eval(mu_cpu);
        let c = (wi - wo).length().min((wi + wo).length());
        let dt = c * EPS + EPS * EPS;
        let spread = [mu_cpu - dt, mu_cpu + dt]
            .iter()
            .map(|m| (pf.eval(m.clamp(-1.0, 1.0)) - want_pdf).abs())
            .fold(0.0, f64::max);
        let tol = 1e-4 * want_pdf + spread;
        assert!(
            (r[3] as f64 - want_pdf).abs() <= tol,
            "{pf:?} #{i}: GPU phase_pdf(wi, wo) = {} vs CPU p(wi·wo) = {want_pdf} ± {tol}",
            r[3]
        );
        assert!(
            (r[2] as f64 - want_pdf).abs() <= tol,
            "{pf:?} #{i}: sampled pdf {} vs CPU p(wi·wo) = {want_pdf} ± {tol}",
            r[2]
        );
        assert!((r[7] - 1.0).abs() < 1e-5, "{pf:?} #{i}: |wo| = {}", r[7]);
        wo_sum += DVec3::new(r[4] as f64, r[5] as f64, r[6] as f64);
        mus.push(mu);
    }
    // 2e-5 wide bins at least: f32 μ near ±1 is quantized at ~6e-8.
    let (stat, crit) = chi_square(pf, &mus, 2e-5);
    assert!(stat < crit, "{pf:?}: GPU chi² {stat} ≥ {crit}");
    let (m, se) = mean_se(&mus);
    let want = pf.mean_cosine();
    assert!((m - want).abs() <= 4.0 * se + 1e-6, "{pf:?}: GPU mean μ {m} ± {se} vs {want}");
    let transverse = wo_sum / n as f64 - m * wi;
    assert!(transverse.length() < 0.02, "{pf:?}: azimuth not uniform, mean transverse {transverse}");
}

#[test]
fn gpu_samples_match_cpu_reference() {
    common::gpu_test(|ctx| {
        let wi = [0.3f32, -0.5, 0.8];
        let wi_n = DVec3::new(0.3, -0.5, 0.8).normalize();
        for (frame, pf) in cases().iter().enumerate() {
            let out = run(ctx, pf, 1 << 16, frame as u32, 0, wi);
            check_gpu_samples(pf, &out, wi_n);
        }
    });
}

#[test]
fn gpu_frame_is_robust_at_the_poles() {
    common::gpu_test(|ctx| {
        let pf = PhaseFunction::HenyeyGreenstein { g: 0.6 };
        for wi in [[0.0f32, 0.0, 1.0], [0.0, 0.0, -1.0], [1e-4, 0.0, -1.0], [1.0, 0.0, 0.0]] {
            let out = run(ctx, &pf, 1 << 16, 1, 0, wi);
            let wi_n = DVec3::new(wi[0] as f64, wi[1] as f64, wi[2] as f64).normalize();
            check_gpu_samples(&pf, &out, wi_n);
        }
    });
}

#[test]
fn gpu_rng_is_open_and_matches_cpu_twin() {
    common::gpu_test(|ctx| {
        let n = 1 << 16;
        let edge = run(ctx, &PhaseFunction::Isotropic, n, 0, 1, [0.0, 0.0, 1.0]);
        let words = [0u32, 0xFFFF_FFFF, 0xFFFF_FE00, 0x0000_01FF, 0x8000_0000, 0x7FFF_FFFF];
        for i in 0..n as usize {
            let x = edge[i * FLOATS];
            let want = u32_to_open01(if i < words.len() { words[i] } else { pcg_hash(i as u32) });
            assert_eq!(x, want, "u32_to_open01 word #{i}");
            assert!(x > 0.0 && x < 1.0, "xi #{i} = {x} not in (0,1)");
        }
        assert_eq!(edge[FLOATS], 1.0 - 2f32.powi(-24), "largest xi");
        assert_eq!(edge[0], 2f32.powi(-24), "smallest xi");

        for frame in [0u32, 1] {
            let out = run(ctx, &PhaseFunction::Isotropic, n, frame, 0, [0.0, 0.0, 1.0]);
            let xis: Vec<[f32; 2]> = out.chunks_exact(FLOATS).map(|r| [r[8], r[9]]).collect();
            for (i, xi) in xis.iter().enumerate() {
                let mut s = rng_state(i as u32 % 256, i as u32 / 256, frame, 0);
                let want = [rand01(&mut s), rand01(&mut s)];
                assert_eq!(*xi, want, "frame {frame} pixel #{i}: GPU xi != CPU twin");
                assert!(xi.iter().all(|&x| x > 0.0 && x < 1.0), "xi {xi:?} not in (0,1)");
            }
            // Neighbouring pixels (and the two draws of a pixel) are uncorrelated: |r| < 4/√n.
            let corr = |a: &[f64], b: &[f64]| {
                let (ma, mb) = (a.iter().sum::<f64>() / a.len() as f64, b.iter().sum::<f64>() / b.len() as f64);
                let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
                let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
                let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
                cov / (va * vb).sqrt()
            };
            let x0: Vec<f64> = xis.iter().map(|x| x[0] as f64).collect();
            let x1: Vec<f64> = xis.iter().map(|x| x[1] as f64).collect();
            let limit = 4.0 / (n as f64).sqrt();
            assert!(corr(&x0[..n as usize - 1], &x0[1..]).abs() < limit, "x-neighbour correlation");
            assert!(corr(&x0[..n as usize - 256], &x0[256..]).abs() < limit, "y-neighbour correlation");
            assert!(corr(&x0, &x1).abs() < limit, "draw-to-draw correlation");
            let (m, se) = mean_se(&x0);
            assert!((m - 0.5).abs() < 4.0 * se, "mean xi {m}");
        }
        // Different pixels, frames and streams start different sequences.
        let mut a = rng_state(0, 0, 0, 0);
        let mut b = rng_state(1, 0, 0, 0);
        let mut c = rng_state(0, 0, 1, 0);
        let mut d = rng_state(0, 0, 0, 1);
        let seq = |s: &mut u32| (0..8).map(|_| rand01(s)).collect::<Vec<_>>();
        let (sa, sb, sc, sd) = (seq(&mut a), seq(&mut b), seq(&mut c), seq(&mut d));
        assert!(sa != sb && sa != sc && sa != sd && sb != sc);
    });
}
