//! Small scenes built in code for the GPU tests.

use glam::Vec3;
use std::collections::BTreeMap;
use vkengine::mesh::camera::View;
use vkengine::scene::{Aabb, AlphaMode, Camera, Light, Material, Mesh, Scene};

/// Axis-aligned quad with normal `n`, centred at `c`, spanning `u` and `v` (half extents).
pub fn quad(c: Vec3, u: Vec3, v: Vec3, material: usize) -> Mesh {
    let n = u.cross(v).normalize();
    let p = [c - u - v, c + u - v, c + u + v, c - u + v];
    Mesh {
        name: "quad".into(),
        positions: p.iter().map(|x| x.to_array()).collect(),
        normals: vec![n.to_array(); 4],
        uvs: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        tangents: vec![[u.x, u.y, u.z, 1.0]; 4],
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
    }
}

/// Closed box from `lo` to `hi` with outward normals.
pub fn boxed(lo: Vec3, hi: Vec3, material: usize) -> Vec<Mesh> {
    let c = (lo + hi) * 0.5;
    let h = (hi - lo) * 0.5;
    let (x, y, z) = (Vec3::X * h.x, Vec3::Y * h.y, Vec3::Z * h.z);
    vec![
        quad(c + y, z, x, material),
        quad(c - y, x, z, material),
        quad(c + x, y, z, material),
        quad(c - x, z, y, material),
        quad(c + z, x, y, material),
        quad(c - z, y, x, material),
    ]
}

pub fn lambert(albedo: f32) -> Material {
    Material {
        base_color: [albedo, albedo, albedo, 1.0],
        specular: [0.0; 3],
        shininess: 1.0,
        alpha_mode: AlphaMode::Opaque,
        ..Material::default()
    }
}

pub fn scene(meshes: Vec<Mesh>, lights: Vec<Light>, camera: Camera) -> Scene {
    let bounds = Aabb::from_points(meshes.iter().flat_map(|m| m.positions.iter()));
    Scene {
        meshes,
        materials: vec![lambert(0.5)],
        textures: vec![],
        lights,
        camera,
        camera_path: None,
        bounds,
        warnings: vec![],
        settings: BTreeMap::new(),
    }
}

/// A camera at `position` looking at `target` (near 0.1, far 50).
pub fn camera(position: [f32; 3], target: [f32; 3], up: [f32; 3], fov_y_deg: f32) -> Camera {
    Camera { position, target, up, fov_y_deg, near: 0.1, far: 50.0 }
}

pub fn view_of(c: &Camera) -> View {
    View::look_at(c.position.into(), c.target.into(), c.up.into(), c.fov_y_deg, c.near, c.far)
}

/// A built-in scene (`cornell`, `atrium`) by name.
pub fn builtin_scene(name: &str) -> vkengine::Result<Scene> {
    vkengine::scene::procedural::builtin(name)
        .ok_or_else(|| vkengine::Error::Input(format!("unknown built-in scene `{name}`")))
}

/// Mesh settings as the mesh demos layer them: a scene file's `[settings]` under `--set` pairs;
/// also the RSM edge.
pub fn mesh_settings(
    file: &BTreeMap<String, String>,
    sets: &[(String, String)],
) -> vkengine::Result<(vkengine::mesh::renderer::MeshSettings, u32)> {
    use vkengine::settings::{layered, Origin};
    let s = vkengine::mesh::settings::MeshSetup::parse(&layered(file, &Origin::File("scene file".into()), sets))?;
    Ok((s.settings, s.rsm_size()))
}
