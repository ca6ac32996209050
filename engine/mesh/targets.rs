//! The mesh renderer's persistent outputs: HDR and LDR images, the reflective shadow map, the
//! LPV counters, readback buffers and the packed LPV a later frame may reuse. Each image owns
//! its state ([`PersistentImage`]).

use super::formats::RSM_FORMAT;
use super::shadow::ShadowView;
use crate::graph::PersistentImage;
use crate::lpv::grid::{Cascade, HostGrid};
use crate::lpv::passes::LpvStats;
use crate::vk::{vk, Context, Image, ImageInfo};
use crate::{Error, Result};

/// A reflective shadow map's images (world position, normal, reflected flux per texel).
pub struct RsmTargets {
    /// World position (w = 1 where a surface was seen).
    pub position: PersistentImage,
    /// Unit normal facing the light.
    pub normal: PersistentImage,
    /// Reflected flux (W, RGB).
    pub flux: PersistentImage,
    /// The light view the last frame rendered it from.
    pub view: Option<ShadowView>,
    /// What the images hold the answer for: a frame with the same key reads them as they are.
    pub(crate) key: Option<RsmKey>,
}

/// Everything an RSM depends on. Floats compare exactly: any change renders it again.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RsmKey {
    /// Which uploaded scene (geometry and materials).
    pub scene: u64,
    /// The RSM's world → clip.
    pub view_proj: glam::Mat4,
    /// The RSM light's kind and footprint (frame.glsl `rsm_light`).
    pub rsm_light: [f32; 4],
    /// The sun the RSM sees the scene from, if any.
    pub sun: Option<crate::mesh::gpu_scene::Sun>,
    /// Else the spot light it sees it from.
    pub spot: Option<crate::mesh::gpu_scene::Spot>,
    /// Back-face culling on.
    pub cull: bool,
}

/// Persistent outputs of the mesh renderer.
pub struct MeshTargets {
    /// Linear HDR radiance.
    pub hdr: PersistentImage,
    /// Tone-mapped RGBA8.
    pub ldr: PersistentImage,
    /// The RSM, when requested (the LPV and tests read it).
    pub rsm: Option<RsmTargets>,
    /// LPV counters of the last frame.
    pub lpv_stats: LpvStats,
    /// Triangles each view kept in the last frame that culled them (`cull_triangles`).
    pub cull_stats: super::cull::CullStats,
    /// The most workgroups along x of the cascade blend pass's dispatch, past which it adds rows
    /// along y: 65,535 (Vulkan's least `maxComputeWorkGroupCount[0]`); tests lower it to reach
    /// the rows with a small image.
    pub blend_group_limit: u32,
    /// Subsurface-LPV counters of the last frame.
    pub sslpv_stats: LpvStats,
    /// Host copies of the injected and accumulated light grids, when requested.
    pub lpv_readback: Option<[crate::vk::Buffer; 2]>,
    /// The cascades the last frame used.
    pub lpv_cascades: Vec<Cascade>,
    /// Fixed-point scale the last frame's integer injection used.
    pub lpv_scale: f32,
    /// The packed LPV of an earlier frame and what it was computed from: with a static light,
    /// static geometry and the same cascades, later frames reuse it instead of recomputing.
    pub(crate) lpv_cache: Option<LpvCache>,
}

/// Everything an LPV depends on. Floats compare exactly: any change recomputes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LpvKey {
    /// Where the grids are.
    pub cascades: Vec<Cascade>,
    /// Every LPV setting.
    pub settings: crate::lpv::settings::LpvSettings,
    /// The RSM it is injected from (scene, light, light view).
    pub rsm: Option<RsmKey>,
    /// Flux bound (sets the fixed-point scale).
    pub flux_bound: f32,
    /// The camera's view-projection, when the camera's depth feeds the geometry volume.
    pub camera: Option<glam::Mat4>,
    /// The sky's radiance (the LPV's sky light scales it).
    pub sky: [f32; 3],
}

impl LpvKey {
    /// The cascades (indices) whose placement differs from `self`'s when nothing else does:
    /// those alone need computing again. None when anything else changed.
    pub(crate) fn moved_cascades(&self, new: &LpvKey) -> Option<Vec<usize>> {
        let rest = |k: &LpvKey| LpvKey { cascades: Vec::new(), ..k.clone() };
        if self.cascades.len() != new.cascades.len() || rest(self) != rest(new) {
            return None;
        }
        Some((0..new.cascades.len()).filter(|&i| self.cascades[i] != new.cascades[i]).collect())
    }
}

/// Persistent packed LPV images and the inputs they hold the answer for.
pub(crate) struct LpvCache {
    pub(crate) key: LpvKey,
    pub(crate) images: [PersistentImage; 3],
}

impl MeshTargets {
    /// Targets of `size`; `rsm_size > 0` also renders a reflective shadow map of that edge.
    pub fn new(ctx: &Context, [w, h]: [u32; 2], rsm_size: u32) -> Result<Self> {
        let u = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let rsm = if rsm_size > 0 {
            if rsm_size > 4096 {
                return Err(Error::Input(format!("rsm_size={rsm_size}: must be in 1..=4096")));
            }
            let ru = vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::TRANSFER_SRC;
            let img = |name| -> Result<PersistentImage> {
                Ok(PersistentImage::new(Image::new(ctx, name, ImageInfo::d2(RSM_FORMAT, rsm_size, rsm_size, ru))?))
            };
            Some(RsmTargets {
                position: img("rsm position")?,
                normal: img("rsm normal")?,
                flux: img("rsm flux")?,
                view: None,
                key: None,
            })
        } else {
            None
        };
        Ok(Self {
            hdr: PersistentImage::new(Image::new(
                ctx,
                "mesh hdr",
                ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, w, h, u),
            )?),
            // Colour-attachment use lets the window's UI overlay draw onto it.
            ldr: PersistentImage::new(Image::new(
                ctx,
                "mesh ldr",
                ImageInfo::d2(vk::Format::R8G8B8A8_UNORM, w, h, u | vk::ImageUsageFlags::COLOR_ATTACHMENT),
            )?),
            rsm,
            lpv_stats: LpvStats::new(ctx)?,
            cull_stats: super::cull::CullStats::new(ctx)?,
            blend_group_limit: 65_535,
            sslpv_stats: LpvStats::new(ctx)?,
            lpv_readback: None,
            lpv_cascades: Vec::new(),
            lpv_scale: 1.0,
            lpv_cache: None,
        })
    }

    /// Keeps host copies of the LPV's injected and accumulated grids after every frame (tests, tools).
    pub fn enable_lpv_readback(&mut self, ctx: &Context, lpv: &crate::lpv::settings::LpvSettings) -> Result<()> {
        let bytes = 12 * (lpv.size as u64).pow(3) * lpv.cascades as u64 * 4;
        let usage = vk::BufferUsageFlags::TRANSFER_DST;
        let b = |name| crate::vk::Buffer::new(ctx, name, bytes, usage, crate::vk::MemoryLocation::GpuToCpu);
        self.lpv_readback = Some([b("lpv injected readback")?, b("lpv accumulated readback")?]);
        Ok(())
    }

    /// The last frame's (injected, accumulated) light grids.
    pub fn lpv_grids(&self) -> Option<[HostGrid; 2]> {
        let read = |b: &crate::vk::Buffer| -> Vec<f32> {
            b.mapped()
                .map(|m| m.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
                .unwrap_or_default()
        };
        self.lpv_readback.as_ref().map(|[a, b]| [HostGrid::new(read(a)), HostGrid::new(read(b))])
    }

    /// Reads back the packed LPV the last frame's lighting read (accumulated light of every
    /// cascade, computed that frame or kept from earlier ones), if there is one.
    pub fn read_lpv(&self, ctx: &Context) -> Result<Option<HostGrid>> {
        let Some(c) = &self.lpv_cache else { return Ok(None) };
        let mut values = Vec::new();
        for image in &c.images {
            values.extend(image.read_rgba32f(ctx)?.into_iter().flatten());
        }
        Ok(Some(HostGrid::new(values)))
    }

    /// Size in pixels.
    pub fn size(&self) -> [u32; 2] {
        [self.hdr.info.extent[0], self.hdr.info.extent[1]]
    }

    /// Reads the HDR image back (RGBA f32 per pixel).
    pub fn read_hdr(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        self.hdr.read_rgba32f(ctx)
    }

    /// Reads the tone-mapped image back (RGBA8).
    pub fn read_ldr(&self, ctx: &Context) -> Result<Vec<u8>> {
        self.ldr.read(ctx)
    }

    /// Reads the RSM back: (position, normal, flux) per texel.
    pub fn read_rsm(&self, ctx: &Context) -> Result<[Vec<[f32; 4]>; 3]> {
        let r = self.rsm.as_ref().ok_or_else(|| Error::Input("these targets have no RSM (rsm_size = 0)".into()))?;
        Ok([r.position.read_rgba32f(ctx)?, r.normal.read_rgba32f(ctx)?, r.flux.read_rgba32f(ctx)?])
    }
}
