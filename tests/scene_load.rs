//! Mesh scene loading on the CPU: glTF, OBJ/MTL, TOML descriptions and the built-in scenes, from small
//! files written here; every bad-input case must be an error naming the file and the problem.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

use vkengine::scene::geometry::generate_normals;
use vkengine::scene::procedural::{add_box, atrium, cornell_box, ATRIUM_THIN_WALL};
use vkengine::scene::texture::build_mips;
use vkengine::scene::{load_scene, AlphaMode, Camera, CameraKey, CameraPath, Light, Mesh, Scene, Texture};
use vkengine::Error;

/// A fresh, empty directory per call (tests run in parallel).
fn tmpdir(name: &str) -> PathBuf {
    static N: AtomicU32 = AtomicU32::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let dir =
        std::env::temp_dir().join(format!("vkengine_scene_load_{}", std::process::id())).join(format!("{name}_{n}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

fn write(path: &Path, bytes: impl AsRef<[u8]>) {
    if let Some(p) = path.parent() {
        std::fs::create_dir_all(p).expect("create dir");
    }
    std::fs::write(path, bytes).expect("write test file");
}

/// Loads `path`, expects an input error naming the file and containing `phrase`.
fn load_err(path: &Path, phrase: &str) -> String {
    let err = match load_scene(path) {
        Ok(s) => {
            panic!("{} loaded ({} triangles) but should fail with \"{phrase}\"", path.display(), s.triangle_count())
        }
        Err(e) => e,
    };
    let msg = err.to_string();
    assert!(matches!(err, Error::Input(_)), "not an input error: {msg}");
    let name = path.file_name().and_then(|n| n.to_str()).expect("file name");
    assert!(msg.contains(name), "message does not name {name}: {msg}");
    assert!(msg.contains(phrase), "message lacks \"{phrase}\": {msg}");
    msg
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let v = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(v >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A glTF with one mesh on a child node: parent translated by (10, 0, 0), child by (0, 2, 0).
fn gltf(positions: &[[f32; 3]], normals: Option<&[[f32; 3]]>, indices: &[u32], mode: u32) -> String {
    let mut buf = Vec::new();
    positions.iter().flatten().for_each(|v| buf.extend_from_slice(&v.to_le_bytes()));
    let pos_len = buf.len();
    normals.into_iter().flatten().flatten().for_each(|v| buf.extend_from_slice(&v.to_le_bytes()));
    let nrm_len = buf.len() - pos_len;
    indices.iter().for_each(|v| buf.extend_from_slice(&v.to_le_bytes()));
    let idx_len = buf.len() - pos_len - nrm_len;
    let n = positions.len();
    let (normal_attr, normal_view) = if normals.is_some() {
        (r#","NORMAL":1"#.to_string(), format!(r#",{{"buffer":0,"byteOffset":{pos_len},"byteLength":{nrm_len}}}"#))
    } else {
        (String::new(), format!(r#",{{"buffer":0,"byteOffset":{pos_len},"byteLength":0}}"#))
    };
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"name": "parent", "translation": [10, 0, 0], "children": [1]}},
            {{"name": "child", "translation": [0, 2, 0], "mesh": 0}}],
  "meshes": [{{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 0{normal_attr}}}, "indices": 2, "mode": {mode}, "material": 0}}]}}],
  "materials": [{{"name": "red", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.1, 0.05, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}}}}],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{b64}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {pos_len}}}{normal_view},
                  {{"buffer": 0, "byteOffset": {idx_off}, "byteLength": {idx_len}}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": {n}, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]}},
    {{"bufferView": 1, "componentType": 5126, "count": {n}, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5125, "count": {ni}, "type": "SCALAR"}}
  ]
}}"#,
        len = buf.len(),
        b64 = base64(&buf),
        idx_off = pos_len + nrm_len,
        ni = indices.len(),
    )
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
const UP: [[f32; 3]; 3] = [[0.0, 0.0, 1.0]; 3];

fn approx(a: [f32; 3], b: [f32; 3], eps: f32) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= eps)
}

#[test]
fn gltf_hierarchy_transforms_positions_and_reads_material() {
    let dir = tmpdir("gltf_ok");
    let p = dir.join("tri.gltf");
    write(&p, gltf(&TRI, Some(&UP), &[0, 1, 2], 4));
    let s = load_scene(&p).expect("load");
    assert_eq!(s.triangle_count(), 1);
    let m = &s.meshes[0];
    assert!(approx(m.positions[0], [10.0, 2.0, 0.0], 1e-6), "{:?}", m.positions);
    assert!(approx(m.positions[1], [11.0, 2.0, 0.0], 1e-6));
    assert!(approx(m.normals[0], [0.0, 0.0, 1.0], 1e-6));
    let mat = &s.materials[m.material];
    assert_eq!(mat.name, "red");
    assert_eq!(mat.base_color, [0.8, 0.1, 0.05, 1.0]);
    assert_eq!(m.tangents.len(), 3);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(approx(s.bounds.min, [10.0, 2.0, 0.0], 1e-6) && approx(s.bounds.max, [11.0, 3.0, 0.0], 1e-6));
    // Bare models get the default sun and a camera framing the bounds.
    assert!(matches!(s.lights[0], Light::Directional { intensity, .. } if intensity == 3.0));
    assert_eq!(s.camera.target, s.bounds.center());
}

#[test]
fn gltf_transmission_becomes_translucency() {
    let dir = tmpdir("gltf_transmission");
    let p = dir.join("tri.gltf");
    let text = gltf(&TRI, Some(&UP), &[0, 1, 2], 4).replace(
        r#""roughnessFactor": 0.5}}"#,
        r#""roughnessFactor": 0.5}, "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.4}}}"#,
    );
    assert!(text.contains("transmissionFactor"), "the test's glTF edit did not apply");
    write(&p, text);
    let s = load_scene(&p).expect("load");
    assert_eq!(s.materials[s.meshes[0].material].translucency, 0.4);
    // Without the extension: opaque.
    write(&p, gltf(&TRI, Some(&UP), &[0, 1, 2], 4));
    assert_eq!(load_scene(&p).expect("load").materials[0].translucency, 0.0);
}

#[test]
fn gltf_double_sided_is_read_and_obj_materials_are_single_sided() {
    let dir = tmpdir("gltf_double_sided");
    let p = dir.join("tri.gltf");
    let text =
        gltf(&TRI, Some(&UP), &[0, 1, 2], 4).replace(r#""name": "red","#, r#""name": "red", "doubleSided": true,"#);
    assert!(text.contains("doubleSided"), "the test's glTF edit did not apply");
    write(&p, text);
    assert!(load_scene(&p).expect("load").materials[0].double_sided);
    // glTF's default is single-sided.
    write(&p, gltf(&TRI, Some(&UP), &[0, 1, 2], 4));
    assert!(!load_scene(&p).expect("load").materials[0].double_sided);
    let obj = dir.join("quad.obj");
    write(&obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    assert!(load_scene(&obj).expect("load").materials.iter().all(|m| !m.double_sided));
}

#[test]
fn gltf_without_normals_generates_them_with_a_warning() {
    let dir = tmpdir("gltf_nonormals");
    let p = dir.join("nonormals.gltf");
    write(&p, gltf(&TRI, None, &[0, 1, 2], 4));
    let s = load_scene(&p).expect("load");
    for n in &s.meshes[0].normals {
        assert!(approx(*n, [0.0, 0.0, 1.0], 1e-6), "counter-clockwise in xy must face +z: {n:?}");
    }
    assert!(s.warnings.iter().any(|w| w.contains("normals") && w.contains("nonormals.gltf")), "{:?}", s.warnings);
}

#[test]
fn gltf_index_out_of_range_is_an_error() {
    let dir = tmpdir("gltf_idx");
    let p = dir.join("badindex.gltf");
    write(&p, gltf(&TRI, Some(&UP), &[0, 1, 7], 4));
    load_err(&p, "index");
}

#[test]
fn gltf_nan_position_is_an_error() {
    let dir = tmpdir("gltf_nan");
    let p = dir.join("nan.gltf");
    let mut pos = TRI;
    pos[1][1] = f32::NAN;
    write(&p, gltf(&pos, Some(&UP), &[0, 1, 2], 4));
    load_err(&p, "NaN");
}

#[test]
fn gltf_points_and_lines_are_errors_strips_are_converted() {
    let dir = tmpdir("gltf_mode");
    let p = dir.join("points.gltf");
    write(&p, gltf(&TRI, Some(&UP), &[0, 1, 2], 0));
    load_err(&p, "primitive mode Points");
    let p = dir.join("lines.gltf");
    write(&p, gltf(&TRI, Some(&UP), &[0, 1, 2], 1));
    load_err(&p, "primitive mode Lines");
    // A 4-vertex strip is two triangles, both facing +z.
    let quad = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let p = dir.join("strip.gltf");
    write(&p, gltf(&quad, None, &[0, 1, 2, 3], 5));
    let s = load_scene(&p).expect("strip");
    assert_eq!(s.triangle_count(), 2);
    let n = generate_normals(&s.meshes[0].positions, &s.meshes[0].indices);
    assert!(n.iter().all(|n| approx(*n, [0.0, 0.0, 1.0], 1e-6)), "strip winding flipped: {n:?}");
}

#[test]
fn broken_gltf_and_truncated_glb_name_the_file() {
    let dir = tmpdir("gltf_broken");
    let p = dir.join("broken.gltf");
    write(&p, r#"{"asset": {"version": "2.0"}, "meshes": [ "#);
    load_err(&p, "not a valid glTF");
    let p = dir.join("trunc.glb");
    let mut glb = b"glTF".to_vec();
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&4000u32.to_le_bytes());
    glb.extend_from_slice(&100u32.to_le_bytes());
    glb.extend_from_slice(b"JSON{\"asset\"");
    write(&p, glb);
    load_err(&p, "not a valid glTF");
    // A buffer pointing at a missing file.
    let p = dir.join("nobuf.gltf");
    let text = gltf(&TRI, Some(&UP), &[0, 1, 2], 4);
    let start = text.find("data:").expect("uri");
    let end = start + text[start..].find('"').expect("end of uri");
    write(&p, format!("{}missing.bin{}", &text[..start], &text[end..]));
    load_err(&p, "missing.bin");
}

#[test]
fn obj_with_missing_texture_loads_with_fallback_and_warning() {
    let dir = tmpdir("obj_tex");
    write(&dir.join("m.mtl"), "newmtl brick\nKd 0.5 0.25 0.125\nKs 0.1 0.1 0.1\nNs 64\nmap_Kd nothere.png\n");
    let p = dir.join("tex.obj");
    write(&p, "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl brick\nf 1/1 2/2 3/3\n");
    let s = load_scene(&p).expect("load");
    let mat = &s.materials[s.meshes[0].material];
    assert_eq!(mat.name, "brick");
    assert_eq!(mat.base_color, [0.5, 0.25, 0.125, 1.0]);
    assert_eq!(mat.shininess, 64.0);
    let t = &s.textures[mat.base_color_tex.expect("fallback texture index")];
    assert_eq!((t.width, t.height, t.mips.len()), (1, 1, 1));
    assert_eq!(t.mips[0], vec![255, 255, 255, 255]);
    assert!(s.warnings.iter().any(|w| w.contains("nothere.png")), "{:?}", s.warnings);
    // OBJ v runs bottom-up; ours runs top-down.
    assert_eq!(s.meshes[0].uvs[2], [0.0, 0.0]);
}

/// A 4×4 DXT1 (BC1) DDS file whose one block is solid red.
fn dds_red_dxt1() -> Vec<u8> {
    let mut b = vec![0u8; 128];
    let mut put = |at: usize, v: u32| b[at..at + 4].copy_from_slice(&v.to_le_bytes());
    put(4, 124); // header size
    put(8, 0x1 | 0x2 | 0x4 | 0x1000 | 0x8_0000); // caps, height, width, pixel format, linear size
    put(12, 4);
    put(16, 4);
    put(20, 8);
    put(76, 32); // pixel format size
    put(80, 0x4); // FourCC
    put(108, 0x1000); // texture
    b[0..4].copy_from_slice(b"DDS ");
    b[84..88].copy_from_slice(b"DXT1");
    // colour0 = red (RGB565 0xF800) > colour1 = blue, every index 0.
    b.extend([0x00, 0xf8, 0x1f, 0x00, 0, 0, 0, 0]);
    b
}

#[test]
fn obj_bmp_tga_and_dds_textures_decode() {
    let dir = tmpdir("obj_formats");
    let img = image::RgbaImage::from_fn(3, 2, |x, y| image::Rgba([40 * x as u8, 100 * y as u8, 7, 255]));
    img.save_with_format(dir.join("t.bmp"), image::ImageFormat::Bmp).expect("write bmp");
    img.save_with_format(dir.join("t.tga"), image::ImageFormat::Tga).expect("write tga");
    write(&dir.join("t.dds"), dds_red_dxt1());
    write(&dir.join("m.mtl"), "newmtl b\nmap_Kd t.bmp\nnewmtl t\nmap_Kd t.tga\nnewmtl d\nmap_Kd t.dds\n");
    let p = dir.join("formats.obj");
    write(
        &p,
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n\
         usemtl b\nf 1/1 2/2 3/3\nusemtl t\nf 1/1 2/2 3/3\nusemtl d\nf 1/1 2/2 3/3\n",
    );
    let s = load_scene(&p).expect("load");
    assert!(!s.warnings.iter().any(|w| w.contains("texture")), "{:?}", s.warnings);
    let tex = |name: &str| {
        let m = s.materials.iter().find(|m| m.name == name).expect("material");
        &s.textures[m.base_color_tex.expect("texture")]
    };
    for name in ["b", "t"] {
        let t = tex(name);
        assert_eq!((t.width, t.height), (3, 2), "{name}");
        assert_eq!(t.mips[0], img.as_raw().clone(), "{name}");
    }
    let d = tex("d");
    assert_eq!((d.width, d.height), (4, 4));
    assert!(d.mips[0].chunks(4).all(|p| p == [255, 0, 0, 255]), "{:?}", &d.mips[0][..8]);
}

#[test]
fn obj_quad_is_triangulated() {
    let dir = tmpdir("obj_quad");
    let p = dir.join("quad.obj");
    write(&p, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    let s = load_scene(&p).expect("load");
    assert_eq!(s.triangle_count(), 2);
    assert!(s.meshes[0].normals.iter().all(|n| approx(*n, [0.0, 0.0, 1.0], 1e-6)));
}

#[test]
fn obj_with_missing_mtl_uses_default_material() {
    let dir = tmpdir("obj_nomtl");
    let p = dir.join("nomtl.obj");
    write(&p, "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n");
    let s = load_scene(&p).expect("load");
    assert!(s.warnings.iter().any(|w| w.contains("gone.mtl")), "{:?}", s.warnings);
    assert_eq!(s.materials[s.meshes[0].material].name, "default");
}

#[test]
fn obj_bad_geometry_is_an_error() {
    let dir = tmpdir("obj_bad");
    let p = dir.join("nan.obj");
    write(&p, "v 0 0 0\nv NaN 0 0\nv 0 1 0\nf 1 2 3\n");
    load_err(&p, "NaN");
    let p = dir.join("range.obj");
    write(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    let e = load_scene(&p).expect_err("index 9 of 3");
    assert!(e.to_string().contains("range.obj"), "{e}");
}

#[test]
fn obj_real_world_bump_syntax_and_backslash_paths() {
    let dir = tmpdir("obj_bump");
    // A greyscale ramp (height map) and a flat-blue (already a normal map) image in a subdirectory.
    let ramp = image::GrayImage::from_fn(4, 4, |x, _| image::Luma([(x * 60) as u8]));
    std::fs::create_dir_all(dir.join("tex")).expect("mkdir");
    ramp.save(dir.join("tex").join("h.png")).expect("png");
    image::RgbImage::from_pixel(2, 2, image::Rgb([120, 130, 250])).save(dir.join("tex").join("n.png")).expect("png");
    image::RgbImage::from_pixel(2, 2, image::Rgb([200, 10, 10])).save(dir.join("tex").join("c.png")).expect("png");
    let mask = image::GrayImage::from_fn(2, 2, |x, _| image::Luma([if x == 0 { 0 } else { 255 }]));
    mask.save(dir.join("tex").join("mask.png")).expect("png");
    write(
        &dir.join("mats").join("scene.mtl"),
        "newmtl a\nKd 1 1 1\nmap_Kd -s 1 1 1 ..\\tex\\c.png\nmap_bump ..\\tex\\h.png\nmap_d ..\\tex\\mask.png\n\
         newmtl b\nKd 1 1 1\nbump -bm 2.0 ..\\tex\\h.png\n\
         newmtl c\nKd 1 1 1\nmap_Bump -bm 1.0 ..\\tex\\n.png\n",
    );
    let p = dir.join("bump.obj");
    write(
        &p,
        "mtllib mats/scene.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n\
         o A\nusemtl a\nf 1/1 2/2 3/3\no B\nusemtl b\nf 1/1 2/2 3/3\no C\nusemtl c\nf 1/1 2/2 3/3\n",
    );
    let s = load_scene(&p).expect("load");
    assert!(!s.warnings.iter().any(|w| w.contains("texture") || w.contains("mask")), "{:?}", s.warnings);
    let mat = |name: &str| s.materials.iter().find(|m| m.name == name).expect("material");
    let tex = |i: Option<usize>| &s.textures[i.expect("texture")];
    // Height ramp along x → normals tilt towards −x, not flat.
    let a = tex(mat("a").normal_tex);
    assert!(!a.srgb && a.width == 4);
    assert!(a.mips[0][4] < 128 && a.mips[0][6] > 128, "height map not converted: {:?}", &a.mips[0][..8]);
    // Larger -bm tilts further.
    let b = tex(mat("b").normal_tex);
    assert!(b.mips[0][4] < a.mips[0][4]);
    // A coloured map is used as a normal map as is.
    assert_eq!(&tex(mat("c").normal_tex).mips[0][..3], &[120, 130, 250]);
    // map_d went into the base colour's alpha.
    let c = tex(mat("a").base_color_tex);
    assert_eq!(mat("a").alpha_mode, AlphaMode::Mask(0.5));
    assert_eq!((&c.mips[0][..4], c.mips[0][7]), (&[200, 10, 10, 0][..], 255));
}

#[test]
fn description_with_builtin_camera_light_and_settings() {
    let dir = tmpdir("desc_ok");
    let p = dir.join("scene.toml");
    write(
        &p,
        r#"builtin = "cornell"
[camera]
position = [0.278, 0.273, -0.5]
target = [0.278, 0.273, 0.0]
fov = 40.0
[[camera_path]]
time = 0.0
position = [0.0, 0.2, -1.0]
target = [0.2, 0.2, 0.2]
[[camera_path]]
time = 2.0
position = [0.5, 0.2, -1.0]
target = [0.2, 0.2, 0.2]
[[lights]]
type = "spot"
position = [0.278, 0.54, 0.28]
direction = [0.0, -1.0, 0.0]
intensity = 2.0
inner_angle_deg = 30.0
outer_angle_deg = 45.0
[settings]
lpv_cascades = 3
gi = true
tonemap = "aces"
exposure = 1.5
"#,
    );
    let s = load_scene(&p).expect("load");
    assert_eq!(s.camera.fov_y_deg, 40.0);
    assert_eq!(s.lights.len(), 1);
    assert!(matches!(s.lights[0], Light::Spot { outer_angle, .. } if (outer_angle - 45f32.to_radians()).abs() < 1e-6));
    assert_eq!(s.settings.get("lpv_cascades").map(String::as_str), Some("3"));
    assert_eq!(s.settings.get("gi").map(String::as_str), Some("true"));
    assert_eq!(s.settings.get("exposure").map(String::as_str), Some("1.5"));
    assert_eq!(s.setting(&[("tonemap".into(), "reinhard".into())], "tonemap"), Some("reinhard"));
    assert_eq!(s.setting(&[], "tonemap"), Some("aces"));
    assert_eq!(s.camera_path.as_ref().map(|p| p.keys.len()), Some(2));
    assert_eq!(s.triangle_count(), cornell_box().triangle_count());
}

#[test]
fn description_with_model_path_relative_to_the_file() {
    let dir = tmpdir("desc_model");
    write(&dir.join("models").join("q.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    let p = dir.join("s.toml");
    write(&p, "model = \"models/q.obj\"\n");
    assert_eq!(load_scene(&p).expect("load").triangle_count(), 2);
}

#[test]
fn description_errors_name_the_file_and_problem() {
    let dir = tmpdir("desc_bad");
    let p = dir.join("unknown.toml");
    write(&p, "builtin = \"cornell\"\nshiny = true\n");
    let msg = load_err(&p, "shiny");
    assert!(msg.contains("unknown.toml:2:"), "no line number: {msg}");
    let p = dir.join("unknown_light.toml");
    write(&p, "builtin = \"cornell\"\n[[lights]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nintensity = 1\nbrightness = 2\n");
    load_err(&p, "brightness");
    let p = dir.join("both.toml");
    write(&p, "builtin = \"cornell\"\nmodel = \"x.obj\"\n");
    load_err(&p, "not both");
    let p = dir.join("builtin.toml");
    write(&p, "builtin = \"sponza\"\n");
    load_err(&p, "sponza");
    let p = dir.join("model.fbx");
    write(&p, "whatever");
    let msg = load_err(&p, "accepted");
    assert!(msg.contains(".gltf") && msg.contains(".glb") && msg.contains(".obj") && msg.contains(".toml"), "{msg}");
    load_err(&dir.join("does_not_exist.toml"), "no such file");
    load_err(&dir.join("does_not_exist.glb"), "no such file");
}

#[test]
fn cornell_box_matches_published_data() {
    let s = cornell_box();
    // Published extents: the ceiling and red wall reach x = 556.0 mm; floor 552.8 mm.
    assert!(approx(s.bounds.min, [0.0, 0.0, 0.0], 1e-3), "{:?}", s.bounds);
    assert!(approx(s.bounds.max, [0.556, 0.5488, 0.5592], 1e-3), "{:?}", s.bounds);
    let names: Vec<&str> = s.meshes.iter().map(|m| m.name.as_str()).collect();
    for n in
        ["floor", "ceiling", "back_wall", "left_wall_red", "right_wall_green", "short_block", "tall_block", "light"]
    {
        assert!(names.contains(&n), "missing {n}: {names:?}");
    }
    // 5 walls + light patch = 6 quads; each block 5 quads (no bottom).
    assert_eq!(s.triangle_count(), 2 * (6 + 5 + 5));
    let centre = glam::Vec3::from(s.bounds.center());
    for m in s.meshes.iter().filter(|m| !m.name.ends_with("block")) {
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let to_centre = centre - glam::Vec3::from(*p);
            assert!(to_centre.dot(glam::Vec3::from(*n)) > 0.0, "{} normal {n:?} faces outwards", m.name);
        }
        check_winding(m);
    }
    for m in s.meshes.iter().filter(|m| m.name.ends_with("block")) {
        let c = glam::Vec3::from(vkengine::scene::Aabb::from_points(&m.positions).center());
        for (p, n) in m.positions.iter().zip(&m.normals) {
            assert!(
                (glam::Vec3::from(*p) - c).dot(glam::Vec3::from(*n)) > 0.0,
                "{} normal {n:?} faces inwards",
                m.name
            );
        }
        check_winding(m);
    }
    let red = &s.materials[s.meshes.iter().find(|m| m.name == "left_wall_red").expect("red wall").material];
    assert_eq!(red.base_color, [0.63, 0.065, 0.05, 1.0]);
    assert!(approx(s.camera.position, [0.278, 0.273, -0.8], 1e-6));
    assert!((s.camera.fov_y_deg - 39.3).abs() < 0.05);
    assert!(matches!(s.lights[0], Light::Spot { direction: [0.0, -1.0, 0.0], .. }));
}

/// Every triangle's geometric normal (counter-clockwise) agrees with its vertex normals.
fn check_winding(m: &Mesh) {
    for t in m.indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| glam::Vec3::from(m.positions[i as usize]));
        let face = (b - a).cross(c - a).normalize();
        for &i in t {
            assert!(
                face.dot(glam::Vec3::from(m.normals[i as usize])) > 0.99,
                "{}: winding disagrees with normal",
                m.name
            );
        }
    }
}

#[test]
fn atrium_has_thin_walls_and_expected_size() {
    let s = atrium();
    let size = s.bounds.size();
    assert!(approx(size, [20.0, 8.0, 20.0], 0.5), "{size:?}");
    let thin = s.meshes.iter().filter(|m| m.name.starts_with("thin_wall")).map(|m| {
        let b = vkengine::scene::Aabb::from_points(&m.positions).size();
        b[0].min(b[2])
    });
    let thinnest = thin.fold(f32::INFINITY, f32::min);
    assert!(thinnest < 0.15 && (thinnest - ATRIUM_THIN_WALL).abs() < 1e-5, "{thinnest}");
    assert!(s.meshes.iter().any(|m| m.name == "thin_wall_courtyard_east"));
    // Distinct floor colours per room.
    let floors: Vec<[f32; 4]> =
        s.meshes.iter().filter(|m| m.name.ends_with("_floor")).map(|m| s.materials[m.material].base_color).collect();
    assert_eq!(floors.len(), 5);
    for i in 0..floors.len() {
        for j in i + 1..floors.len() {
            assert_ne!(floors[i], floors[j]);
        }
    }
    assert!(matches!(s.lights[0], Light::Directional { direction, .. } if direction[1] < 0.0));
    for m in &s.meshes {
        check_winding(m);
    }
}

#[test]
fn add_box_has_outward_normals_and_ccw_winding() {
    let mut m = Mesh::default();
    add_box(&mut m, [1.0, 2.0, 3.0], [2.0, 4.0, 6.0]);
    assert_eq!(m.triangle_count(), 12);
    let c = glam::Vec3::new(1.5, 3.0, 4.5);
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!((glam::Vec3::from(*p) - c).dot(glam::Vec3::from(*n)) > 0.0, "inward normal {n:?} at {p:?}");
        assert!((glam::Vec3::from(*n).length() - 1.0).abs() < 1e-6);
    }
    check_winding(&m);
    assert_eq!(m.uvs.len(), m.positions.len());
    assert_eq!(m.tangents.len(), m.positions.len());
}

fn path() -> CameraPath {
    CameraPath::new(vec![
        CameraKey { time: 0.0, position: [0.0, 0.0, 0.0], target: [0.0, 0.0, -1.0] },
        CameraKey { time: 1.0, position: [1.0, 2.0, 0.0], target: [1.0, 0.0, -1.0] },
        CameraKey { time: 3.0, position: [4.0, 0.0, 1.0], target: [2.0, 0.0, -1.0] },
        CameraKey { time: 3.5, position: [5.0, 1.0, 3.0], target: [3.0, 1.0, -1.0] },
    ])
    .expect("valid path")
}

#[test]
fn camera_path_interpolates_keys_and_is_c1() {
    let lens = Camera {
        position: [0.0; 3],
        target: [0.0, 0.0, -1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 50.0,
        near: 0.1,
        far: 10.0,
    };
    let p = path();
    for k in &p.keys {
        let c = p.at(k.time, &lens);
        assert!(approx(c.position, k.position, 1e-5) && approx(c.target, k.target, 1e-5), "{c:?} vs {k:?}");
        assert_eq!(c.fov_y_deg, 50.0);
    }
    // Clamped at the ends.
    assert_eq!(p.at(-5.0, &lens).position, p.keys[0].position);
    assert_eq!(p.at(99.0, &lens).position, p.keys[3].position);
    // C1: one-sided velocities agree at the interior keys (unevenly spaced in time).
    let h = 1e-3;
    for k in &p.keys[1..3] {
        let at = |t: f32| glam::Vec3::from(p.at(t, &lens).position);
        let left = (at(k.time) - at(k.time - h)) / h;
        let right = (at(k.time + h) - at(k.time)) / h;
        assert!((left - right).length() < 0.05 * left.length().max(1.0), "kink at t={}: {left} vs {right}", k.time);
    }
    // One key: constant.
    let one = CameraPath::new(vec![p.keys[1]]).expect("one key");
    assert_eq!(one.at(0.0, &lens).position, p.keys[1].position);
    assert_eq!(one.at(7.0, &lens).target, p.keys[1].target);
    assert!(CameraPath::new(vec![p.keys[1], p.keys[0]]).is_err());
    assert!(CameraPath::new(vec![]).is_err());
}

#[test]
fn texture_mips_box_average() {
    // 4×2 linear texture: red channel 0..7, other channels fixed.
    let px: Vec<u8> = (0..8u8).flat_map(|i| [i * 10, 100, 200, 255]).collect();
    let t = Texture::from_rgba8("t", 4, 2, false, px);
    assert_eq!(t.mips.len(), 3);
    assert_eq!(t.mips.iter().map(Vec::len).collect::<Vec<_>>(), vec![32, 8, 4]);
    // Level 1 texel 0 averages texels (0,1,4,5) → red (0+10+40+50)/4 = 25.
    assert_eq!(&t.mips[1][..4], &[25, 100, 200, 255]);
    assert_eq!(&t.mips[1][4..], &[45, 100, 200, 255]);
    assert_eq!(&t.mips[2][..], &[35, 100, 200, 255]);
    // sRGB averaging happens in linear light: black + white averages to ~188, not 128.
    let m = build_mips(2, 1, true, vec![0, 0, 0, 255, 255, 255, 255, 255]);
    assert!((186..=190).contains(&m[1][0]), "{:?}", m[1]);
}

#[test]
fn scene_triangle_count_sums_meshes() {
    let mut a = Mesh::default();
    add_box(&mut a, [0.0; 3], [1.0; 3]);
    let b = a.clone();
    let s = Scene::from_parts(vec![a, b], vec![Default::default()], Vec::new());
    assert_eq!(s.triangle_count(), 24);
    assert!(approx(s.bounds.max, [1.0; 3], 0.0));
}

#[test]
fn fuzz_found_obj_mtl_inputs_are_errors_or_expanded_not_panics() {
    // tobj 4 panics on `Kd` with fewer than three numbers and overflows on huge face indices;
    // the loader checks both first (found by fuzz_loaders).
    let dir = tmpdir("obj_fuzz");
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nusemtl a\nf 1//1 2//1 3//1\n";
    let p = dir.join("m.obj");
    write(&p, obj);
    write(&dir.join("m.mtl"), "newmtl a\nKd 0.5\n");
    let s = load_scene(&p).expect("one number is the grey shorthand");
    assert_eq!(s.materials[0].base_color[..3], [0.5, 0.5, 0.5]);
    write(&dir.join("m.mtl"), "newmtl a\nKd 0.2 0.22\n");
    let s = load_scene(&p).expect("a bad material library is a warning");
    assert!(s.warnings.iter().any(|w| w.contains("m.mtl") && w.contains("could not be loaded")), "{:?}", s.warnings);
    write(&p, obj.replace("f 1//1 2//1 3//1", "f 1//1 2//1 3//-6148914691236517206"));
    load_err(&p, "normal index `-6148914691236517206` is out of range (1 defined so far)");
    write(&p, obj.replace("f 1//1 2//1 3//1", "f 1/99999999999999999999 2 3"));
    load_err(&p, "m.obj:7: texture coordinate index `99999999999999999999` is not an integer");
}
