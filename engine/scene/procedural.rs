//! Built-in scenes that need no downloads: the Cornell box and a thin-walled atrium.

use super::{blinn_phong_from_metallic_roughness, Camera, Light, Material, Mesh, Scene};

pub use super::geometry::{add_box, add_quad};

fn diffuse(name: &str, rgb: [f32; 3]) -> Material {
    let (specular, shininess) = blinn_phong_from_metallic_roughness(rgb, 0.0, 1.0);
    Material {
        name: name.into(),
        base_color: [rgb[0], rgb[1], rgb[2], 1.0],
        specular,
        shininess,
        metallic: 0.0,
        roughness: 1.0,
        ..Material::default()
    }
}

fn mm(p: [f32; 3]) -> [f32; 3] {
    p.map(|v| v * 0.001)
}

fn quads(name: &str, material: usize, list: &[[[f32; 3]; 4]]) -> Mesh {
    let mut m = Mesh { name: name.into(), material, ..Mesh::default() };
    for q in list {
        add_quad(&mut m, q.map(mm));
    }
    m
}

/// Names of the built-in scenes (`builtin = "NAME"` in scene files, the mesh demos' defaults).
pub const BUILTIN: &[&str] = &["cornell", "atrium"];

/// A built-in scene by name.
pub fn builtin(name: &str) -> Option<Scene> {
    match name {
        "cornell" => Some(cornell_box()),
        "atrium" => Some(atrium()),
        _ => None,
    }
}

/// The original Cornell box (Cornell University Program of Computer Graphics, "Cornell Box Data"), with
/// its published vertex coordinates converted from millimetres to metres.
///
/// The published data is already right-handed with +Y up: the camera sits at z = −0.8 looking down +z,
/// so +x (the red wall) is on the viewer's left, and every published quad winds counter-clockwise seen
/// from the inside, which matches this module's front-face convention without reordering. Colours are
/// the usual RGB approximations of the published spectral reflectances (as used by e.g. the Mitsuba and
/// PBRT Cornell box scenes); the light patch's emission (17, 12, 4) is from the same source. The light
/// patch is lowered 0.5 mm below the ceiling so the two coplanar surfaces don't z-fight. A spot light at
/// the patch's centre, pointing down with an 80° half-angle, stands in for the area light where a
/// shadowed punctual light is needed.
pub fn cornell_box() -> Scene {
    let materials = vec![
        diffuse("white", [0.725, 0.71, 0.68]),
        diffuse("red", [0.63, 0.065, 0.05]),
        diffuse("green", [0.14, 0.45, 0.091]),
        Material { emissive: [17.0, 12.0, 4.0], ..diffuse("light", [0.78, 0.78, 0.78]) },
    ];
    let (white, red, green, light) = (0, 1, 2, 3);
    let ly = 548.8 - 0.5;
    let meshes = vec![
        quads("floor", white, &[[[552.8, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 559.2], [549.6, 0.0, 559.2]]]),
        quads(
            "ceiling",
            white,
            &[[[556.0, 548.8, 0.0], [556.0, 548.8, 559.2], [0.0, 548.8, 559.2], [0.0, 548.8, 0.0]]],
        ),
        quads(
            "back_wall",
            white,
            &[[[549.6, 0.0, 559.2], [0.0, 0.0, 559.2], [0.0, 548.8, 559.2], [556.0, 548.8, 559.2]]],
        ),
        quads(
            "right_wall_green",
            green,
            &[[[0.0, 0.0, 559.2], [0.0, 0.0, 0.0], [0.0, 548.8, 0.0], [0.0, 548.8, 559.2]]],
        ),
        quads(
            "left_wall_red",
            red,
            &[[[552.8, 0.0, 0.0], [549.6, 0.0, 559.2], [556.0, 548.8, 559.2], [556.0, 548.8, 0.0]]],
        ),
        quads("light", light, &[[[343.0, ly, 227.0], [343.0, ly, 332.0], [213.0, ly, 332.0], [213.0, ly, 227.0]]]),
        quads(
            "short_block",
            white,
            &[
                [[130.0, 165.0, 65.0], [82.0, 165.0, 225.0], [240.0, 165.0, 272.0], [290.0, 165.0, 114.0]],
                [[290.0, 0.0, 114.0], [290.0, 165.0, 114.0], [240.0, 165.0, 272.0], [240.0, 0.0, 272.0]],
                [[130.0, 0.0, 65.0], [130.0, 165.0, 65.0], [290.0, 165.0, 114.0], [290.0, 0.0, 114.0]],
                [[82.0, 0.0, 225.0], [82.0, 165.0, 225.0], [130.0, 165.0, 65.0], [130.0, 0.0, 65.0]],
                [[240.0, 0.0, 272.0], [240.0, 165.0, 272.0], [82.0, 165.0, 225.0], [82.0, 0.0, 225.0]],
            ],
        ),
        quads(
            "tall_block",
            white,
            &[
                [[423.0, 330.0, 247.0], [265.0, 330.0, 296.0], [314.0, 330.0, 456.0], [472.0, 330.0, 406.0]],
                [[423.0, 0.0, 247.0], [423.0, 330.0, 247.0], [472.0, 330.0, 406.0], [472.0, 0.0, 406.0]],
                [[472.0, 0.0, 406.0], [472.0, 330.0, 406.0], [314.0, 330.0, 456.0], [314.0, 0.0, 456.0]],
                [[314.0, 0.0, 456.0], [314.0, 330.0, 456.0], [265.0, 330.0, 296.0], [265.0, 0.0, 296.0]],
                [[265.0, 0.0, 296.0], [265.0, 330.0, 296.0], [423.0, 330.0, 247.0], [423.0, 0.0, 247.0]],
            ],
        ),
    ];
    let mut scene = Scene::from_parts(meshes, materials, Vec::new());
    // Published camera: 35 mm focal length on a 25 mm film → vertical fov 2·atan(12.5/35) ≈ 39.3°.
    scene.camera = Camera {
        position: mm([278.0, 273.0, -800.0]),
        target: mm([278.0, 273.0, 0.0]),
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 39.3,
        near: 0.01,
        far: 10.0,
    };
    // Radiant intensity along the axis ≈ the patch's radiance × area (0.13 m × 0.105 m), red channel.
    let area = 0.13 * 0.105;
    scene.lights = vec![Light::Spot {
        position: mm([278.0, 548.8 - 1.0, 279.5]),
        direction: [0.0, -1.0, 0.0],
        color: [1.0, 12.0 / 17.0, 4.0 / 17.0],
        intensity: 17.0 * area,
        inner_angle: 60f32.to_radians(),
        outer_angle: 80f32.to_radians(),
        range: 5.0,
    }];
    scene
}

/// Thickness of the interior walls of [`atrium`] (metres): thin enough that a light propagation volume
/// with cells larger than this leaks light through them.
pub const ATRIUM_THIN_WALL: f32 = 0.08;

/// A 20 m × 20 m × 8 m atrium: an 8 m × 8 m open courtyard (sunlit through a roof opening) ringed by four
/// rooms with distinct floor colours, pillars along the courtyard's open north and west sides, and thin
/// (0.08 m) walls elsewhere. The east room is closed off from the sunlit courtyard by a single thin wall
/// with no opening, so it should stay dark: light seen there is leakage.
pub fn atrium() -> Scene {
    let t = ATRIUM_THIN_WALL;
    let outer = 0.2;
    let (h, roof) = (7.8, 8.0);
    let mut materials = vec![
        diffuse("plaster", [0.8, 0.78, 0.74]),
        diffuse("stone", [0.55, 0.53, 0.5]),
        diffuse("roof", [0.4, 0.4, 0.42]),
    ];
    let (plaster, stone, roof_mat) = (0, 1, 2);
    let mut meshes = Vec::new();
    let mut floor = |name: &str, rgb: [f32; 3], x: [f32; 2], z: [f32; 2]| {
        materials.push(diffuse(&format!("{name}_floor"), rgb));
        let mut m = Mesh { name: format!("{name}_floor"), material: materials.len() - 1, ..Mesh::default() };
        add_quad(&mut m, [[x[0], 0.0, z[0]], [x[0], 0.0, z[1]], [x[1], 0.0, z[1]], [x[1], 0.0, z[0]]]);
        m
    };
    meshes.push(floor("courtyard", [0.7, 0.7, 0.68], [6.0, 14.0], [6.0, 14.0]));
    meshes.push(floor("west_room", [0.75, 0.2, 0.15], [0.0, 6.0], [0.0, 20.0]));
    meshes.push(floor("east_room", [0.15, 0.3, 0.75], [14.0, 20.0], [0.0, 20.0]));
    meshes.push(floor("south_room", [0.2, 0.6, 0.2], [6.0, 14.0], [0.0, 6.0]));
    meshes.push(floor("north_room", [0.8, 0.7, 0.15], [6.0, 14.0], [14.0, 20.0]));

    let mut boxed = |name: &str, material: usize, min: [f32; 3], max: [f32; 3]| {
        let mut m = Mesh { name: name.into(), material, ..Mesh::default() };
        add_box(&mut m, min, max);
        meshes.push(m);
    };
    let half = t / 2.0;
    // Outer shell.
    boxed("outer_wall_south", plaster, [0.0, 0.0, 0.0], [20.0, h, outer]);
    boxed("outer_wall_north", plaster, [0.0, 0.0, 20.0 - outer], [20.0, h, 20.0]);
    boxed("outer_wall_west", plaster, [0.0, 0.0, outer], [outer, h, 20.0 - outer]);
    boxed("outer_wall_east", plaster, [20.0 - outer, 0.0, outer], [20.0, h, 20.0 - outer]);
    // The leak test: sunlit courtyard | dark east room, one thin wall, no opening.
    boxed("thin_wall_courtyard_east", plaster, [14.0 - half, 0.0, 6.0], [14.0 + half, h, 14.0]);
    // Courtyard | south room: thin wall with a 2 m wide, 2.5 m high doorway in the middle.
    boxed("thin_wall_courtyard_south_a", plaster, [6.0, 0.0, 6.0 - half], [9.0, h, 6.0 + half]);
    boxed("thin_wall_courtyard_south_b", plaster, [11.0, 0.0, 6.0 - half], [14.0, h, 6.0 + half]);
    boxed("thin_wall_courtyard_south_lintel", plaster, [9.0, 2.5, 6.0 - half], [11.0, h, 6.0 + half]);
    // Between the ring rooms.
    boxed("thin_wall_south_west", plaster, [6.0 - half, 0.0, outer], [6.0 + half, h, 6.0]);
    boxed("thin_wall_south_east", plaster, [14.0 - half, 0.0, outer], [14.0 + half, h, 6.0]);
    boxed("thin_wall_north_west", plaster, [6.0 - half, 0.0, 14.0], [6.0 + half, h, 20.0 - outer]);
    boxed("thin_wall_north_east", plaster, [14.0 - half, 0.0, 14.0], [14.0 + half, h, 20.0 - outer]);
    // Pillars along the open west (x = 6) and north (z = 14) sides of the courtyard.
    for (i, c) in [7.0, 9.3, 11.6, 13.8].into_iter().enumerate() {
        boxed(&format!("pillar_west_{i}"), stone, [5.8, 0.0, c - 0.2], [6.2, h, c + 0.2]);
    }
    for (i, c) in [6.2, 8.5, 10.8, 13.0].into_iter().enumerate() {
        boxed(&format!("pillar_north_{i}"), stone, [c - 0.2, 0.0, 13.8], [c + 0.2, h, 14.2]);
    }
    // Roof slab with the courtyard opening.
    boxed("roof_south", roof_mat, [0.0, h, 0.0], [20.0, roof, 6.0]);
    boxed("roof_north", roof_mat, [0.0, h, 14.0], [20.0, roof, 20.0]);
    boxed("roof_west", roof_mat, [0.0, h, 6.0], [6.0, roof, 14.0]);
    boxed("roof_east", roof_mat, [14.0, h, 6.0], [20.0, roof, 14.0]);

    let mut scene = Scene::from_parts(meshes, materials, Vec::new());
    // Sun travelling down and towards +x, +z: it lights the courtyard floor and the courtyard face of the
    // thin east wall, and reaches into the north room under the pillars.
    let d = glam::Vec3::new(0.45, -1.0, 0.3).normalize();
    scene.lights = vec![Light::Directional { direction: d.into(), color: [1.0, 0.95, 0.85], intensity: 3.0 }];
    // From above the courtyard's south-west corner: the sunlit floor, the thin east wall and the
    // pillars' shadows reaching into the north room are all in view.
    scene.camera = Camera {
        position: [7.0, 6.5, 7.0],
        target: [14.0, 1.0, 16.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 70.0,
        near: 0.05,
        far: 100.0,
    };
    scene
}
