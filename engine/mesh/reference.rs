//! An independent CPU reference for diffuse lighting of mesh scenes: direct light (sun and spot
//! lights with ray-traced shadows) and one-bounce diffuse indirect light, by Monte Carlo ray tracing.
//!
//! It follows the GPU renderer's conventions (`shaders_glsl/mesh/lighting.comp`) so its images can be
//! compared pixel for pixel: the same camera rays, double-sided surfaces lit on the side the viewer
//! sees, the first directional light as the sun, at most [`MAX_SPOTS`] spot lights, spot `range`
//! ignored (the GPU does not attenuate by it), point lights ignored, no ambient term. It is
//! diffuse-only (f = ρ/π); emission, specular, alpha masks and normal maps are not modelled.

use std::f32::consts::PI;

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::camera::View;
use super::frame::MAX_SPOTS;
use crate::lpv::bvh::Bvh;
use crate::scene::{Light, Scene};
use crate::{Error, Result};

/// Largest image [`Tracer::render`] accepts (8192², a guard against sizes that cannot be allocated).
pub const MAX_PIXELS: u64 = 1 << 26;

/// How to render the reference.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceSettings {
    /// Cosine-weighted hemisphere samples per pixel for the indirect term (0: direct light only).
    pub samples: u32,
    /// Random seed; images depend only on it, never on `threads`.
    pub seed: u64,
    /// Worker threads (0: one per available core).
    pub threads: usize,
    /// Radiance of a sky over the upper hemisphere (y > 0), seen by the indirect samples that
    /// escape the scene (the LPV sky light's reference; zero: no sky).
    pub sky: [f32; 3],
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self {
            samples: 64,
            seed: 0,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            sky: [0.0; 3],
        }
    }
}

/// The reference's images: row-major, row 0 at the top, linear HDR radiance with alpha 1.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceImages {
    /// Width and height in pixels.
    pub size: [u32; 2],
    /// Direct diffuse radiance from the sun and spot lights at each pixel's first hit.
    pub direct: Vec<[f32; 4]>,
    /// One-bounce diffuse indirect radiance at each pixel's first hit.
    pub indirect: Vec<[f32; 4]>,
    /// Radiance at each pixel's first hit from the sky (`ReferenceSettings::sky`) through the
    /// scene's openings: no bounce, occlusion by ray casting.
    pub sky: Vec<[f32; 4]>,
    /// Whether the pixel's camera ray hit a surface (both terms are 0 where it did not).
    pub hit: Vec<bool>,
}

/// Per-triangle data for shading a hit.
#[derive(Clone, Copy, Debug)]
struct TriData {
    positions: [Vec3; 3],
    /// Vertex normals, when the mesh has usable ones.
    normals: Option<[Vec3; 3]>,
    uvs: [Vec2; 3],
    /// Unit geometric normal (counter-clockwise front face).
    ng: Vec3,
    material: u32,
    /// Ray-origin offset along the normal that clears this triangle's own surface.
    eps: f32,
}

#[derive(Clone, Debug)]
struct Surface {
    color: Vec3,
    /// Index into `Tracer::textures`.
    texture: Option<usize>,
}

/// A base-colour texture's mip 0, kept as RGBA8 (decoding on lookup keeps memory at the scene's size).
#[derive(Clone, Debug)]
struct ColorTexture {
    width: usize,
    height: usize,
    srgb: bool,
    texels: Vec<u8>,
}

#[derive(Clone, Copy, Debug)]
struct Sun {
    to_sun: Vec3,
    irradiance: Vec3,
}

#[derive(Clone, Copy, Debug)]
struct Spot {
    position: Vec3,
    direction: Vec3,
    intensity: Vec3,
    cos_outer: f32,
    cos_inner: f32,
}

/// A shading point: position, normals oriented towards the side being lit or viewed, albedo.
#[derive(Clone, Copy, Debug)]
struct SurfacePoint {
    p: Vec3,
    n: Vec3,
    ng: Vec3,
    albedo: Vec3,
    eps: f32,
}

/// A scene prepared for ray tracing: its BVH, shading data and lights, built once and reusable
/// across renders.
#[derive(Clone, Debug)]
pub struct Tracer {
    bvh: Bvh,
    tris: Vec<TriData>,
    materials: Vec<Surface>,
    textures: Vec<Option<ColorTexture>>,
    sun: Option<Sun>,
    spots: Vec<Spot>,
    /// Smallest ray offset: scene extent × 1e-7, for triangles tiny compared with the scene.
    min_eps: f32,
}

impl Tracer {
    /// Builds the BVH and shading data. Errors (`Error::Input`): no triangles, an index or material
    /// out of range, a non-finite position or light, a malformed base-colour texture.
    pub fn new(scene: &Scene) -> Result<Tracer> {
        let mut corners = Vec::with_capacity(scene.triangle_count());
        let mut tris = Vec::with_capacity(scene.triangle_count());
        let mut extent = 0f32;
        for mesh in &scene.meshes {
            let bad = |what: String| Error::Input(format!("reference: mesh `{}`: {what}", mesh.name));
            if mesh.material >= scene.materials.len() {
                return Err(bad(format!("material {} of {}", mesh.material, scene.materials.len())));
            }
            if mesh.positions.iter().flatten().any(|c| !c.is_finite()) {
                return Err(bad("non-finite vertex position".into()));
            }
            let has_normals = mesh.normals.len() == mesh.positions.len();
            let has_uvs = mesh.uvs.len() == mesh.positions.len();
            for tri in mesh.indices.chunks_exact(3) {
                let idx = [tri[0], tri[1], tri[2]].map(|i| i as usize);
                if let Some(&i) = idx.iter().find(|&&i| i >= mesh.positions.len()) {
                    return Err(bad(format!("index {i} out of range ({} vertices)", mesh.positions.len())));
                }
                let positions = idx.map(|i| Vec3::from(mesh.positions[i]));
                let normals = has_normals
                    .then(|| idx.map(|i| Vec3::from(mesh.normals[i])))
                    .filter(|n| n.iter().all(|v| v.is_finite()));
                let uvs = if has_uvs { idx.map(|i| Vec2::from(mesh.uvs[i])) } else { [Vec2::ZERO; 3] };
                let ng = (positions[1] - positions[0]).cross(positions[2] - positions[0]).normalize_or_zero();
                let scale = positions.iter().map(|p| p.abs().max_element()).fold(0.0, f32::max);
                extent = extent.max(scale);
                // The hit point is rebuilt from the vertices to within a few ulps of their
                // coordinates; 1e-5 relative is ~100 ulps of margin without visible light leaks.
                let eps = 1e-5 * scale;
                corners.push(positions);
                tris.push(TriData { positions, normals, uvs, ng, material: mesh.material as u32, eps });
            }
        }
        if tris.is_empty() {
            return Err(Error::Input("reference: the scene has no triangles".into()));
        }
        let mut textures: Vec<Option<ColorTexture>> = vec![None; scene.textures.len()];
        let materials = scene
            .materials
            .iter()
            .map(|m| {
                // An out-of-range texture index samples white, as on the GPU.
                let texture = m.base_color_tex.filter(|&i| i < scene.textures.len());
                if let Some(i) = texture {
                    if textures[i].is_none() {
                        textures[i] = Some(color_texture(&scene.textures[i])?);
                    }
                }
                let c = m.base_color;
                if c.iter().any(|v| !v.is_finite()) {
                    return Err(Error::Input(format!("reference: material `{}` has a non-finite colour", m.name)));
                }
                Ok(Surface { color: Vec3::new(c[0], c[1], c[2]), texture })
            })
            .collect::<Result<Vec<_>>>()?;
        let (sun, spots) = lights(&scene.lights)?;
        Ok(Tracer { bvh: Bvh::new(&corners), tris, materials, textures, sun, spots, min_eps: 1e-7 * extent })
    }

    /// The hierarchy over the scene's triangles (indexed in mesh order, then index-buffer order).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Irradiance (W/m², RGB) from the sun and spot lights at `point` on a surface with unit `normal`,
    /// with shadow rays (offset from `point` along `normal`).
    pub fn irradiance(&self, point: [f32; 3], normal: [f32; 3]) -> [f32; 3] {
        let p = Vec3::from(point);
        let n = Vec3::from(normal).normalize_or_zero();
        let eps = (1e-5 * p.abs().max_element()).max(self.min_eps);
        self.irradiance_at(&SurfacePoint { p, n, ng: n, albedo: Vec3::ONE, eps }).into()
    }

    /// Renders the direct and one-bounce indirect images seen by `view` at `size` (width, height).
    ///
    /// Errors (`Error::Input`): a zero or oversized `size`, a non-finite or degenerate view.
    pub fn render(&self, view: &View, size: [u32; 2], settings: &ReferenceSettings) -> Result<ReferenceImages> {
        let [w, h] = size;
        if w == 0 || h == 0 || w as u64 * h as u64 > MAX_PIXELS {
            return Err(Error::Input(format!("reference: image size {w}×{h} must be 1..={MAX_PIXELS} pixels")));
        }
        let camera = CameraRays::new(view, size)?;
        let threads = match settings.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        }
        .clamp(1, h as usize);
        let mut pixels = vec![Pixel::default(); w as usize * h as usize];
        // Rows dealt round-robin: neighbouring rows cost about the same, so this balances well, and
        // each pixel's value depends only on its own coordinates and the seed.
        let mut buckets: Vec<Vec<(usize, &mut [Pixel])>> = (0..threads).map(|_| Vec::new()).collect();
        for (y, row) in pixels.chunks_mut(w as usize).enumerate() {
            buckets[y % threads].push((y, row));
        }
        std::thread::scope(|s| {
            for bucket in buckets {
                let camera = &camera;
                s.spawn(move || {
                    for (y, row) in bucket {
                        for (x, px) in row.iter_mut().enumerate() {
                            *px = self.pixel(camera, x as u32, y as u32, settings);
                        }
                    }
                });
            }
        });
        let rgba = |c: Vec3| [c.x, c.y, c.z, 1.0];
        Ok(ReferenceImages {
            size,
            direct: pixels.iter().map(|p| rgba(p.direct)).collect(),
            indirect: pixels.iter().map(|p| rgba(p.indirect)).collect(),
            sky: pixels.iter().map(|p| rgba(p.sky)).collect(),
            hit: pixels.iter().map(|p| p.hit).collect(),
        })
    }

    fn pixel(&self, camera: &CameraRays, x: u32, y: u32, settings: &ReferenceSettings) -> Pixel {
        let (dir, t_min, t_max) = camera.ray(x, y);
        let Some(hit) = self.bvh.closest_hit(camera.origin, dir, t_min, t_max) else {
            return Pixel::default();
        };
        let sp = self.surface(&hit, dir);
        let direct = sp.albedo / PI * self.irradiance_at(&sp);
        let (mut indirect, mut sky) = (Vec3::ZERO, Vec3::ZERO);
        if settings.samples > 0 && sp.albedo != Vec3::ZERO {
            let pixel = y as u64 * camera.width as u64 + x as u64;
            let (t, b) = orthonormal_basis(sp.n);
            let origin = sp.p + sp.ng * sp.eps;
            // f64 sums: with thousands of near-identical samples an f32 sum drifts by more than the
            // Monte Carlo error the tests resolve.
            let mut sum = [0f64; 3];
            let mut sky_sum = 0f64;
            for s in 0..settings.samples {
                let (u1, u2) = sample_2d(settings.seed, pixel, s);
                let r = u1.sqrt();
                let (sin, cos) = (2.0 * PI * u2).sin_cos();
                let w = t * (r * cos) + b * (r * sin) + sp.n * (1.0 - u1).max(0.0).sqrt();
                // Below the geometric surface (possible with interpolated normals) the ray would hit
                // the surface itself: no light arrives from there.
                if w.dot(sp.ng) <= 0.0 {
                    continue;
                }
                let Some(h) = self.bvh.closest_hit(origin, w, 0.0, f32::INFINITY) else {
                    // Escaped: the sky, if it is above the horizon (the same estimator as below).
                    if w.y > 0.0 {
                        sky_sum += 1.0;
                    }
                    continue;
                };
                let y = self.surface(&h, w);
                // Cosine-weighted pdf cosθ/π cancels the BRDF's 1/π and the cosine: each sample is
                // ρ_x · L(y), with L(y) = ρ_y/π · E(y); ρ_x is applied once below.
                let l = y.albedo / PI * self.irradiance_at(&y);
                for k in 0..3 {
                    sum[k] += l[k] as f64;
                }
            }
            let mean = Vec3::from(sum.map(|v| (v / settings.samples as f64) as f32));
            indirect = sp.albedo * mean;
            sky = sp.albedo * Vec3::from(settings.sky) * (sky_sum / settings.samples as f64) as f32;
        }
        Pixel { direct, indirect, sky, hit: true }
    }

    /// The shading point of `hit` for a ray travelling along `dir`, its normals flipped to face the ray.
    fn surface(&self, hit: &crate::lpv::bvh::Hit, dir: Vec3) -> SurfacePoint {
        let tri = &self.tris[hit.triangle as usize];
        let (u, v) = (hit.u, hit.v);
        let w0 = 1.0 - u - v;
        let [a, b, c] = tri.positions;
        // From the vertices rather than origin + t·dir: accurate to the vertices' precision however
        // far the ray travelled.
        let p = a + u * (b - a) + v * (c - a);
        let interpolated = tri.normals.map(|[na, nb, nc]| (w0 * na + u * nb + v * nc).normalize_or_zero());
        let mut n = interpolated.filter(|n| *n != Vec3::ZERO).unwrap_or(tri.ng);
        let mut ng = tri.ng;
        // Double-sided, like the GPU's gl_FrontFacing test: the winding decides the side, and the
        // shading normal follows the geometric one.
        if ng.dot(dir) > 0.0 {
            ng = -ng;
            n = -n;
        }
        let [ta, tb, tc] = tri.uvs;
        let uv = w0 * ta + u * tb + v * tc;
        let m = &self.materials[tri.material as usize];
        let tex = m.texture.and_then(|i| self.textures[i].as_ref()).map_or(Vec3::ONE, |t| t.bilinear(uv));
        SurfacePoint { p, n, ng, albedo: m.color * tex, eps: tri.eps.max(self.min_eps) }
    }

    /// Sun and spot irradiance at a shading point, each light's visibility by a shadow ray.
    fn irradiance_at(&self, sp: &SurfacePoint) -> Vec3 {
        let origin = sp.p + sp.ng * sp.eps;
        let mut e = Vec3::ZERO;
        if let Some(sun) = &self.sun {
            let cos = sp.n.dot(sun.to_sun);
            if cos > 0.0 && !self.bvh.any_hit(origin, sun.to_sun, 0.0, f32::INFINITY) {
                e += sun.irradiance * cos;
            }
        }
        for spot in &self.spots {
            let d = spot.position - sp.p;
            let dist2 = d.length_squared().max(1e-8);
            let l = d / dist2.sqrt();
            let cos = sp.n.dot(l);
            let cone = cone_falloff((-l).dot(spot.direction), spot.cos_outer, spot.cos_inner);
            if cos <= 0.0 || cone <= 0.0 {
                continue;
            }
            let to_light = spot.position - origin;
            let len = to_light.length();
            if len > sp.eps && self.bvh.any_hit(origin, to_light / len, 0.0, len - sp.eps) {
                continue;
            }
            e += spot.intensity * (cone * cos / dist2);
        }
        e
    }
}

/// Renders `scene` from `view`: builds a [`Tracer`] and calls [`Tracer::render`].
pub fn render(scene: &Scene, view: &View, size: [u32; 2], settings: &ReferenceSettings) -> Result<ReferenceImages> {
    Tracer::new(scene)?.render(view, size, settings)
}

#[derive(Clone, Copy, Debug, Default)]
struct Pixel {
    direct: Vec3,
    indirect: Vec3,
    sky: Vec3,
    hit: bool,
}

/// The GPU's camera rays: through the pixel centre, clipped to the near and far planes.
struct CameraRays {
    origin: Vec3,
    inv_view_proj: Mat4,
    width: u32,
    height: u32,
}

impl CameraRays {
    fn new(view: &View, [width, height]: [u32; 2]) -> Result<CameraRays> {
        let finite = view.position.iter().chain(&view.forward).chain(&view.up).all(|v| v.is_finite())
            && [view.fov_y, view.near, view.far].iter().all(|v| v.is_finite());
        let sane = view.fov_y > 0.0 && view.fov_y < PI && view.near > 0.0 && view.far > view.near;
        let inv_view_proj = view.view_proj(width as f32 / height as f32).inverse();
        if !finite || !sane || !inv_view_proj.is_finite() {
            return Err(Error::Input(format!("reference: unusable camera {view:?}")));
        }
        Ok(CameraRays { origin: view.position.into(), inv_view_proj, width, height })
    }

    /// Unit direction and the `t` range between the near and far planes for pixel `(x, y)`.
    fn ray(&self, x: u32, y: u32) -> (Vec3, f32, f32) {
        let ndc = Vec2::new((x as f32 + 0.5) / self.width as f32, (y as f32 + 0.5) / self.height as f32) * 2.0 - 1.0;
        let unproject = |depth: f32| {
            let w = self.inv_view_proj * Vec4::new(ndc.x, ndc.y, depth, 1.0);
            w.truncate() / w.w
        };
        let (near, far) = (unproject(0.0) - self.origin, unproject(1.0) - self.origin);
        let dir = far.normalize_or_zero();
        (dir, near.length(), far.length())
    }
}

fn lights(lights: &[Light]) -> Result<(Option<Sun>, Vec<Spot>)> {
    let mut sun = None;
    let mut spots = Vec::new();
    let bad = |i: usize| Error::Input(format!("reference: light {i} has a non-finite parameter"));
    for (i, light) in lights.iter().enumerate() {
        match *light {
            Light::Directional { direction, color, intensity } if sun.is_none() => {
                if direction.iter().chain(&color).chain([&intensity]).any(|v| !v.is_finite()) {
                    return Err(bad(i));
                }
                let to_sun = (-Vec3::from(direction)).normalize_or(Vec3::Y);
                sun = Some(Sun { to_sun, irradiance: Vec3::from(color) * intensity });
            }
            Light::Spot { position, direction, color, intensity, inner_angle, outer_angle, .. }
                if spots.len() < MAX_SPOTS =>
            {
                let values = position.iter().chain(&direction).chain(&color);
                if values.chain([&intensity, &inner_angle, &outer_angle]).any(|v| !v.is_finite()) {
                    return Err(bad(i));
                }
                spots.push(Spot {
                    position: position.into(),
                    direction: Vec3::from(direction).normalize_or(Vec3::NEG_Y),
                    intensity: Vec3::from(color) * intensity,
                    cos_outer: outer_angle.cos(),
                    cos_inner: inner_angle.min(outer_angle).cos(),
                });
            }
            _ => {}
        }
    }
    Ok((sun, spots))
}

/// `frame.glsl`'s `cone_falloff`: smoothstep between the cone cosines, a hard edge when they coincide.
fn cone_falloff(cos_axis: f32, cos_outer: f32, cos_inner: f32) -> f32 {
    if cos_inner > cos_outer {
        let t = ((cos_axis - cos_outer) / (cos_inner - cos_outer)).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    } else if cos_axis >= cos_outer {
        1.0
    } else {
        0.0
    }
}

fn color_texture(t: &crate::scene::Texture) -> Result<ColorTexture> {
    let (width, height) = (t.width as usize, t.height as usize);
    let texels = t.mips.first().filter(|m| width > 0 && height > 0 && m.len() >= width * height * 4);
    let Some(texels) = texels else {
        return Err(Error::Input(format!("reference: texture `{}` has no valid {width}×{height} level", t.name)));
    };
    Ok(ColorTexture { width, height, srgb: t.srgb, texels: texels[..width * height * 4].to_vec() })
}

impl ColorTexture {
    /// Bilinear lookup on mip 0 with repeat wrapping, filtering decoded linear values (as the
    /// hardware does for sRGB formats).
    fn bilinear(&self, uv: Vec2) -> Vec3 {
        let st = uv * Vec2::new(self.width as f32, self.height as f32) - 0.5;
        let base = st.floor();
        let f = st - base;
        // `as` saturates (NaN → 0), and rem_euclid keeps every index in range.
        let (x0, y0) = (base.x as i64, base.y as i64);
        let texel = |x: i64, y: i64| {
            let (x, y) = (x.rem_euclid(self.width as i64) as usize, y.rem_euclid(self.height as i64) as usize);
            let p = &self.texels[(y * self.width + x) * 4..][..3];
            Vec3::new(self.decode(p[0]), self.decode(p[1]), self.decode(p[2]))
        };
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), f.x);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), f.x);
        top.lerp(bottom, f.y)
    }

    fn decode(&self, v: u8) -> f32 {
        let c = v as f32 / 255.0;
        match (self.srgb, c <= 0.04045) {
            (false, _) => c,
            (true, true) => c / 12.92,
            (true, false) => ((c + 0.055) / 1.055).powf(2.4),
        }
    }
}

/// Two unit vectors completing `n` to an orthonormal basis (Duff et al. 2017, branch-free).
fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// SplitMix64's output mix: a bijection that scrambles every input bit into every output bit.
fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Two uniform numbers in [0, 1) keyed by (seed, pixel, sample): counter-based, so results do not
/// depend on which thread renders what.
fn sample_2d(seed: u64, pixel: u64, sample: u32) -> (f32, f32) {
    let h = mix64(mix64(mix64(seed) ^ pixel) ^ sample as u64);
    let scale = 1.0 / (1u32 << 24) as f32;
    ((h >> 40) as f32 * scale, ((h >> 16) & 0xFF_FFFF) as f32 * scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal() {
        for n in [Vec3::X, Vec3::NEG_Z, Vec3::new(0.3, -0.5, 0.8).normalize(), Vec3::new(0.0, 0.0, -1.0)] {
            let (t, b) = orthonormal_basis(n);
            for (x, y) in [(t, b), (t, n), (b, n)] {
                assert!(x.dot(y).abs() < 1e-6);
            }
            for v in [t, b] {
                assert!((v.length() - 1.0).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn cone_falloff_matches_glsl() {
        let (co, ci) = (0.5f32, 0.9f32);
        assert_eq!(cone_falloff(0.4, co, ci), 0.0);
        assert_eq!(cone_falloff(0.95, co, ci), 1.0);
        // smoothstep at the midpoint is exactly 1/2.
        assert!((cone_falloff(0.7, co, ci) - 0.5).abs() < 1e-6);
        assert_eq!(cone_falloff(0.5, 0.5, 0.5), 1.0);
        assert_eq!(cone_falloff(0.49, 0.5, 0.5), 0.0);
    }

    #[test]
    fn samples_are_uniform_and_keyed() {
        let n = 20_000;
        let mean: f64 = (0..n).map(|s| sample_2d(7, 3, s).0 as f64).sum::<f64>() / n as f64;
        // Uniform mean 1/2, standard error 1/√(12n) ≈ 0.002: 4 standard errors.
        assert!((mean - 0.5).abs() < 0.008, "mean {mean}");
        assert_ne!(sample_2d(7, 3, 0), sample_2d(8, 3, 0));
        assert_ne!(sample_2d(7, 3, 0), sample_2d(7, 4, 0));
    }
}
