//! Blackbody emission: Planck's law integrated against the CIE 1931 colour-matching functions,
//! in linear sRGB (Rec. 709 primaries, D65 white), for temperature-driven emissive media.

/// Second radiation constant hc/k in m·K (CODATA 2018).
const C2: f64 = 1.438_776_877e-2;
/// Wavelengths integrated over (nm), in 1 nm steps: where the colour-matching functions are not
/// negligible.
const LAMBDA: std::ops::RangeInclusive<u32> = 360..=830;
/// Entries of the GPU table over a temperature range.
pub const TABLE_SIZE: usize = 256;

/// Planck's spectral radiance at wavelength `nm` and temperature `kelvin`, up to the constant
/// factor 2hc² (which the normalisation removes): λ⁻⁵ / (exp(c2/(λT)) − 1), λ in metres.
pub fn planck(nm: f64, kelvin: f64) -> f64 {
    let l = nm * 1e-9;
    1.0 / (l.powi(5) * (C2 / (l * kelvin)).exp_m1())
}

/// CIE 1931 2° colour-matching functions (x̄, ȳ, z̄) by the multi-lobe Gaussian fit of Wyman,
/// Sloan and Shirley (JCGT 2013), accurate to about 1 % of the tabulated functions' peak.
pub fn cie_xyz(nm: f64) -> [f64; 3] {
    let g = |mu: f64, s1: f64, s2: f64| {
        let t = (nm - mu) / if nm < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    [
        1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
        0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
        1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8),
    ]
}

/// CIE XYZ of a blackbody at `kelvin` (same arbitrary unit for every temperature).
pub fn xyz(kelvin: f64) -> [f64; 3] {
    LAMBDA.fold([0.0; 3], |acc, nm| {
        let (b, c) = (planck(f64::from(nm), kelvin), cie_xyz(f64::from(nm)));
        [acc[0] + b * c[0], acc[1] + b * c[1], acc[2] + b * c[2]]
    })
}

/// CIE XYZ → linear sRGB (IEC 61966-2-1).
pub fn xyz_to_linear_srgb(c: [f64; 3]) -> [f64; 3] {
    [
        3.2406 * c[0] - 1.5372 * c[1] - 0.4986 * c[2],
        -0.9689 * c[0] + 1.8758 * c[1] + 0.0415 * c[2],
        0.0557 * c[0] - 0.2040 * c[1] + 1.0570 * c[2],
    ]
}

/// Linear sRGB radiance of a blackbody at `kelvin`, scaled so that a blackbody at `reference`
/// kelvin has luminance Y = 1: hotter is brighter (∝ T⁴ overall) and bluer. Channels outside
/// the sRGB gamut (red-hot blue) are clamped at 0.
pub fn radiance(kelvin: f64, reference: f64) -> [f64; 3] {
    let y = xyz(reference)[1];
    xyz_to_linear_srgb(xyz(kelvin)).map(|c| (c / y).max(0.0))
}

/// The GPU table: [`TABLE_SIZE`] RGBA texels at temperatures evenly spaced from `range[0]` to
/// `range[1]` (the last texel is the hottest), normalised to luminance 1 at `range[1]`.
pub fn table(range: [f32; 2]) -> Vec<[f32; 4]> {
    let (lo, hi) = (f64::from(range[0]), f64::from(range[1]));
    (0..TABLE_SIZE)
        .map(|i| {
            let t = lo + (hi - lo) * i as f64 / (TABLE_SIZE - 1) as f64;
            let [r, g, b] = radiance(t, hi).map(|c| c as f32);
            [r, g, b, 1.0]
        })
        .collect()
}
