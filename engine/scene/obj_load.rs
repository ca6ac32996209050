//! Wavefront OBJ + MTL to a [`Scene`] via `tobj` (triangulated, single index).
//!
//! MTL mapping: `Kd` → base colour, `d` → alpha, `Ks`/`Ns` → Blinn–Phong specular/shininess (roughness
//! derived from `Ns` by [`roughness_from_shininess`]), `Ke` → emissive, `map_Kd` → base colour texture,
//! `map_Ks` → specular texture, `map_d` → merged into the base colour texture's alpha with an alpha test
//! at 0.5, and `norm`/`map_Bump`/`map_bump`/`bump` → normal map. Bump maps that are greyscale are height
//! maps and are converted to normal maps on load (Sobel, scaled by `-bm`); coloured ones are used as
//! normal maps. Texture options (`-bm 1.0`, `-s u v w`, ...) are skipped, backslashes become slashes, and
//! paths are relative to the MTL file's directory. A missing MTL is a warning and a grey default material.
//! OBJ `v` runs bottom-up, so it is flipped to the top-left origin used everywhere else.

use std::path::{Path, PathBuf};

use super::geometry::finish_mesh;
use super::texture::{TextureCache, TextureKind};
use super::{roughness_from_shininess, warn, AlphaMode, Material, Mesh, Scene};
use crate::{Error, Result};

/// Checks every `f`/`l`/`p` index against the `v`/`vt`/`vn` counts so far (negative indices
/// count back from the last one): tobj 4 multiplies texture and normal indices unchecked, which
/// overflows on huge ones (found by `fuzz_loaders`).
fn check_face_indices(f: &str, text: &[u8]) -> Result<()> {
    let mut counts = [0i64; 3];
    for (n, line) in String::from_utf8_lossy(text).lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f" | "l" | "p") => {
                for vertex in words {
                    for (k, idx) in vertex.split('/').take(3).enumerate() {
                        if idx.is_empty() {
                            continue;
                        }
                        let what = ["vertex", "texture coordinate", "normal"][k];
                        let bad = |why: &str| Error::Input(format!("{f}:{}: {what} index `{idx}` {why}", n + 1));
                        let i: i64 = idx.parse().map_err(|_| bad("is not an integer"))?;
                        if i == 0 || i > counts[k] || -i > counts[k] {
                            return Err(bad(&format!("is out of range ({} defined so far)", counts[k])));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Loads an MTL file for tobj after checking what tobj 4 does not: its `Ka`/`Kd`/`Ks`/`Ke`
/// parser panics on fewer than three numbers (found by `fuzz_loaders`). One number is the MTL
/// shorthand for grey (`Kd 0.5` = `Kd 0.5 0.5 0.5`) and is expanded; two are a parse error, which
/// the caller reports like any unreadable material library.
fn load_mtl_checked(path: &Path) -> tobj::MTLLoadResult {
    let text = std::fs::read(path).map_err(|_| tobj::LoadError::OpenFileFailed)?;
    let text = String::from_utf8_lossy(&text);
    let mut fixed = String::with_capacity(text.len());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let key = words.next();
        let args: Vec<&str> = words.collect();
        match key {
            Some(k @ ("Ka" | "Kd" | "Ks" | "Ke")) if args.len() < 3 => match args.as_slice() {
                [v] => fixed.push_str(&format!("{k} {v} {v} {v}")),
                _ => return Err(tobj::LoadError::MaterialParseError),
            },
            _ => fixed.push_str(line),
        }
        fixed.push('\n');
    }
    tobj::load_mtl_buf(&mut fixed.as_bytes())
}

/// Loads an `.obj` file and the material libraries it names.
pub fn load_obj(path: &Path) -> Result<Scene> {
    let f = path.display().to_string();
    // Read once up front so a missing file is reported like every other loader reports it.
    let text = super::read_file(path)?;
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    check_face_indices(&f, &text)?;
    let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    // tobj's own load_obj, with the MTL checked first (see `load_mtl_checked`).
    let (models, mtl_result) =
        tobj::load_obj_buf(&mut text.as_slice(), &opts, |mat| load_mtl_checked(&base_dir.join(mat)))
            .map_err(|e| Error::Input(format!("{f}: cannot parse OBJ: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mtllib = String::from_utf8_lossy(&text)
        .lines()
        .find_map(|l| l.trim().strip_prefix("mtllib").map(|r| r.trim().replace('\\', "/")))
        .filter(|s| !s.is_empty());
    let mtl_path = mtllib.as_ref().map(|m| base.join(m));
    let mtl_dir = mtl_path.as_ref().and_then(|p| p.parent()).unwrap_or(base).to_path_buf();

    let mut warnings = Vec::new();
    let mut cache = TextureCache::default();
    let mut materials = match mtl_result {
        Ok(mats) => {
            let ctx = mtl_path.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| f.clone());
            mats.iter().map(|m| material(&ctx, m, &mtl_dir, &mut cache, &mut warnings)).collect()
        }
        Err(e) => {
            let lib = mtl_path.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "(unnamed)".into());
            warn(&mut warnings, format!("{f}: material library {lib} could not be loaded ({e}); using a grey default"));
            Vec::new()
        }
    };
    let default_material = materials.len();
    materials.push(Material::default());

    let mut meshes = Vec::new();
    for model in models {
        let m = &model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let mut mesh = Mesh {
            name: model.name.clone(),
            positions: m.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
            normals: m.normals.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
            uvs: m.texcoords.chunks_exact(2).map(|t| [t[0], 1.0 - t[1]]).collect(),
            tangents: Vec::new(),
            indices: m.indices.clone(),
            material: m.material_id.filter(|&i| i < default_material).unwrap_or(default_material),
        };
        finish_mesh(path, &mut mesh, &mut warnings)?;
        meshes.push(mesh);
    }
    if meshes.is_empty() {
        return Err(Error::Input(format!("{f}: the file contains no faces")));
    }
    let mut scene = Scene::from_parts(meshes, materials, cache.into_textures());
    scene.warnings = warnings;
    Ok(scene)
}

fn material(
    ctx: &str,
    m: &tobj::Material,
    dir: &Path,
    cache: &mut TextureCache,
    warnings: &mut Vec<String>,
) -> Material {
    let kd = m.diffuse.unwrap_or([0.7; 3]);
    let alpha = m.dissolve.unwrap_or(1.0).clamp(0.0, 1.0);
    let shininess = m.shininess.unwrap_or(16.0).clamp(1.0, 4096.0);
    let tex_path = |s: &Option<String>| s.as_deref().and_then(parse_map).map(|(p, bm)| (dir.join(p), bm));
    let diffuse = tex_path(&m.diffuse_texture);
    let mask = tex_path(&m.dissolve_texture);
    let (base_color_tex, alpha_mode) = match &mask {
        Some((mask, _)) => match cache.color_with_mask(ctx, diffuse.as_ref().map(|d| d.0.as_path()), mask, warnings) {
            Some(i) => (Some(i), AlphaMode::Mask(0.5)),
            None => {
                (diffuse.as_ref().map(|(p, _)| cache.file(ctx, p, TextureKind::Color, warnings)), AlphaMode::Opaque)
            }
        },
        None => (diffuse.as_ref().map(|(p, _)| cache.file(ctx, p, TextureKind::Color, warnings)), AlphaMode::Opaque),
    };
    let specular_tex = tex_path(&m.specular_texture).map(|(p, _)| cache.file(ctx, &p, TextureKind::Color, warnings));
    // tobj keeps `norm` among the unknown parameters; it is the explicit normal-map statement.
    let normal_tex = match m.unknown_param.get("norm").and_then(|s| parse_map(s)) {
        Some((p, _)) => Some(cache.file(ctx, &dir.join(p), TextureKind::Normal, warnings)),
        None => tex_path(&m.normal_texture).map(|(p, bm)| cache.file(ctx, &p, TextureKind::Bump(bm), warnings)),
    };
    Material {
        name: m.name.clone(),
        base_color: [kd[0], kd[1], kd[2], alpha],
        base_color_tex,
        normal_tex,
        specular: m.specular.unwrap_or([0.0; 3]),
        shininess,
        specular_tex,
        metallic_roughness_tex: None,
        metallic: 0.0,
        roughness: roughness_from_shininess(shininess),
        alpha_mode,
        emissive: m.emissive.unwrap_or([0.0; 3]),
        translucency: 0.0,
        double_sided: false,
    }
}

/// Splits an MTL texture statement's arguments into the file path (backslashes normalised, spaces
/// kept) and the `-bm` bump multiplier (1 if absent), skipping every other option and its values.
pub fn parse_map(args: &str) -> Option<(PathBuf, f32)> {
    let words: Vec<&str> = args.split_whitespace().collect();
    let mut bm = 1.0;
    let mut i = 0;
    while i < words.len() && words[i].starts_with('-') && words[i].len() > 1 {
        let nargs = match words[i] {
            "-bm" => {
                bm = words.get(i + 1).and_then(|v| v.parse().ok()).unwrap_or(1.0);
                1
            }
            "-o" | "-s" | "-t" => {
                // One to three numbers follow.
                words[i + 1..].iter().take(3).take_while(|w| w.parse::<f32>().is_ok()).count()
            }
            "-mm" => 2,
            _ => 1, // -blendu/-blendv/-boost/-texres/-clamp/-cc/-imfchan/-type take one value
        };
        i += 1 + nargs;
    }
    let rest = words.get(i..)?.join(" ");
    (!rest.is_empty()).then(|| (PathBuf::from(rest.replace('\\', "/")), bm))
}
