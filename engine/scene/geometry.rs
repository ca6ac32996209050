//! Mesh validation, normal/tangent generation, transforms and box/quad builders shared by every loader.

use std::path::Path;

use glam::{Mat3, Mat4, Vec2, Vec3};

use super::{warn, Mesh};
use crate::{Error, Result};

/// Checks a loaded mesh and fills in what is missing, in the mesh's own space.
///
/// Errors (naming `file` and the mesh): index count not a multiple of 3, an index out of range, a
/// non-finite position, or attribute arrays whose length differs from the positions'. Missing or unusable
/// normals are generated (area-weighted, with a warning), missing UVs become zeros, missing tangents are
/// generated from the UVs.
pub fn finish_mesh(file: &Path, mesh: &mut Mesh, warnings: &mut Vec<String>) -> Result<()> {
    let f = file.display();
    let n = mesh.positions.len();
    let bad = |what: String| Error::Input(format!("{f}: mesh `{}`: {what}", mesh.name));
    if !mesh.indices.len().is_multiple_of(3) {
        return Err(bad(format!("{} indices is not a whole number of triangles", mesh.indices.len())));
    }
    if let Some((i, &v)) = mesh.indices.iter().enumerate().find(|(_, &v)| v as usize >= n) {
        return Err(bad(format!("index {v} at position {i} is out of range ({n} vertices)")));
    }
    if let Some(i) = mesh.positions.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        let p = mesh.positions[i];
        let kind = if p.iter().any(|c| c.is_nan()) { "NaN" } else { "infinite" };
        return Err(bad(format!("vertex {i} has a {kind} position {p:?}")));
    }
    for (what, len) in [("normals", mesh.normals.len()), ("uvs", mesh.uvs.len()), ("tangents", mesh.tangents.len())] {
        if len != 0 && len != n {
            return Err(bad(format!("{len} {what} for {n} vertices")));
        }
    }
    if mesh.uvs.iter().any(|t| t.iter().any(|c| !c.is_finite())) {
        return Err(bad("non-finite texture coordinate".into()));
    }
    let normals_ok = !mesh.normals.is_empty() && mesh.normals.iter().all(|v| unit_or_none(*v).is_some());
    if !normals_ok {
        let why = if mesh.normals.is_empty() { "no normals" } else { "zero or non-finite normals" };
        warn(warnings, format!("{f}: mesh `{}` has {why}; generated smooth normals", mesh.name));
        mesh.normals = generate_normals(&mesh.positions, &mesh.indices);
    } else {
        // Files often store slightly denormalised normals; shaders assume unit length.
        for v in &mut mesh.normals {
            *v = unit_or_none(*v).unwrap_or([0.0, 1.0, 0.0]);
        }
    }
    if mesh.uvs.is_empty() {
        mesh.uvs = vec![[0.0; 2]; n];
    }
    let tangents_ok = !mesh.tangents.is_empty() && mesh.tangents.iter().all(|t| t.iter().all(|c| c.is_finite()));
    if !tangents_ok {
        mesh.tangents = generate_tangents(&mesh.positions, &mesh.normals, &mesh.uvs, &mesh.indices);
    }
    Ok(())
}

fn unit_or_none(v: [f32; 3]) -> Option<[f32; 3]> {
    let v = Vec3::from(v);
    let l = v.length();
    (l.is_finite() && l > 1e-12).then(|| (v / l).into())
}

/// Area-weighted smooth vertex normals (the unnormalised face cross product weights each face by its
/// area); vertices touching only degenerate faces get +Y.
pub fn generate_normals(positions: &[[f32; 3]], indices: &[u32]) -> Vec<[f32; 3]> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(positions[i as usize]));
        let n = (b - a).cross(c - a);
        for &i in t {
            acc[i as usize] += n;
        }
    }
    acc.into_iter().map(|n| n.try_normalize().unwrap_or(Vec3::Y).into()).collect()
}

/// Per-vertex tangents by accumulating each triangle's UV-derived tangent frame (MikkTSpace-lite), then
/// Gram–Schmidt against the normal. Without usable UVs an arbitrary perpendicular is chosen.
pub fn generate_tangents(
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    uvs: &[[f32; 2]],
    indices: &[u32],
) -> Vec<[f32; 4]> {
    let mut tan = vec![Vec3::ZERO; positions.len()];
    let mut bit = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [i0, i1, i2] = [t[0], t[1], t[2]].map(|i| i as usize);
        let [p0, p1, p2] = [i0, i1, i2].map(|i| Vec3::from(positions[i]));
        let [w0, w1, w2] = [i0, i1, i2].map(|i| Vec2::from(uvs[i]));
        let (e1, e2) = (p1 - p0, p2 - p0);
        let (d1, d2) = (w1 - w0, w2 - w0);
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-20 {
            continue;
        }
        let r = 1.0 / det;
        let tv = (e1 * d2.y - e2 * d1.y) * r;
        let bv = (e2 * d1.x - e1 * d2.x) * r;
        if !(tv.is_finite() && bv.is_finite()) {
            continue;
        }
        for i in [i0, i1, i2] {
            tan[i] += tv;
            bit[i] += bv;
        }
    }
    (0..positions.len())
        .map(|i| {
            let n = Vec3::from(normals[i]);
            let t = (tan[i] - n * n.dot(tan[i])).try_normalize().unwrap_or_else(|| n.any_orthonormal_vector());
            let w = if n.cross(t).dot(bit[i]) < 0.0 { -1.0 } else { 1.0 };
            [t.x, t.y, t.z, w]
        })
        .collect()
}

/// Applies a world matrix: positions by `m`, normals by its inverse transpose, tangents by its upper 3×3;
/// a mirroring matrix (det < 0) flips the winding and the bitangent sign so front faces stay front.
pub fn transform_mesh(mesh: &mut Mesh, m: Mat4) {
    if m == Mat4::IDENTITY {
        return;
    }
    let m3 = Mat3::from_mat4(m);
    let nm = m3.inverse().transpose();
    for p in &mut mesh.positions {
        *p = m.transform_point3(Vec3::from(*p)).into();
    }
    for n in &mut mesh.normals {
        *n = (nm * Vec3::from(*n)).try_normalize().unwrap_or(Vec3::Y).into();
    }
    let flip = m3.determinant() < 0.0;
    for t in &mut mesh.tangents {
        let v = (m3 * Vec3::new(t[0], t[1], t[2])).try_normalize().unwrap_or(Vec3::X);
        *t = [v.x, v.y, v.z, if flip { -t[3] } else { t[3] }];
    }
    if flip {
        for tri in mesh.indices.chunks_exact_mut(3) {
            tri.swap(1, 2);
        }
    }
}

/// Triangle-strip indices as a list; every other triangle is flipped to keep a consistent winding.
pub fn strip_to_list(strip: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(strip.len().saturating_sub(2) * 3);
    for (i, w) in strip.windows(3).enumerate() {
        if i % 2 == 0 {
            out.extend_from_slice(&[w[0], w[1], w[2]]);
        } else {
            out.extend_from_slice(&[w[1], w[0], w[2]]);
        }
    }
    out
}

/// Triangle-fan indices as a list.
pub fn fan_to_list(fan: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(fan.len().saturating_sub(2) * 3);
    if let Some(&c) = fan.first() {
        for w in fan[1..].windows(2) {
            out.extend_from_slice(&[c, w[0], w[1]]);
        }
    }
    out
}

/// Appends a flat quad `a b c d` (counter-clockwise seen from the side the normal points to, normal
/// `normalize((b − a) × (c − a))`), as two triangles with four vertices of their own.
pub fn add_quad(mesh: &mut Mesh, corners: [[f32; 3]; 4]) {
    let [a, b, c, d] = corners.map(Vec3::from);
    let n = (b - a).cross(c - a).try_normalize().unwrap_or(Vec3::Y);
    let u = (b - a).try_normalize().unwrap_or_else(|| n.any_orthonormal_vector());
    let base = mesh.positions.len() as u32;
    // UVs in metres along the quad's first edge and its perpendicular, so tiled textures keep their scale.
    let v_axis = n.cross(u);
    for p in [a, b, c, d] {
        mesh.positions.push(p.into());
        mesh.normals.push(n.into());
        mesh.uvs.push([(p - a).dot(u), (p - a).dot(v_axis)]);
        mesh.tangents.push([u.x, u.y, u.z, 1.0]);
    }
    mesh.indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// Appends an axis-aligned box between `min` and `max` with outward normals (six quads, 12 triangles).
pub fn add_box(mesh: &mut Mesh, min: [f32; 3], max: [f32; 3]) {
    let [x0, y0, z0] = min;
    let [x1, y1, z1] = max;
    let quads = [
        [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]], // +x
        [[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]], // -x
        [[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]], // +y
        [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]], // -y
        [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], // +z
        [[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]], // -z
    ];
    for q in quads {
        add_quad(mesh, q);
    }
}
