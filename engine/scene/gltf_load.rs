//! glTF 2.0 (`.gltf` with external or embedded buffers, and `.glb`) to a flattened [`Scene`].
//!
//! Buffers and images are resolved here rather than by `gltf::import`, so that a missing or broken
//! texture becomes a warning and a fallback instead of failing the whole load, and so that odd URIs are
//! input errors rather than panics. Triangle strips and fans are converted to lists; points and lines
//! are an error naming the mesh. Sparse accessors are not supported (an error). `BLEND` materials are
//! approximated by an alpha test at 0.5 (with a warning). Only texture coordinate set 0 is read; glTF
//! cameras, lights and animations are ignored.

use std::path::Path;

use glam::Mat4;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::geometry::{fan_to_list, finish_mesh, strip_to_list, transform_mesh};
use super::texture::{decode_bytes, TextureCache, TextureKind};
use super::{blinn_phong_from_metallic_roughness, warn, AlphaMode, Material, Mesh, Scene};
use crate::{Error, Result};

/// Checks what the `gltf` 1.4 crate would panic on (found by `fuzz_loaders`): a GLB header
/// length below the header's own 12 bytes (an unchecked subtraction), and a primitive's
/// `POSITION` accessor index past the accessor list (its validation indexes without a check).
fn precheck(f: &str, bytes: &[u8]) -> Result<()> {
    let bad = |m: String| Error::Input(format!("{f}: not a valid glTF file: {m}"));
    let json = if bytes.starts_with(b"glTF") {
        let len = bytes.get(8..12).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        match len {
            Some(n) if n >= 12 => {}
            Some(n) => return Err(bad(format!("GLB header gives a total length of {n} bytes, less than the header"))),
            // Too short for a header: the crate reports that itself.
            None => return Ok(()),
        }
        match gltf::binary::Glb::from_slice(bytes) {
            Ok(glb) => glb.json.into_owned(),
            Err(_) => return Ok(()),
        }
    } else {
        bytes.to_vec()
    };
    // Unparseable JSON is the crate's to report, with its position.
    let Ok(root) = serde_json::from_slice::<serde_json::Value>(&json) else { return Ok(()) };
    let accessors = root.get("accessors").and_then(|a| a.as_array()).map_or(0, Vec::len);
    let meshes = root.get("meshes").and_then(|m| m.as_array()).map(Vec::as_slice).unwrap_or(&[]);
    for (m, mesh) in meshes.iter().enumerate() {
        let prims = mesh.get("primitives").and_then(|p| p.as_array()).map(Vec::as_slice).unwrap_or(&[]);
        for (p, prim) in prims.iter().enumerate() {
            if let Some(i) = prim.get("attributes").and_then(|a| a.get("POSITION")).and_then(|v| v.as_u64()) {
                if i >= accessors as u64 {
                    return Err(bad(format!(
                        "meshes[{m}].primitives[{p}] POSITION accessor {i} does not exist ({accessors} accessors)"
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Loads a `.gltf` or `.glb` file, baking node transforms into world-space meshes.
pub fn load_gltf(path: &Path) -> Result<Scene> {
    let f = path.display().to_string();
    let bytes = super::read_file(path)?;
    precheck(&f, &bytes)?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| Error::Input(format!("{f}: not a valid glTF file: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let doc = &gltf.document;
    let buffers = load_buffers(&f, doc, base, gltf.blob.clone())?;
    let mut warnings = Vec::new();
    let mut cache = TextureCache::default();

    let mut materials: Vec<Material> =
        doc.materials().map(|m| material(&f, &m, base, &buffers, &mut cache, &mut warnings)).collect();
    let default_material = materials.len();
    materials.push(Material::default());

    let mut meshes = Vec::new();
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            // No scene: every node that is nobody's child is a root.
            let children: std::collections::HashSet<usize> =
                doc.nodes().flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>()).collect();
            doc.nodes().filter(|n| !children.contains(&n.index())).collect()
        }
    };
    let mut stack = Vec::new();
    for node in roots {
        walk(&f, &node, Mat4::IDENTITY, &mut stack, &buffers, default_material, &mut meshes, &mut warnings)?;
    }
    if meshes.is_empty() {
        return Err(Error::Input(format!("{f}: the scene contains no triangle meshes")));
    }
    let mut scene = Scene::from_parts(meshes, materials, cache.into_textures());
    scene.warnings = warnings;
    Ok(scene)
}

#[allow(clippy::too_many_arguments)]
fn walk(
    f: &str,
    node: &gltf::Node,
    parent: Mat4,
    stack: &mut Vec<usize>,
    buffers: &[Vec<u8>],
    default_material: usize,
    meshes: &mut Vec<Mesh>,
    warnings: &mut Vec<String>,
) -> Result<()> {
    if stack.contains(&node.index()) {
        return Err(Error::Input(format!("{f}: node {} is its own ancestor (cyclic node hierarchy)", node.index())));
    }
    let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
    if !world.is_finite() {
        return Err(Error::Input(format!("{f}: node {} has a non-finite transform", node.index())));
    }
    if let Some(mesh) = node.mesh() {
        let name = mesh.name().map(str::to_string).unwrap_or_else(|| format!("mesh{}", mesh.index()));
        for prim in mesh.primitives() {
            let mut m = primitive(f, &name, &prim, buffers)?;
            m.material = prim.material().index().unwrap_or(default_material);
            finish_mesh(Path::new(f), &mut m, warnings)?;
            transform_mesh(&mut m, world);
            meshes.push(m);
        }
    }
    stack.push(node.index());
    for child in node.children() {
        walk(f, &child, world, stack, buffers, default_material, meshes, warnings)?;
    }
    stack.pop();
    Ok(())
}

fn primitive(f: &str, mesh_name: &str, prim: &gltf::Primitive, buffers: &[Vec<u8>]) -> Result<Mesh> {
    let name = format!("{mesh_name}#{}", prim.index());
    let err = |what: String| Error::Input(format!("{f}: mesh `{name}`: {what}"));
    let mode = prim.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Err(err(format!("primitive mode {mode:?} is not supported (only triangles, strips and fans)")));
    }
    let f32only = &[DataType::F32][..];
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let missing = |what: &str| err(format!("{what} accessor data lies outside its buffer"));

    let pos_acc = prim.get(&gltf::Semantic::Positions).ok_or_else(|| err("no POSITION attribute".into()))?;
    check_accessor(&pos_acc, &[Dimensions::Vec3], f32only).map_err(|e| err(format!("POSITION {e}")))?;
    let positions: Vec<[f32; 3]> = reader.read_positions().ok_or_else(|| missing("POSITION"))?.collect();
    let n = positions.len();

    let mut normals = Vec::new();
    if let Some(acc) = prim.get(&gltf::Semantic::Normals) {
        check_accessor(&acc, &[Dimensions::Vec3], f32only).map_err(|e| err(format!("NORMAL {e}")))?;
        normals = reader.read_normals().ok_or_else(|| missing("NORMAL"))?.collect();
    }
    let mut tangents = Vec::new();
    if let Some(acc) = prim.get(&gltf::Semantic::Tangents) {
        check_accessor(&acc, &[Dimensions::Vec4], f32only).map_err(|e| err(format!("TANGENT {e}")))?;
        tangents = reader.read_tangents().ok_or_else(|| missing("TANGENT"))?.collect();
    }
    let mut uvs = Vec::new();
    if let Some(acc) = prim.get(&gltf::Semantic::TexCoords(0)) {
        check_accessor(&acc, &[Dimensions::Vec2], &[DataType::F32, DataType::U8, DataType::U16])
            .map_err(|e| err(format!("TEXCOORD_0 {e}")))?;
        uvs = reader.read_tex_coords(0).ok_or_else(|| missing("TEXCOORD_0"))?.into_f32().collect();
    }
    let raw_indices: Vec<u32> = match prim.indices() {
        Some(acc) => {
            check_accessor(&acc, &[Dimensions::Scalar], &[DataType::U8, DataType::U16, DataType::U32])
                .map_err(|e| err(format!("index {e}")))?;
            reader.read_indices().ok_or_else(|| missing("index"))?.into_u32().collect()
        }
        None => (0..n as u32).collect(),
    };
    let indices = match mode {
        Mode::TriangleStrip => strip_to_list(&raw_indices),
        Mode::TriangleFan => fan_to_list(&raw_indices),
        _ => raw_indices,
    };
    Ok(Mesh { name, positions, normals, uvs, tangents, indices, material: 0 })
}

/// Checks what `gltf`'s reader would otherwise assert on or overflow with: type, count, stride, range.
fn check_accessor(acc: &gltf::Accessor, dims: &[Dimensions], types: &[DataType]) -> Result<(), String> {
    if !dims.contains(&acc.dimensions()) || !types.contains(&acc.data_type()) {
        return Err(format!("accessor {} has type {:?} {:?}", acc.index(), acc.dimensions(), acc.data_type()));
    }
    if acc.sparse().is_some() {
        return Err(format!("accessor {} is sparse, which is not supported", acc.index()));
    }
    if acc.count() == 0 {
        return Err(format!("accessor {} has count 0", acc.index()));
    }
    let Some(view) = acc.view() else {
        return Err(format!("accessor {} has no buffer view", acc.index()));
    };
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(format!(
            "accessor {}: byte stride {stride} is smaller than its element ({elem} bytes)",
            acc.index()
        ));
    }
    let end = (acc.count() - 1).checked_mul(stride).and_then(|v| v.checked_add(elem)?.checked_add(acc.offset()));
    if !matches!(end, Some(end) if end <= view.length()) {
        return Err(format!("accessor {} runs past the end of buffer view {}", acc.index(), view.index()));
    }
    // The reader adds these unchecked; the buffer's own length was checked against its data on load.
    match view.offset().checked_add(view.length()) {
        Some(end) if end <= view.buffer().length() => Ok(()),
        _ => Err(format!("buffer view {} runs past the end of buffer {}", view.index(), view.buffer().index())),
    }
}

fn load_buffers(f: &str, doc: &gltf::Document, base: &Path, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| Error::Input(format!("{f}: buffer {} refers to a missing GLB chunk", buffer.index())))?,
            gltf::buffer::Source::Uri(uri) => {
                read_uri(base, uri).map_err(|e| Error::Input(format!("{f}: buffer {}: {e}", buffer.index())))?
            }
        };
        if data.len() < buffer.length() {
            return Err(Error::Input(format!(
                "{f}: buffer {} holds {} bytes but declares byteLength {}",
                buffer.index(),
                data.len(),
                buffer.length()
            )));
        }
        out.push(data);
    }
    Ok(out)
}

fn material(
    f: &str,
    m: &gltf::Material,
    base: &Path,
    buffers: &[Vec<u8>],
    cache: &mut TextureCache,
    warnings: &mut Vec<String>,
) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let mut tex = |t: gltf::Texture, kind: TextureKind| {
        let img = t.source();
        match img.source() {
            gltf::image::Source::View { view, .. } => {
                let key = format!("{f}#image{}", img.index());
                let bytes = buffers
                    .get(view.buffer().index())
                    .and_then(|b| b.get(view.offset()..view.offset().checked_add(view.length())?));
                cache.get(&key, kind, warnings, f, || match bytes {
                    Some(b) => decode_bytes(b),
                    None => Err("buffer view out of range".into()),
                })
            }
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                let key = format!("{f}#image{}", img.index());
                cache.get(&key, kind, warnings, f, || read_uri(base, uri).and_then(|b| decode_bytes(&b)))
            }
            gltf::image::Source::Uri { uri, .. } => match percent_decode(uri) {
                Ok(rel) => cache.file(f, &base.join(rel), kind, warnings),
                Err(e) => cache.get(uri, kind, warnings, f, || Err(e)),
            },
        }
    };
    let base_color_tex = pbr.base_color_texture().map(|i| tex(i.texture(), TextureKind::Color));
    let metallic_roughness_tex = pbr.metallic_roughness_texture().map(|i| tex(i.texture(), TextureKind::Linear));
    let normal_tex = m.normal_texture().map(|i| tex(i.texture(), TextureKind::Normal));
    let base_color = pbr.base_color_factor();
    let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
    let (specular, shininess) =
        blinn_phong_from_metallic_roughness([base_color[0], base_color[1], base_color[2]], metallic, roughness);
    let name = m.name().map(str::to_string).unwrap_or_else(|| format!("material{}", m.index().unwrap_or(0)));
    let alpha_mode = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
        gltf::material::AlphaMode::Blend => {
            warn(warnings, format!("{f}: material `{name}` uses BLEND; approximated by an alpha test at 0.5"));
            AlphaMode::Mask(0.5)
        }
    };
    Material {
        name,
        base_color,
        base_color_tex,
        normal_tex,
        specular,
        shininess,
        specular_tex: None,
        metallic_roughness_tex,
        metallic,
        roughness,
        alpha_mode,
        emissive: m.emissive_factor(),
        translucency: m.transmission().map_or(0.0, |t| t.transmission_factor().clamp(0.0, 1.0)),
        double_sided: m.double_sided(),
    }
}

/// Reads a `data:` URI (base64 only) or a path relative to `base`.
fn read_uri(base: &Path, uri: &str) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest.split_once(";base64,").ok_or("data URI is not base64")?;
        return base64_decode(payload);
    }
    if uri.contains("://") {
        return Err(format!("URI `{uri}` is not a relative file path"));
    }
    let path = base.join(percent_decode(uri)?);
    std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))
}

fn percent_decode(uri: &str) -> Result<String, String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
            let v = hex.and_then(|h| u8::from_str_radix(h, 16).ok()).ok_or(format!("bad %-escape in URI `{uri}`"))?;
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("URI `{uri}` is not UTF-8 after %-decoding"))
}

/// Standard base64 with optional padding; whitespace is skipped.
fn base64_decode(s: &str) -> Result<Vec<u8>, String> {
    let val = |c: u8| -> Result<u32, String> {
        Ok(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return Err(format!("invalid base64 character `{}`", c as char)),
        } as u32)
    };
    let digits: Vec<u8> = s.bytes().filter(|c| !c.is_ascii_whitespace()).collect();
    let digits = digits.strip_suffix(&b"=="[..]).or_else(|| digits.strip_suffix(&b"="[..])).unwrap_or(&digits);
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        if chunk.len() == 1 {
            return Err("truncated base64 data".into());
        }
        let mut acc = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * k);
        }
        out.extend_from_slice(&acc.to_be_bytes()[1..chunk.len()]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_known_strings() {
        assert_eq!(base64_decode("aGVsbG8=").as_deref(), Ok(&b"hello"[..]));
        assert_eq!(base64_decode("aGVsbG8h").as_deref(), Ok(&b"hello!"[..]));
        assert_eq!(base64_decode("aGk=").as_deref(), Ok(&b"hi"[..]));
        assert!(base64_decode("a*==").is_err());
        assert_eq!(percent_decode("a%20b.png").as_deref(), Ok("a b.png"));
        assert!(percent_decode("%ff%fe").is_err());
    }
}
