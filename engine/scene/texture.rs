//! RGBA8 textures: decoding with fallbacks, box-filtered mip chains, and bump-to-normal conversion.

use std::collections::HashMap;
use std::path::Path;

use super::warn;

/// An RGBA8 texture with its full mip chain.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Source path or name (for messages and debugging).
    pub name: String,
    /// Width of mip 0 in texels.
    pub width: u32,
    /// Height of mip 0 in texels.
    pub height: u32,
    /// Whether the RGB channels are sRGB-encoded (colour data) rather than linear.
    pub srgb: bool,
    /// RGBA8 levels from full size down to 1×1, each `max(1, w >> i) × max(1, h >> i) × 4` bytes.
    pub mips: Vec<Vec<u8>>,
}

/// What a texture is used for, which decides its colour space and its fallback.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TextureKind {
    /// sRGB colour (base colour, specular colour); falls back to white.
    Color,
    /// Tangent-space normal map; falls back to flat (128, 128, 255).
    Normal,
    /// OBJ bump map with its `-bm` scale: a greyscale image is a height map and is converted to a normal
    /// map (see [`height_to_normal`]); a coloured one is used as a normal map. Falls back to flat.
    Bump(f32),
    /// Linear data (metallic-roughness); falls back to white.
    Linear,
}

impl TextureKind {
    fn srgb(self) -> bool {
        matches!(self, TextureKind::Color)
    }

    fn fallback_texel(self) -> [u8; 4] {
        match self {
            TextureKind::Color | TextureKind::Linear => [255; 4],
            TextureKind::Normal | TextureKind::Bump(_) => [128, 128, 255, 255],
        }
    }
}

impl Texture {
    /// A texture from RGBA8 pixels (`width × height × 4` bytes), building its mip chain.
    pub fn from_rgba8(name: impl Into<String>, width: u32, height: u32, srgb: bool, pixels: Vec<u8>) -> Texture {
        let mips = build_mips(width, height, srgb, pixels);
        Texture { name: name.into(), width, height, srgb, mips }
    }

    /// A 1×1 texture of one texel.
    pub fn solid(name: impl Into<String>, rgba: [u8; 4], srgb: bool) -> Texture {
        Texture::from_rgba8(name, 1, 1, srgb, rgba.to_vec())
    }
}

fn srgb_to_linear_lut() -> [f32; 256] {
    std::array::from_fn(|i| {
        let c = i as f32 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    })
}

/// The mip chain of an RGBA8 image: each level box-averages the texels of the level above that fall
/// in its footprint (odd sizes give uneven footprints rather than dropping a row). sRGB colour channels
/// are averaged in linear light so mips don't darken; alpha is always linear.
pub fn build_mips(width: u32, height: u32, srgb: bool, level0: Vec<u8>) -> Vec<Vec<u8>> {
    let lut = srgb_to_linear_lut();
    let encode = |v: f32| -> u8 {
        // Nearest code: the first whose decoded value passes the midpoint to the next.
        let i = lut.partition_point(|&l| l < v);
        match i {
            0 => 0,
            256 => 255,
            i if (v - lut[i - 1]) < (lut[i] - v) => (i - 1) as u8,
            i => i as u8,
        }
    };
    let mut mips = vec![level0];
    let (mut w, mut h) = (width.max(1) as usize, height.max(1) as usize);
    while w > 1 || h > 1 {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let src = &mips[mips.len() - 1];
        let mut dst = vec![0u8; nw * nh * 4];
        for y in 0..nh {
            let (y0, y1) = (y * h / nh, (y + 1) * h / nh);
            for x in 0..nw {
                let (x0, x1) = (x * w / nw, (x + 1) * w / nw);
                let mut sum = [0f32; 4];
                for sy in y0..y1 {
                    for sx in x0..x1 {
                        let p = &src[(sy * w + sx) * 4..][..4];
                        for c in 0..4 {
                            sum[c] += if srgb && c < 3 { lut[p[c] as usize] } else { p[c] as f32 };
                        }
                    }
                }
                let count = ((y1 - y0) * (x1 - x0)) as f32;
                let o = &mut dst[(y * nw + x) * 4..][..4];
                for c in 0..4 {
                    let avg = sum[c] / count;
                    o[c] = if srgb && c < 3 { encode(avg) } else { (avg + 0.5) as u8 };
                }
            }
        }
        mips.push(dst);
        (w, h) = (nw, nh);
    }
    mips
}

/// Whether every texel has R = G = B (within 2 codes), i.e. the image is a greyscale height map.
pub fn is_greyscale(rgba: &[u8]) -> bool {
    rgba.chunks_exact(4).all(|p| p[0].abs_diff(p[1]) <= 2 && p[1].abs_diff(p[2]) <= 2)
}

/// Converts a greyscale height map (red channel, 0 = low) into a tangent-space normal map with a 3×3
/// Sobel gradient, wrapping at the edges because such maps tile. `scale` is the OBJ `-bm` multiplier:
/// with heights in [0, 1], the normal is `normalize(−scale·∂h/∂x, −scale·∂h/∂y, 1)` where the Sobel
/// derivative of a one-texel black-to-white step is 4, i.e. a ~76° tilt at scale 1. `+y` in texture
/// space points down the image (towards increasing `v`).
pub fn height_to_normal(width: u32, height: u32, rgba: &[u8], scale: f32) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let at = |x: isize, y: isize| {
        let xx = x.rem_euclid(w as isize) as usize;
        let yy = y.rem_euclid(h as isize) as usize;
        rgba[(yy * w + xx) * 4] as f32 / 255.0
    };
    let mut out = vec![0u8; w * h * 4];
    for y in 0..h as isize {
        for x in 0..w as isize {
            let gx = (at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x - 1, y) + at(x - 1, y + 1));
            let gy = (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x, y - 1) + at(x + 1, y - 1));
            let n = glam::Vec3::new(-scale * gx, -scale * gy, 1.0).normalize();
            let o = &mut out[(y as usize * w + x as usize) * 4..][..4];
            let enc = |v: f32| ((v * 0.5 + 0.5) * 255.0 + 0.5).clamp(0.0, 255.0) as u8;
            o.copy_from_slice(&[enc(n.x), enc(n.y), enc(n.z), 255]);
        }
    }
    out
}

/// Decodes an image file to RGBA8, guessing the format from its content and then its extension.
pub fn decode_file(path: &Path) -> Result<(u32, u32, Vec<u8>), String> {
    let reader = image::ImageReader::open(path).map_err(|e| e.to_string())?;
    let img = reader.with_guessed_format().map_err(|e| e.to_string())?.decode().map_err(|e| e.to_string())?;
    let rgba = img.to_rgba8();
    Ok((rgba.width(), rgba.height(), rgba.into_raw()))
}

/// Decodes an in-memory image (PNG, JPEG, ...) to RGBA8.
pub fn decode_bytes(bytes: &[u8]) -> Result<(u32, u32, Vec<u8>), String> {
    let img = image::load_from_memory(bytes).map_err(|e| e.to_string())?;
    let rgba = img.to_rgba8();
    Ok((rgba.width(), rgba.height(), rgba.into_raw()))
}

/// Collects textures for one scene, decoding each (source, use) once and substituting 1×1 fallbacks
/// (with a warning naming the file) for anything missing or undecodable.
#[derive(Default)]
pub(crate) struct TextureCache {
    textures: Vec<Texture>,
    index: HashMap<String, usize>,
}

impl TextureCache {
    /// Index of the texture at `path` decoded for `kind`; `context` (the referring file) prefixes warnings.
    pub fn file(&mut self, context: &str, path: &Path, kind: TextureKind, warnings: &mut Vec<String>) -> usize {
        let name = path.display().to_string();
        self.get(&name.clone(), kind, warnings, context, || decode_file(path))
    }

    /// Index of a texture decoded from `decoded` (cached under `key`, e.g. a glTF image index).
    pub fn get(
        &mut self,
        key: &str,
        kind: TextureKind,
        warnings: &mut Vec<String>,
        context: &str,
        decoded: impl FnOnce() -> Result<(u32, u32, Vec<u8>), String>,
    ) -> usize {
        let cache_key = format!("{kind:?}|{key}");
        if let Some(&i) = self.index.get(&cache_key) {
            return i;
        }
        let tex = match decoded() {
            Ok((w, h, px)) if w > 0 && h > 0 => {
                let px = match kind {
                    TextureKind::Bump(scale) if is_greyscale(&px) => height_to_normal(w, h, &px, scale),
                    _ => px,
                };
                Texture::from_rgba8(key, w, h, kind.srgb(), px)
            }
            Ok(_) => self.fallback(context, key, kind, "image is empty", warnings),
            Err(e) => self.fallback(context, key, kind, &e, warnings),
        };
        self.push(cache_key, tex)
    }

    /// A base-colour texture whose alpha is replaced by an alpha-mask image (OBJ `map_d`), resampled to
    /// the colour image's size. Returns `None` (with a warning) when the mask cannot be read.
    pub fn color_with_mask(
        &mut self,
        context: &str,
        color: Option<&Path>,
        mask: &Path,
        warnings: &mut Vec<String>,
    ) -> Option<usize> {
        let cache_key =
            format!("mask|{}|{}", color.map(|p| p.display().to_string()).unwrap_or_default(), mask.display());
        if let Some(&i) = self.index.get(&cache_key) {
            return Some(i);
        }
        let (mw, mh, mpx) = match decode_file(mask) {
            Ok(m) if m.0 > 0 && m.1 > 0 => m,
            Ok(_) | Err(_) => {
                let msg =
                    format!("{context}: alpha mask {} is missing or unreadable; material is opaque", mask.display());
                warn(warnings, msg);
                return None;
            }
        };
        let (w, h, mut px) = match color.map(decode_file) {
            Some(Ok(c)) if c.0 > 0 && c.1 > 0 => c,
            Some(_) => {
                let name = color.map(|p| p.display().to_string()).unwrap_or_default();
                warn(warnings, format!("{context}: texture {name} is missing or unreadable; using white"));
                (mw, mh, vec![255; (mw * mh * 4) as usize])
            }
            None => (mw, mh, vec![255; (mw * mh * 4) as usize]),
        };
        // Masks are usually greyscale without alpha; one that has real alpha carries the mask there.
        let use_alpha = mpx.chunks_exact(4).any(|p| p[3] != 255);
        for y in 0..h as usize {
            for x in 0..w as usize {
                let (sx, sy) = (x * mw as usize / w as usize, y * mh as usize / h as usize);
                let m = &mpx[(sy * mw as usize + sx) * 4..][..4];
                px[(y * w as usize + x) * 4 + 3] = if use_alpha { m[3] } else { m[0] };
            }
        }
        let tex = Texture::from_rgba8(
            format!("{} + mask {}", color.map(|p| p.display().to_string()).unwrap_or_default(), mask.display()),
            w,
            h,
            true,
            px,
        );
        Some(self.push(cache_key, tex))
    }

    fn fallback(&self, context: &str, key: &str, kind: TextureKind, why: &str, warnings: &mut Vec<String>) -> Texture {
        let texel = kind.fallback_texel();
        warn(warnings, format!("{context}: texture {key} could not be loaded ({why}); using a 1×1 {texel:?} fallback"));
        Texture::solid(format!("fallback for {key}"), texel, kind.srgb())
    }

    fn push(&mut self, cache_key: String, tex: Texture) -> usize {
        self.textures.push(tex);
        let i = self.textures.len() - 1;
        self.index.insert(cache_key, i);
        i
    }

    /// The collected textures, in index order.
    pub fn into_textures(self) -> Vec<Texture> {
        self.textures
    }
}
