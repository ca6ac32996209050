//! CPU-side mesh scenes: an in-memory, GPU-agnostic model ready for upload, and loaders for glTF 2.0,
//! OBJ/MTL, TOML scene descriptions and built-in procedural scenes.
//! Loaders (`description`, `gltf_load`, `obj_load`, `procedural`) use the shared pieces
//! (`geometry`, `texture`, `camera`) and never each other, but for the TOML description, which
//! names a model file or a built-in scene. Uses `crate::error` and `crate::settings` (a scene
//! file's settings tables); used by
//! `crate::mesh`, the demos and the Python module.
//!
//! Conventions (shared by every loader and the procedural scenes):
//! - Right-handed, +Y up, metres (glTF's convention). Front faces wind counter-clockwise seen from the
//!   side their normal points to.
//! - Meshes are indexed triangle lists in world space: node hierarchies are flattened on load.
//! - Light directions are the direction the light *travels* (from the light into the scene).
//! - Texture coordinates have their origin at the top-left of the image (glTF/Vulkan); OBJ's
//!   bottom-left `v` is flipped on load.
//! - Recoverable problems (missing textures, generated normals, missing MTL) become warnings, logged and
//!   kept in [`Scene::warnings`]; malformed geometry is an [`Error::Input`](crate::Error::Input) naming the
//!   file and the problem.

mod camera;
pub mod description;
pub mod geometry;
pub mod gltf_load;
pub mod obj_load;
pub mod procedural;
pub mod texture;

use std::collections::BTreeMap;

pub use camera::{Camera, CameraKey, CameraPath};
pub use description::load_scene;
pub use texture::{Texture, TextureKind};

/// One drawable primitive: an indexed triangle list in world space.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Name from the source file (mesh/object name, with a primitive suffix when split).
    pub name: String,
    /// World-space vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// World-space unit normals, one per vertex.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates (origin top-left), one per vertex.
    pub uvs: Vec<[f32; 2]>,
    /// World-space tangents; `w` is the bitangent sign (`b = w · cross(n, t)`).
    pub tangents: Vec<[f32; 4]>,
    /// Triangle list, three indices per triangle, counter-clockwise front faces.
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// How a material's alpha is used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    Opaque,
    /// Alpha test: fragments with alpha below the cutoff are discarded.
    Mask(f32),
}

/// A surface description carrying both metallic-roughness and Blinn–Phong parameters, so either
/// shading model can be used whatever the source format.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name from the source file.
    pub name: String,
    /// Linear base colour (RGB) and alpha.
    pub base_color: [f32; 4],
    /// sRGB base colour texture (alpha in `a`), multiplied by `base_color`.
    pub base_color_tex: Option<usize>,
    /// Tangent-space normal map (linear; bump height maps are converted on load).
    pub normal_tex: Option<usize>,
    /// Blinn–Phong specular colour (linear).
    pub specular: [f32; 3],
    /// Blinn–Phong exponent in [1, 4096].
    pub shininess: f32,
    /// sRGB specular colour texture, multiplied by `specular`.
    pub specular_tex: Option<usize>,
    /// glTF metallic (B) / roughness (G) texture, linear.
    pub metallic_roughness_tex: Option<usize>,
    /// Metalness in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    /// Alpha handling.
    pub alpha_mode: AlphaMode,
    /// Linear emitted radiance.
    pub emissive: [f32; 3],
    /// Fraction of the light reaching the surface that enters it instead of being reflected
    /// (glTF `KHR_materials_transmission`); the subsurface LPV carries it through the object.
    pub translucency: f32,
    /// Both faces are drawn (glTF `doubleSided`); otherwise back faces are culled unless the
    /// renderer's `cull=0`.
    pub double_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        let (metallic, roughness) = (0.0, 0.8);
        let base = [0.7, 0.7, 0.7];
        let (specular, shininess) = blinn_phong_from_metallic_roughness(base, metallic, roughness);
        Material {
            name: "default".into(),
            base_color: [base[0], base[1], base[2], 1.0],
            base_color_tex: None,
            normal_tex: None,
            specular,
            shininess,
            specular_tex: None,
            metallic_roughness_tex: None,
            metallic,
            roughness,
            alpha_mode: AlphaMode::Opaque,
            emissive: [0.0; 3],
            translucency: 0.0,
            // glTF's default; OBJ has no such statement and closed models are the norm.
            double_sided: false,
        }
    }
}

/// Maps metallic-roughness to Blinn–Phong `(specular colour, shininess)`.
///
/// Specular is the Fresnel reflectance at normal incidence, `mix(0.04, base, metallic)` (4 % is the
/// usual dielectric F0). Shininess uses the Beckmann ↔ Phong correspondence `n = 2/α² − 2` with
/// `α = roughness²` (the glTF/Disney remapping), clamped to [1, 4096] because roughness 0 would be
/// infinite and very rough surfaces would go negative.
pub fn blinn_phong_from_metallic_roughness(base: [f32; 3], metallic: f32, roughness: f32) -> ([f32; 3], f32) {
    let m = metallic.clamp(0.0, 1.0);
    let spec = base.map(|b| 0.04 + (b - 0.04) * m);
    let r = roughness.clamp(0.0, 1.0);
    let r4 = r * r * r * r;
    let shininess = if r4 > 0.0 { 2.0 / r4 - 2.0 } else { f32::INFINITY };
    (spec, shininess.clamp(1.0, 4096.0))
}

/// Inverse of the shininess mapping in [`blinn_phong_from_metallic_roughness`]: `roughness = (2/(n+2))^¼`.
pub fn roughness_from_shininess(shininess: f32) -> f32 {
    (2.0 / (shininess.max(0.0) + 2.0)).powf(0.25)
}

/// A light source.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// An infinitely distant light (the sun).
    Directional {
        /// Unit direction the light travels (from the light into the scene).
        direction: [f32; 3],
        /// Linear colour, roughly unit luminance.
        color: [f32; 3],
        /// Irradiance on a surface facing the light (W/m², linear units).
        intensity: f32,
    },
    /// A cone light.
    Spot {
        /// World-space position.
        position: [f32; 3],
        /// Unit direction of the cone axis (direction the light travels).
        direction: [f32; 3],
        /// Linear colour.
        color: [f32; 3],
        /// Radiant intensity along the axis (W/sr, linear units).
        intensity: f32,
        /// Half-angle from the axis, radians, inside which the light is at full intensity.
        inner_angle: f32,
        /// Half-angle from the axis, radians, outside which the light is zero.
        outer_angle: f32,
        /// Distance beyond which the light is ignored (metres).
        range: f32,
    },
    /// An omnidirectional light.
    Point {
        /// World-space position.
        position: [f32; 3],
        /// Linear colour.
        color: [f32; 3],
        /// Radiant intensity (W/sr, linear units).
        intensity: f32,
        /// Distance beyond which the light is ignored (metres).
        range: f32,
    },
}

/// Axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Aabb {
    /// The box around `points`; an empty input gives a degenerate box at the origin.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a [f32; 3]>) -> Aabb {
        let mut b = Aabb { min: [f32::INFINITY; 3], max: [f32::NEG_INFINITY; 3] };
        for p in points {
            for (k, &v) in p.iter().enumerate() {
                b.min[k] = b.min[k].min(v);
                b.max[k] = b.max[k].max(v);
            }
        }
        if b.min[0] > b.max[0] {
            b = Aabb { min: [0.0; 3], max: [0.0; 3] };
        }
        b
    }

    /// Centre point.
    pub fn center(&self) -> [f32; 3] {
        [0, 1, 2].map(|k| 0.5 * (self.min[k] + self.max[k]))
    }

    /// Edge lengths.
    pub fn size(&self) -> [f32; 3] {
        [0, 1, 2].map(|k| self.max[k] - self.min[k])
    }
}

/// A loaded scene, ready for upload.
#[derive(Debug, Clone)]
pub struct Scene {
    /// World-space meshes.
    pub meshes: Vec<Mesh>,
    /// Materials referenced by [`Mesh::material`].
    pub materials: Vec<Material>,
    /// Textures referenced by the materials.
    pub textures: Vec<Texture>,
    /// Light sources.
    pub lights: Vec<Light>,
    /// The initial (or fixed) camera.
    pub camera: Camera,
    /// Optional animated camera; lens parameters come from `camera`.
    pub camera_path: Option<CameraPath>,
    /// Bounds of all mesh positions.
    pub bounds: Aabb,
    /// Recoverable problems met while loading (already logged).
    pub warnings: Vec<String>,
    /// Renderer settings from the scene file, as strings (overridable with `--set`).
    pub settings: BTreeMap<String, String>,
}

impl Scene {
    /// A scene around these meshes, with computed bounds, a framing camera and a default sun.
    pub fn from_parts(meshes: Vec<Mesh>, materials: Vec<Material>, textures: Vec<Texture>) -> Scene {
        let bounds = Aabb::from_points(meshes.iter().flat_map(|m| m.positions.iter()));
        Scene {
            camera: Camera::framing(&bounds, 45.0),
            meshes,
            materials,
            textures,
            lights: vec![default_sun()],
            camera_path: None,
            bounds,
            warnings: Vec::new(),
            settings: BTreeMap::new(),
        }
    }

    /// Total number of triangles over all meshes.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(Mesh::triangle_count).sum()
    }

    /// The setting `key`, with `--set` overrides (last one wins) taking precedence over the scene file.
    pub fn setting<'a>(&'a self, sets: &'a [(String, String)], key: &str) -> Option<&'a str> {
        sets.iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
            .or(self.settings.get(key).map(|s| s.as_str()))
    }
}

/// The sun used for bare models: travelling down and slightly sideways so vertical faces are lit too.
pub fn default_sun() -> Light {
    let d = [-0.3f32, -1.0, -0.2];
    let len = d.iter().map(|v| v * v).sum::<f32>().sqrt();
    Light::Directional { direction: d.map(|v| v / len), color: [1.0, 1.0, 1.0], intensity: 3.0 }
}

/// Logs a loader warning and keeps it for the caller.
pub(crate) fn warn(warnings: &mut Vec<String>, msg: String) {
    log::warn!("{msg}");
    warnings.push(msg);
}

/// Reads a whole file; a missing file is bad input (exit code 2), other failures are I/O errors.
pub(crate) fn read_file(path: &std::path::Path) -> crate::Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => crate::Error::Input(format!("{}: no such file", path.display())),
        _ => crate::Error::Io { path: path.display().to_string(), source },
    })
}
