//! A loaded scene on the GPU: one interleaved vertex buffer, one index buffer, a draw per mesh,
//! mipmapped material textures (plus fallbacks, so every draw binds the same slots) and lights.

use crate::scene::{AlphaMode, Light, Scene};
use crate::vk::{vk, Buffer, Context, Image, ImageInfo};
use crate::{Error, Result};
use glam::Vec3;

/// Floats per vertex: position 3, normal 3, uv 2, tangent 4.
pub const VERTEX_FLOATS: usize = 12;
/// Texture slot of the white fallback (colour and specular maps).
pub const WHITE: usize = 0;
/// Texture slot of the flat fallback normal map.
pub const FLAT_NORMAL: usize = 1;

/// Bytes per vertex of [`GpuScene::positions`]: (x, y, z, 1) as f32.
pub const POSITION_BYTES: u32 = 16;

/// Triangles per culling chunk (mesh/cull.comp: a workgroup each, its survivors one indirect
/// draw): small enough that a view keeps little it cannot see, large enough that llvmpipe's cost
/// per draw stays small against the triangles' (~142 draws a view for Sibenik's 72k triangles).
pub const CULL_CHUNK: u32 = 512;

/// One indexed draw.
#[derive(Clone, Copy, Debug)]
pub struct Draw {
    /// First index in the index buffer.
    pub first_index: u32,
    /// Index count.
    pub index_count: u32,
    /// Material slot.
    pub material: usize,
    /// First of the mesh's culling chunks ([`GpuScene::chunks`]).
    pub first_chunk: u32,
    /// Its chunks: ⌈triangles / [`CULL_CHUNK`]⌉.
    pub chunk_count: u32,
}

/// [`GpuMaterial::flags`] bit of alpha-masked materials (shaders discard below the cutoff).
pub const FLAG_ALPHA_MASK: u32 = 1;
/// [`GpuMaterial::flags`] bit of materials with a normal map.
pub const FLAG_NORMAL_MAP: u32 = 2;

/// A material as the raster passes use it; texture fields index [`GpuScene::textures`].
#[derive(Clone, Copy, Debug)]
pub struct GpuMaterial {
    /// Linear base colour and alpha.
    pub base_color: [f32; 4],
    /// Specular colour and shininess.
    pub specular: [f32; 4],
    /// Base-colour texture.
    pub base_color_tex: usize,
    /// Normal map.
    pub normal_tex: usize,
    /// Specular map.
    pub specular_tex: usize,
    /// Shader flags: bit0 alpha mask, bit1 normal map.
    pub flags: u32,
    /// Alpha-mask cutoff.
    pub cutoff: f32,
    /// Fraction of incident light entering the surface (subsurface LPV).
    pub translucency: f32,
    /// Drawn from both sides (otherwise back faces are culled when culling is on).
    pub double_sided: bool,
}

/// The sun: direction towards it and irradiance.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Sun {
    /// Unit vector towards the sun.
    pub to_sun: [f32; 3],
    /// Irradiance on a surface facing the sun (W/m², RGB).
    pub irradiance: [f32; 3],
}

/// A spot light.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Spot {
    /// Position.
    pub position: [f32; 3],
    /// Unit direction the light travels.
    pub direction: [f32; 3],
    /// Radiant intensity (W/sr, RGB).
    pub intensity: [f32; 3],
    /// Inner and outer cone half-angles (radians).
    pub angles: [f32; 2],
    /// Range (shadow far plane).
    pub range: f32,
}

/// GPU copy of a [`Scene`].
pub struct GpuScene {
    /// Interleaved vertices ([`VERTEX_FLOATS`] floats each).
    pub vertices: Buffer,
    /// 32-bit indices.
    pub indices: Buffer,
    /// Vertex positions alone as (x, y, z, 1): culling reads one texel per vertex instead of
    /// three (mesh/cull.comp), opaque depth draws a third of the interleaved vertices' bytes.
    pub positions: Buffer,
    /// Culling chunks of [`CULL_CHUNK`] triangles of one mesh, in draw order: per chunk its
    /// first index, triangles, 1 if back faces may be culled (single-sided material), 0; then
    /// its triangles' bounding box, minimum and maximum corner as (x, y, z, 0) floats.
    pub chunks: Buffer,
    /// Chunks in [`GpuScene::chunks`].
    pub chunk_count: u32,
    /// One draw per mesh.
    pub draws: Vec<Draw>,
    /// Materials.
    pub materials: Vec<GpuMaterial>,
    /// Textures: [`WHITE`], [`FLAT_NORMAL`], then the scene's in order.
    pub textures: Vec<Image>,
    /// World bounds (min, max).
    pub bounds: [Vec3; 2],
    /// The first directional light, if any.
    pub sun: Option<Sun>,
    /// Spot lights.
    pub spots: Vec<Spot>,
    /// Triangle count.
    pub triangles: usize,
    /// Whether any material lets light in (the subsurface LPV has something to carry).
    pub translucent: bool,
    /// Unique per upload: what a cached LPV was computed from (an address could be reused).
    pub id: u64,
}

static NEXT_SCENE_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

fn texture_image(ctx: &Context, name: &str, w: u32, h: u32, srgb: bool, mips: &[Vec<u8>]) -> Result<Image> {
    let format = if srgb { vk::Format::R8G8B8A8_SRGB } else { vk::Format::R8G8B8A8_UNORM };
    let mut info = ImageInfo::d2(format, w, h, vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST);
    info.mip_levels = mips.len().max(1) as u32;
    let img = Image::new(ctx, name, info)?;
    let bytes: Vec<u8> = mips.concat();
    ctx.upload_image(
        &img,
        &bytes,
        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        vk::PipelineStageFlags2::FRAGMENT_SHADER,
        vk::AccessFlags2::SHADER_SAMPLED_READ,
    )?;
    Ok(img)
}

impl GpuScene {
    /// Uploads `scene`. Scenes are validated by their loaders; this only checks GPU limits.
    pub fn upload(ctx: &Context, scene: &Scene) -> Result<Self> {
        let mut vertices: Vec<f32> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut draws: Vec<Draw> = Vec::new();
        let mut chunks: Vec<[u32; 12]> = Vec::new();
        for mesh in &scene.meshes {
            let base = (vertices.len() / VERTEX_FLOATS) as u64;
            if base + mesh.positions.len() as u64 > u32::MAX as u64 {
                return Err(Error::Input(format!("scene `{}`: more than 2^32 vertices", mesh.name)));
            }
            for i in 0..mesh.positions.len() {
                vertices.extend(mesh.positions[i]);
                vertices.extend(mesh.normals.get(i).copied().unwrap_or([0.0, 1.0, 0.0]));
                vertices.extend(mesh.uvs.get(i).copied().unwrap_or([0.0; 2]));
                vertices.extend(mesh.tangents.get(i).copied().unwrap_or([0.0; 4]));
            }
            let first_index = indices.len() as u32;
            indices.extend(mesh.indices.iter().map(|&i| i + base as u32));
            let index_count = mesh.indices.len() as u32;
            let single_sided = scene.materials.get(mesh.material).is_some_and(|m| !m.double_sided);
            let first_chunk = chunks.len() as u32;
            for t in (0..index_count / 3).step_by(CULL_CHUNK as usize) {
                let triangles = (index_count / 3 - t).min(CULL_CHUNK);
                let corners = mesh.indices[3 * t as usize..3 * (t + triangles) as usize]
                    .iter()
                    .filter_map(|&i| mesh.positions.get(i as usize))
                    .fold([[f32::MAX; 3], [f32::MIN; 3]], |[lo, hi], p| {
                        [std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k]))]
                    });
                let [lo, hi] = corners.map(|c| c.map(f32::to_bits));
                #[rustfmt::skip]
                let record = [
                    first_index + 3 * t, triangles, u32::from(single_sided), 0,
                    lo[0], lo[1], lo[2], 0,
                    hi[0], hi[1], hi[2], 0,
                ];
                chunks.push(record);
            }
            let chunk_count = chunks.len() as u32 - first_chunk;
            draws.push(Draw { first_index, index_count, material: mesh.material, first_chunk, chunk_count });
        }
        if indices.is_empty() {
            return Err(Error::Input("scene has no triangles to draw".into()));
        }
        let vbytes: Vec<u8> = vertices.iter().flat_map(|f| f.to_le_bytes()).collect();
        let pbytes: Vec<u8> = (vertices.chunks_exact(VERTEX_FLOATS))
            .flat_map(|v| [v[0], v[1], v[2], 1.0])
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let ibytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        // Culling (mesh/cull.comp) reads positions and indices as texel buffers.
        let texels = vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER;
        let vertices = ctx.upload_buffer("mesh vertices", &vbytes, vk::BufferUsageFlags::VERTEX_BUFFER)?;
        let positions = ctx.upload_buffer("mesh positions", &pbytes, texels | vk::BufferUsageFlags::VERTEX_BUFFER)?;
        let indices_buf = ctx.upload_buffer("mesh indices", &ibytes, vk::BufferUsageFlags::INDEX_BUFFER | texels)?;
        let chunk_count = chunks.len() as u32;
        let chunk_bytes: Vec<u8> = chunks.iter().flatten().flat_map(|w| w.to_le_bytes()).collect();
        let chunks = ctx.upload_buffer("mesh chunks", &chunk_bytes, vk::BufferUsageFlags::STORAGE_BUFFER)?;

        let mut textures = vec![
            texture_image(ctx, "white", 1, 1, false, &[vec![255; 4]])?,
            texture_image(ctx, "flat normal", 1, 1, false, &[vec![128, 128, 255, 255]])?,
        ];
        for t in &scene.textures {
            textures.push(texture_image(ctx, &t.name, t.width, t.height, t.srgb, &t.mips)?);
        }
        let slot =
            |t: Option<usize>, fallback: usize| t.filter(|&i| i < scene.textures.len()).map_or(fallback, |i| i + 2);
        let materials = scene
            .materials
            .iter()
            .map(|m| {
                let (mask, cutoff) = match m.alpha_mode {
                    AlphaMode::Mask(c) => (FLAG_ALPHA_MASK, c),
                    AlphaMode::Opaque => (0, 0.0),
                };
                let normal_tex = slot(m.normal_tex, FLAT_NORMAL);
                GpuMaterial {
                    base_color: m.base_color,
                    specular: [m.specular[0], m.specular[1], m.specular[2], m.shininess],
                    base_color_tex: slot(m.base_color_tex, WHITE),
                    normal_tex,
                    specular_tex: slot(m.specular_tex, WHITE),
                    flags: mask | if normal_tex != FLAT_NORMAL { FLAG_NORMAL_MAP } else { 0 },
                    cutoff,
                    translucency: m.translucency,
                    double_sided: m.double_sided,
                }
            })
            .collect::<Vec<_>>();
        if let Some(d) = draws.iter().find(|d| d.material >= materials.len()) {
            return Err(Error::Input(format!("scene: a mesh uses material {} of {}", d.material, materials.len())));
        }
        let mut sun = None;
        let mut spots = Vec::new();
        for l in &scene.lights {
            match *l {
                Light::Directional { direction, color, intensity } if sun.is_none() => {
                    let to_sun = (-Vec3::from(direction)).normalize_or(Vec3::Y);
                    sun = Some(Sun { to_sun: to_sun.into(), irradiance: color.map(|c| c * intensity) });
                }
                Light::Spot { position, direction, color, intensity, inner_angle, outer_angle, range } => {
                    spots.push(Spot {
                        position,
                        direction: Vec3::from(direction).normalize_or(Vec3::NEG_Y).into(),
                        intensity: color.map(|c| c * intensity),
                        angles: [inner_angle.min(outer_angle), outer_angle],
                        range,
                    });
                }
                _ => {}
            }
        }
        let b = &scene.bounds;
        Ok(Self {
            id: NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            vertices,
            indices: indices_buf,
            positions,
            chunks,
            chunk_count,
            draws,
            materials,
            textures,
            bounds: [Vec3::from(b.min), Vec3::from(b.max)],
            sun,
            spots,
            triangles: scene.triangle_count(),
            translucent: scene.materials.iter().any(|m| m.translucency > 0.0),
        })
    }
}
