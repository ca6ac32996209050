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

/// The camera ray through pixel (px, py)'s centre as the lighting pass reconstructs it (NDC
/// `uv·2 - 1` through the inverse view-projection), in f64, intersected with the plane y = `h`:
/// the world point that pixel shades, if the ray meets the plane in front of the camera.
pub fn shaded_point(view: &View, size: [u32; 2], px: u32, py: u32, h: f64) -> Option<[f64; 3]> {
    let m = view.view_proj(size[0] as f32 / size[1] as f32).inverse().to_cols_array().map(f64::from);
    let ndc = [
        (f64::from(px) + 0.5) / f64::from(size[0]) * 2.0 - 1.0,
        (f64::from(py) + 0.5) / f64::from(size[1]) * 2.0 - 1.0,
    ];
    let unproject = |z: f64| {
        let v = [ndc[0], ndc[1], z, 1.0];
        let c: [f64; 4] = [0, 1, 2, 3].map(|r| (0..4).map(|k| m[k * 4 + r] * v[k]).sum());
        [c[0] / c[3], c[1] / c[3], c[2] / c[3]]
    };
    let (a, b) = (unproject(0.0), unproject(0.5));
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let eye = view.position.map(f64::from);
    let t = (h - a[1]) / d[1];
    let p = [a[0] + d[0] * t, h, a[2] + d[2] * t];
    // In front of the eye: the point lies along the viewing direction from it.
    let ahead: f64 = (0..3).map(|i| (p[i] - eye[i]) * d[i]).sum();
    (t.is_finite() && ahead > 0.0).then_some(p)
}
