#ifndef VOLUME_PHASE_GLSL
#define VOLUME_PHASE_GLSL
// Phase functions for the volumetric path tracer. CPU twin: engine/volume/optics/phase.rs (the tests
// compare both). Convention (REFERENCE.md): mu = dot(wi, wo) with wi the direction light travels
// BEFORE scattering and wo the direction it travels after, so g > 0 scatters forward and the
// mean of sampled mu equals g for Henyey-Greenstein. Every p(mu) is a density over the sphere of
// directions: integral of 2*pi*p(mu) dmu over [-1,1] is 1.
//
// Numerics: lobes are evaluated and sampled through t = 1 - sign(g)*mu (distance from the lobe's
// peak), which is exact near the peak where 1 + g^2 - 2*g*mu cancels catastrophically in f32.
// |g| (and Schlick's |k|) is clamped to PHASE_G_MAX = 0.999 so g = +-1 never gives 0/0; note that
// at |g| = 0.999 the HG lobe is ~5e-7 wide in mu, only ~10 f32 ulps of mu, so prefer |g| <= 0.99.

// Phase.kind values.
const uint PHASE_ISOTROPIC = 0u;
const uint PHASE_HG = 1u;         // Henyey-Greenstein, g = asymmetry
const uint PHASE_SCHLICK = 2u;    // Schlick, g field holds k (precomputed on the CPU, see below)
const uint PHASE_RAYLEIGH = 3u;
const uint PHASE_HG_MIX = 4u;     // w * HG(g) + (1 - w) * HG(g2)
const uint PHASE_SCHLICK_MIX = 5u; // w * Schlick(k = g) + (1 - w) * Schlick(k = g2)

const float PHASE_G_MAX = 0.999;
const float PHASE_INV_4PI = 0.07957747154594767;

// 16 bytes, scalar/std140/std430 compatible; packed by PhaseFunction::to_gpu in Rust.
// For the Schlick kinds g and g2 hold k = 1.55g - 0.55g^3 already clamped to +-PHASE_G_MAX:
// k(g) exceeds 1 for g in ~(0.94, 1) (peak 1.0015 at g = 0.969), and computing it once on the
// CPU keeps the GPU bit-identical to the reference instead of re-rounding a cubic.
struct Phase {
    uint kind;
    float g;  // HG: g of lobe 1; Schlick: k of lobe 1
    float g2; // mixtures: parameter of lobe 2
    float w;  // mixtures: weight of lobe 1 in [0,1]
};

// HG density at distance t = 1 - sign(g) mu from its peak; stable form
// 1 + g^2 - 2 g mu = (1 - a)^2 + 2 a t with a = |g|.
float phase_hg_eval_t(float g, float t) {
    float a = abs(clamp(g, -PHASE_G_MAX, PHASE_G_MAX));
    float d = (1.0 - a) * (1.0 - a) + 2.0 * a * t;
    return PHASE_INV_4PI * (1.0 - a) * (1.0 + a) / (d * sqrt(d));
}

// Schlick density with 1 - k mu = (1 - a) + a t, a = |k|, t = 1 - sign(k) mu.
float phase_schlick_eval_t(float k, float t) {
    float a = abs(clamp(k, -PHASE_G_MAX, PHASE_G_MAX));
    float q = (1.0 - a) + a * t;
    return PHASE_INV_4PI * (1.0 - a) * (1.0 + a) / (q * q);
}

// A lobe's t from the pair (1 - mu, 1 + mu): its peak is at mu = sign(g).
float phase_lobe_t(float g, vec2 t) { return g < 0.0 ? t.y : t.x; }

// HG at cosine mu (the fog pass).
float phase_hg_eval(float g, float mu) { return phase_hg_eval_t(g, phase_lobe_t(g, vec2(1.0 - mu, 1.0 + mu))); }

// Inverse CDF of HG as t = 1 - sign(g) mu. Algebraically equal to the textbook
// mu = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g xi))^2) / (2g) but without the 1/g, so g -> 0 needs no
// isotropic special case (it reduces to mu = 2 xi - 1 exactly). For g < 0, xi is mirrored so mu
// still increases with xi (a true inverse CDF, which keeps stratification intact).
float phase_hg_sample_t(float g, float xi) {
    g = clamp(g, -PHASE_G_MAX, PHASE_G_MAX);
    float a = abs(g);
    float x = g < 0.0 ? 1.0 - xi : xi;
    float den = 1.0 - a + 2.0 * a * x;
    return 2.0 * (1.0 - a) * (1.0 - a) * (1.0 - x) * (1.0 + a * x) / (den * den);
}

// Inverse CDF of Schlick as t: mu = (2 xi + k - 1) / (2 k xi - k + 1) rewritten as
// 1 - mu = 2 (1 - k)(1 - xi) / (1 - k + 2 k xi); forward for k > 0 (checked by tests/phase.rs).
float phase_schlick_sample_t(float k, float xi) {
    k = clamp(k, -PHASE_G_MAX, PHASE_G_MAX);
    float a = abs(k);
    float x = k < 0.0 ? 1.0 - xi : xi;
    return 2.0 * (1.0 - a) * (1.0 - x) / (1.0 - a + 2.0 * a * x);
}

// Rayleigh inverse CDF: root of mu^3 + 3 mu = 4 (2 xi - 1). Cardano gives
// mu = cbrt(s + r) + cbrt(s - r), s = 2 (2 xi - 1), r = sqrt(s^2 + 1); the two roots multiply to -1,
// so mu = sign(s) (u - 1/u) with u = cbrt(|s| + r) >= 1: no cube root of a negative number (GLSL
// pow(x, 1/3) is undefined for x < 0).
float phase_rayleigh_sample_mu(float xi) {
    float s = 2.0 * (2.0 * xi - 1.0);
    float u = pow(abs(s) + sqrt(s * s + 1.0), 1.0 / 3.0);
    return clamp((s < 0.0 ? -1.0 : 1.0) * (u - 1.0 / u), -1.0, 1.0);
}

// Value of the phase function (density over the sphere) given t = (1 - mu, 1 + mu), each exact
// near its own end: a lobe at g = -0.999 is ~5e-7 wide in mu, about 8 f32 ulps of mu near -1, so
// a density evaluated at a rounded mu is off by up to 2x there (the H200 and lavapipe rounded one
// sample's dot product differently: 159,079 against 96,517).
float phase_eval_t(Phase p, vec2 t) {
    t = clamp(t, 0.0, 2.0);
    float w = clamp(p.w, 0.0, 1.0);
    switch (p.kind) {
    case PHASE_HG:
        return phase_hg_eval_t(p.g, phase_lobe_t(p.g, t));
    case PHASE_SCHLICK:
        return phase_schlick_eval_t(p.g, phase_lobe_t(p.g, t));
    case PHASE_RAYLEIGH: {
        float mu = t.x <= 1.0 ? 1.0 - t.x : t.y - 1.0;
        return (3.0 / 16.0) * (1.0 / 3.14159265358979) * (1.0 + mu * mu);
    }
    case PHASE_HG_MIX:
        return w * phase_hg_eval_t(p.g, phase_lobe_t(p.g, t)) + (1.0 - w) * phase_hg_eval_t(p.g2, phase_lobe_t(p.g2, t));
    case PHASE_SCHLICK_MIX:
        return w * phase_schlick_eval_t(p.g, phase_lobe_t(p.g, t)) + (1.0 - w) * phase_schlick_eval_t(p.g2, phase_lobe_t(p.g2, t));
    default:
        return PHASE_INV_4PI;
    }
}

// Value of the phase function (density over the sphere) at cosine mu.
float phase_eval(Phase p, float mu) {
    mu = clamp(mu, -1.0, 1.0);
    return phase_eval_t(p, vec2(1.0 - mu, 1.0 + mu));
}

// Density of scattering light travelling along wi into wo (both unit vectors). 1 -/+ mu are taken
// as half the squared chord |wi -/+ wo|^2 between the directions, not from dot(wi, wo): near a
// lobe's peak the chord is mostly the transverse sin(theta), and the vectors' f32 length errors
// (~1e-7, which enter 1 - dot linearly) enter it only squared.
float phase_pdf(Phase p, vec3 wi, vec3 wo) {
    vec3 dm = wi - wo, dp = wi + wo;
    return phase_eval_t(p, 0.5 * vec2(dot(dm, dm), dot(dp, dp)));
}

// Samples mu = cos(theta) by inverse CDF; also returns sin(theta), computed from the distance to
// the lobe peak so narrow lobes keep their angular resolution (sqrt(1 - mu^2) would quantize),
// and t = (1 - mu, 1 + mu) with the sampled lobe's own end exact, for the sample's density.
float phase_sample_mu(Phase p, float xi, out float sin_theta, out vec2 tt) {
    uint kind = p.kind;
    float g = p.g;
    if (kind == PHASE_HG_MIX || kind == PHASE_SCHLICK_MIX) {
        // Pick lobe 1 with probability w and reuse xi rescaled to [0,1] (endpoints are safe below).
        float w = clamp(p.w, 0.0, 1.0);
        bool first = xi < w;
        xi = clamp(first ? xi / w : (xi - w) / (1.0 - w), 0.0, 1.0);
        g = first ? p.g : p.g2;
        kind = kind == PHASE_HG_MIX ? PHASE_HG : PHASE_SCHLICK;
    }
    if (kind == PHASE_HG || kind == PHASE_SCHLICK) {
        float t = kind == PHASE_HG ? phase_hg_sample_t(g, xi) : phase_schlick_sample_t(g, xi);
        t = clamp(t, 0.0, 2.0);
        sin_theta = sqrt(max(t * (2.0 - t), 0.0));
        tt = g < 0.0 ? vec2(2.0 - t, t) : vec2(t, 2.0 - t);
        return g < 0.0 ? t - 1.0 : 1.0 - t;
    }
    float mu = kind == PHASE_RAYLEIGH ? phase_rayleigh_sample_mu(xi) : 2.0 * xi - 1.0;
    sin_theta = sqrt(max((1.0 - mu) * (1.0 + mu), 0.0));
    tt = vec2(1.0 - mu, 1.0 + mu);
    return mu;
}

// Orthonormal t, b with (t, b, n) right-handed, for unit n; branchless except for the sign
// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"). GLSL sign(0) = 0, hence the select.
void phase_frame(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Samples the outgoing propagation direction wo for light travelling along unit wi, with
// xi in [0,1]^2 (xi.x -> mu, xi.y -> azimuth); pdf = phase_eval(p, mu) (solid-angle density).
vec3 phase_sample(Phase p, vec3 wi, vec2 xi, out float pdf) {
    float sin_theta;
    vec2 tt;
    float mu = phase_sample_mu(p, xi.x, sin_theta, tt);
    vec3 t;
    vec3 b;
    phase_frame(wi, t, b);
    float phi = 6.283185307179586 * xi.y;
    pdf = phase_eval_t(p, tt);
    return mu * wi + sin_theta * (cos(phi) * t + sin(phi) * b);
}
#endif
