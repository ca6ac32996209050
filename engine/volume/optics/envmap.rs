//! HDR environment maps for image-based lighting of the Monte Carlo renderers: loading
//! (`.exr`/`.hdr`, equirectangular lat-long), a procedural sky for tests and demos, and the 2D
//! piecewise-constant importance-sampling distribution (pbrt's `Distribution2D`) that the MC
//! shader walks for next-event estimation. The CPU sampler here is the shader's twin: tests check
//! its pdf and histogram, and the shader stores the same tables.
//!
//! Convention (shared with `mc.comp`): in the map's own frame, +Y is the zenith (image row 0),
//! `θ = acos(d.y)` runs down the rows, `φ = atan2(d.z, d.x) ∈ [0, 2π)` runs along the columns
//! (`u = φ / 2π`, `v = θ / π`). `rotation` turns the map about +Y: world direction `d` looks up
//! the map at `R_y(-rotation)·d`.

use crate::error::{Error, Result};
use std::f32::consts::PI;
use std::path::Path;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// An equirectangular HDR environment map (linear RGB, row 0 = zenith).
#[derive(Clone, Debug)]
pub struct EnvMap {
    /// Width (φ) in texels.
    pub width: u32,
    /// Height (θ) in texels.
    pub height: u32,
    /// Row-major linear radiance.
    pub texels: Vec<[f32; 3]>,
    /// Where it came from (file path or a description), for messages.
    pub source: String,
}

/// Checks an OpenEXR header's `displayWindow` and `dataWindow`: each must have min ≤ max and
/// at most [`MAX_ALLOC`] bytes of texels; the decoder sizes buffers from an inverted display
/// window without a check (found by `fuzz_loaders`: 800 MB for a 700-byte file).
fn check_exr_windows(bytes: &[u8]) -> std::result::Result<(), String> {
    // Magic and version, then attributes `name\0 type\0 size:u32 value` up to an empty name.
    let mut pos = 8;
    let cstr = |at: usize| {
        bytes.get(at..).and_then(|r| r.iter().position(|&b| b == 0)).map(|n| (&bytes[at..at + n], at + n + 1))
    };
    while let Some((attr, next)) = cstr(pos) {
        if attr.is_empty() {
            break;
        }
        let Some((ty, next)) = cstr(next) else { break };
        let Some(size) = bytes.get(next..next + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
        else {
            break;
        };
        let value = next + 4;
        if ty == b"box2i" && (attr == b"displayWindow" || attr == b"dataWindow") && size == 16 {
            let Some(v) = bytes.get(value..value + 16) else { break };
            let i = |k: usize| i64::from(i32::from_le_bytes([v[4 * k], v[4 * k + 1], v[4 * k + 2], v[4 * k + 3]]));
            let (w, h) = (i(2) - i(0) + 1, i(3) - i(1) + 1);
            let what = String::from_utf8_lossy(attr);
            if w < 1 || h < 1 {
                return Err(format!("OpenEXR {what} ({}, {})–({}, {}) is empty or inverted", i(0), i(1), i(2), i(3)));
            }
            if w.saturating_mul(h).saturating_mul(16) as u64 > MAX_ALLOC {
                return Err(format!("OpenEXR {what} of {w} x {h} texels is larger than an environment map may be"));
            }
        }
        pos = value.saturating_add(size);
    }
    Ok(())
}

/// Most bytes an environment map file may decode to (an 8192 × 4096 RGBA f32 map is 512 MiB);
/// a header claiming more is an error, not an allocation.
pub const MAX_ALLOC: u64 = 512 << 20;

impl EnvMap {
    /// Builds a map from texels; rejects empty sizes, wrong lengths and non-finite or negative
    /// radiance (a NaN would poison the sampling tables and every pixel that sees it).
    pub fn new(width: u32, height: u32, texels: Vec<[f32; 3]>, source: &str) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::Input(format!("{source}: environment map has size {width}x{height}")));
        }
        if texels.len() != width as usize * height as usize {
            return Err(Error::Input(format!(
                "{source}: {} texels for a {width}x{height} environment map",
                texels.len()
            )));
        }
        if let Some(i) = texels.iter().position(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0)) {
            let (x, y) = (i as u32 % width, i as u32 / width);
            return Err(Error::Input(format!(
                "{source}: environment map texel ({x}, {y}) is {:?}; radiance must be finite and non-negative",
                texels[i]
            )));
        }
        Ok(Self { width, height, texels, source: source.to_string() })
    }

    /// Loads an `.exr` or `.hdr` file (any format the `image` crate decodes, converted to linear
    /// f32 RGB). Every failure names the file.
    pub fn load(path: &Path) -> Result<Self> {
        let name = path.display().to_string();
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("exr" | "hdr")) {
            return Err(Error::Input(format!("{name}: environment maps must be .exr or .hdr files")));
        }
        if !path.is_file() {
            return Err(Error::Input(format!("{name}: environment map file not found")));
        }
        let mut reader = image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| Error::Input(format!("{name}: cannot open environment map: {e}")))?;
        // Compressed maps (RLE .hdr, zip .exr) legitimately decode to far more than their file
        // size, so the bound is on what the header claims: at most MAX_ALLOC bytes decoded.
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(MAX_ALLOC);
        reader.limits(limits);
        // The EXR decoder does not keep to max_alloc (a 300-byte file made it allocate 800 MB,
        // found by fuzz_loaders): check the header's size first.
        let probe = image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| Error::Input(format!("{name}: cannot open environment map: {e}")))?;
        let (w, h) =
            probe.into_dimensions().map_err(|e| Error::Input(format!("{name}: cannot read environment map: {e}")))?;
        if ext.as_deref() == Some("exr") {
            let bytes = std::fs::read(path).map_err(|e| Error::Input(format!("{name}: cannot read: {e}")))?;
            check_exr_windows(&bytes).map_err(|m| Error::Input(format!("{name}: {m}")))?;
        }
        if u64::from(w) * u64::from(h) * 16 > MAX_ALLOC {
            return Err(Error::Input(format!(
                "{name}: {w} x {h} texels is larger than an environment map may be ({} MiB decoded)",
                MAX_ALLOC >> 20
            )));
        }
        let img = reader
            .decode()
            .map_err(|e| Error::Input(format!("{name}: cannot decode environment map: {e}")))?
            .into_rgb32f();
        let (w, h) = img.dimensions();
        let texels = img.pixels().map(|p| p.0).collect();
        Self::new(w, h, texels, &name)
    }

    /// A procedural sky: a zenith-to-horizon gradient, a dim ground and a small bright sun disc
    /// towards `sun` (map frame). For tests and demos, so no image files need shipping.
    pub fn procedural_sky(width: u32, height: u32, sun: [f32; 3]) -> Result<Self> {
        let s = glam::Vec3::from(sun).normalize_or(glam::Vec3::Y);
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                let d = texel_direction(x, y, width, height);
                let up = d.y;
                let c = if up >= 0.0 {
                    // Horizon white-blue to zenith deep blue.
                    let t = up.sqrt();
                    [0.9 - 0.6 * t, 1.0 - 0.5 * t, 1.1 - 0.1 * t]
                } else {
                    [0.25, 0.2, 0.15]
                };
                // Sun: about 2.5° in radius, 200× the sky.
                let sun = if d.dot(s) > 0.999 { 200.0 } else { 0.0 };
                texels.push([c[0] + sun, c[1] + sun * 0.95, c[2] + sun * 0.85]);
            }
        }
        Self::new(width, height, texels, "procedural sky")
    }

    /// Writes the map as Radiance `.hdr` or OpenEXR, by extension.
    pub fn save(&self, path: &Path) -> Result<()> {
        let flat: Vec<f32> = self.texels.iter().flatten().copied().collect();
        let img = image::Rgb32FImage::from_raw(self.width, self.height, flat)
            .ok_or_else(|| Error::Input(format!("{}: texel count does not match its size", self.source)))?;
        image::DynamicImage::ImageRgb32F(img)
            .save(path)
            .map_err(|e| Error::Input(format!("{}: cannot write environment map: {e}", path.display())))
    }

    /// Radiance of the texel direction `d` (map frame, unit length) falls in: the same
    /// nearest-texel lookup the shader does.
    pub fn lookup(&self, d: glam::Vec3) -> [f32; 3] {
        let (x, y) = self.texel_of(d);
        self.texels[(y * self.width + x) as usize]
    }

    /// Texel (column, row) containing direction `d` (map frame).
    pub fn texel_of(&self, d: glam::Vec3) -> (u32, u32) {
        let (u, v) = direction_to_uv(d);
        let x = ((u * self.width as f32) as u32).min(self.width - 1);
        let y = ((v * self.height as f32) as u32).min(self.height - 1);
        (x, y)
    }
}

/// Direction (map frame) of texel centre (x, y).
pub fn texel_direction(x: u32, y: u32, width: u32, height: u32) -> glam::Vec3 {
    uv_to_direction((x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32)
}

/// `(u, v) ∈ [0,1]²` → unit direction: `φ = 2πu`, `θ = πv`, zenith +Y.
pub fn uv_to_direction(u: f32, v: f32) -> glam::Vec3 {
    let (st, ct) = (PI * v).sin_cos();
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    glam::Vec3::new(st * cp, ct, st * sp)
}

/// Unit direction → `(u, v) ∈ [0,1]²`, inverse of [`uv_to_direction`].
pub fn direction_to_uv(d: glam::Vec3) -> (f32, f32) {
    let theta = d.y.clamp(-1.0, 1.0).acos();
    let mut phi = d.z.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    ((phi / (2.0 * PI)).min(1.0), theta / PI)
}

/// Piecewise-constant 2D distribution over the map's texels, proportional to luminance × sin θ
/// (θ at the texel's centre row), so directions are drawn in proportion to the radiance they carry
/// per unit solid angle. Sampling picks a row from the marginal CDF and a column from that row's
/// conditional CDF, each inverted linearly within its texel.
#[derive(Clone, Debug)]
pub struct EnvDistribution {
    width: u32,
    height: u32,
    /// Marginal CDF over rows, `height + 1` entries from 0 to 1.
    pub marginal: Vec<f32>,
    /// Per row, its conditional CDF over columns (`width + 1` entries from 0 to 1), row-major.
    pub conditional: Vec<f32>,
    /// Density of each texel in (u, v) space: `f_ij / mean(f)` (0 for black texels).
    pub uv_pdf: Vec<f32>,
    /// Σ f over texels; 0 means the map is black and cannot be sampled.
    pub total: f64,
}

impl EnvDistribution {
    /// Builds the tables from `map`.
    pub fn new(map: &EnvMap) -> Self {
        let (w, h) = (map.width as usize, map.height as usize);
        let mut f = vec![0.0f64; w * h];
        for y in 0..h {
            let sin_t = (PI * (y as f32 + 0.5) / h as f32).sin() as f64;
            for x in 0..w {
                f[y * w + x] = luminance(map.texels[y * w + x]) as f64 * sin_t;
            }
        }
        let total: f64 = f.iter().sum();
        let mut conditional = Vec::with_capacity(h * (w + 1));
        let mut row_sums = Vec::with_capacity(h);
        for y in 0..h {
            let row = &f[y * w..(y + 1) * w];
            let s: f64 = row.iter().sum();
            row_sums.push(s);
            conditional.extend(cdf(row, s));
        }
        let marginal = cdf(&row_sums, total);
        let mean = total / (w * h) as f64;
        let uv_pdf = f.iter().map(|&v| if mean > 0.0 { (v / mean) as f32 } else { 0.0 }).collect();
        Self { width: map.width, height: map.height, marginal, conditional, uv_pdf, total }
    }

    /// True if the map carries any light (otherwise nothing can be sampled).
    pub fn is_sampleable(&self) -> bool {
        self.total > 0.0
    }

    /// Solid-angle pdf of sampling direction `d` (map frame): `p(u,v) / (2π² sin θ)`.
    pub fn pdf(&self, d: glam::Vec3) -> f32 {
        let (u, v) = direction_to_uv(d);
        // sin θ from the direction itself: acos near the poles would lose digits.
        let sin_t = (d.x * d.x + d.z * d.z).sqrt();
        if sin_t <= 0.0 {
            return 0.0;
        }
        let x = ((u * self.width as f32) as usize).min(self.width as usize - 1);
        let y = ((v * self.height as f32) as usize).min(self.height as usize - 1);
        self.uv_pdf[y * self.width as usize + x] / (2.0 * PI * PI * sin_t)
    }

    /// Draws a direction from uniforms `xi ∈ (0,1)²`; returns it (map frame) and its solid-angle
    /// pdf (0 if the map is black or the sample landed on a pole).
    pub fn sample(&self, xi: [f32; 2]) -> (glam::Vec3, f32) {
        let (w, h) = (self.width as usize, self.height as usize);
        let (y, fy) = invert(&self.marginal, xi[0]);
        let row = &self.conditional[y * (w + 1)..(y + 1) * (w + 1)];
        let (x, fx) = invert(row, xi[1]);
        let (u, v) = ((x as f32 + fx) / w as f32, (y as f32 + fy) / h as f32);
        let d = uv_to_direction(u, v);
        let sin_t = (PI * v).sin();
        let pdf = if sin_t > 0.0 { self.uv_pdf[y * w + x] / (2.0 * PI * PI * sin_t) } else { 0.0 };
        (d, pdf)
    }
}

/// CDF of `f` normalized by `sum` (`f.len() + 1` entries); a zero row gets a uniform CDF so
/// inversion stays well defined (its texels still have pdf 0 and are never chosen by the marginal).
fn cdf(f: &[f64], sum: f64) -> Vec<f32> {
    let n = f.len();
    let mut out = Vec::with_capacity(n + 1);
    out.push(0.0);
    let mut acc = 0.0f64;
    for (i, &v) in f.iter().enumerate() {
        acc += v;
        out.push(if sum > 0.0 { (acc / sum) as f32 } else { (i + 1) as f32 / n as f32 });
    }
    // Exactly 1 at the end: rounding must not leave ξ near 1 outside every interval.
    out[n] = 1.0;
    out
}

/// Interval `i` with `cdf[i] <= xi < cdf[i+1]` (skipping empty intervals) and the fraction of
/// the way through it. Mirrors the shader's binary search.
fn invert(cdf: &[f32], xi: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    // Largest i in [0, n-1] with cdf[i] <= xi.
    let (mut lo, mut hi) = (0usize, n - 1);
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if cdf[mid] <= xi {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    let width = cdf[lo + 1] - cdf[lo];
    let frac = if width > 0.0 { ((xi - cdf[lo]) / width).clamp(0.0, 1.0 - f32::EPSILON) } else { 0.5 };
    (lo, frac)
}

/// An environment map on the GPU: RGBA32F texture (rgb radiance, a = the texel's (u,v) pdf) and
/// one storage buffer with the marginal CDF followed by the per-row conditional CDFs (the MC
/// pass's `ENV_MAP` variants bind them as bindings 8 and 9).
pub struct EnvLight {
    /// Radiance + pdf texture.
    pub texture: crate::vk::Image,
    /// Marginal then conditional CDFs (f32).
    pub cdf: crate::vk::Buffer,
    /// False for an all-black map: nothing to sample, NEE is skipped.
    pub sampleable: bool,
    /// Size in texels.
    pub size: [u32; 2],
}

impl EnvLight {
    /// Uploads `map` and its distribution.
    pub fn new(ctx: &crate::vk::Context, map: &EnvMap) -> Result<Self> {
        use crate::vk::{vk, Buffer, Image, ImageInfo};
        let max2d = ctx.info.limits.max_image_dimension2_d;
        if map.width > max2d || map.height > max2d {
            return Err(Error::Input(format!(
                "{}: {}x{} environment map exceeds this device's 2D texture limit {max2d}",
                map.source, map.width, map.height
            )));
        }
        let dist = EnvDistribution::new(map);
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let texture = Image::new(
            ctx,
            "environment map",
            ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, map.width, map.height, usage),
        )?;
        let bytes: Vec<u8> = map
            .texels
            .iter()
            .zip(&dist.uv_pdf)
            .flat_map(|(c, &p)| [c[0], c[1], c[2], p])
            .flat_map(f32::to_le_bytes)
            .collect();
        ctx.upload_image(
            &texture,
            &bytes,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_SAMPLED_READ,
        )?;
        let cdf_bytes: Vec<u8> = dist.marginal.iter().chain(&dist.conditional).flat_map(|f| f.to_le_bytes()).collect();
        let cdf = Buffer::with_data(ctx, "environment cdf", &cdf_bytes, vk::BufferUsageFlags::STORAGE_BUFFER)?;
        Ok(Self { texture, cdf, sampleable: dist.is_sampleable(), size: [map.width, map.height] })
    }
}
