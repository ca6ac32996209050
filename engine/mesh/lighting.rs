//! Deferred lighting: direct light with shadow-map filtering (PCF or PCSS), the LPV's indirect
//! light (and its glossy reflections), and the pass that blends two cascades where they meet.

use super::gbuffer::Gbuffer;
use super::gpu_scene::GpuScene;
use super::lpv_frame::LpvGrids;
use super::settings::MeshSettings;
use crate::graph::shader_pass::ComputePass;
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, ImageId, Work};
use crate::shaders;
use crate::vk::Sampling;
use crate::Result;

/// The lighting shader's variants: (LPV, glossy LPV reflections, PCSS) → module. Switches that
/// are off compile out, so they cost nothing in the shader either.
fn lighting_shader(lpv: bool, glossy: bool, pcss: bool) -> &'static shaders::Shader {
    match (lpv, glossy && lpv, pcss) {
        (false, _, false) => &shaders::MESH_LIGHTING_COMP,
        (false, _, true) => &shaders::MESH_LIGHTING_COMP__PCSS,
        (true, false, false) => &shaders::MESH_LIGHTING_COMP__LPV,
        (true, false, true) => &shaders::MESH_LIGHTING_COMP__LPV_PCSS,
        (true, true, false) => &shaders::MESH_LIGHTING_COMP__LPV_GLOSSY,
        (true, true, true) => &shaders::MESH_LIGHTING_COMP__LPV_GLOSSY_PCSS,
    }
}

/// The lighting pass into `hdr` (and, with the LPV, the cascade blend pass).
#[allow(clippy::too_many_arguments)]
pub(super) fn lighting(
    g: &mut GraphBuilder<'_>,
    scene: &GpuScene,
    s: &MeshSettings,
    ubo: BufferId,
    gbuf: Gbuffer,
    atlas: ImageId,
    hdr: ImageId,
    lpv: &LpvGrids,
    [w, h]: [u32; 2],
    blend_group_limit: u32,
) -> Result<()> {
    // Texels each pixel reads: 4 G-buffer texels (~8 B), (2r+2)² shadow taps per light, and 8
    // cells × 3 RGBA32F textures per LPV lookup (twice with damping).
    let pixels = u64::from(w) * u64::from(h);
    let lights = u64::from(scene.sun.is_some()) + scene.spots.len() as u64;
    let taps = u64::from(2 * s.pcf_radius + 2).pow(2);
    let lpv_bytes = if lpv.images.is_some() { 8 * 3 * 16 * (1 + u64::from(s.lpv.damping)) } else { 0 };
    // The subsurface grids, or (never read: LPV_SUBSURFACE false) the surface ones again.
    let lpv_grids = lpv.images.map(|imgs| [imgs, lpv.sslpv.unwrap_or(imgs)]);
    let shader = lighting_shader(lpv.images.is_some(), s.lpv_glossy, s.soft_shadows);
    // The pixels that blend two cascades, listed for the blend pass (lighting.comp).
    let blend_list = lpv.images.is_some().then(|| blend_list(g, pixels)).transpose()?;
    // The blend pass's dispatch needs rows of groups past the group limit × 64 pixels
    // (lighting.comp).
    let limit = blend_group_limit.clamp(1, 65_535);
    let rows = pixels > u64::from(limit) * 64;
    let spec = [u32::from(s.lpv.damping), u32::from(lpv.sslpv.is_some()), u32::from(rows), limit];
    let grids: Vec<ImageId> = lpv_grids.into_iter().flatten().flatten().collect();
    let b = LightingBindings {
        ubo,
        gbuffer: [gbuf.depth, gbuf.albedo, gbuf.normal, gbuf.specular, atlas],
        hdr,
        grids,
        blend_list,
        spec,
    };
    let work = Work { bytes: pixels * (4 * 8 + lights * taps * 4 + lpv_bytes + 16), ..Default::default() };
    b.bind(g.compute("lighting", shader).work(work), false).dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
    if let Some(list) = blend_list {
        b.bind(g.compute("cascade blend", &shaders::MESH_LIGHTING_COMP__LPV_BLEND), true).dispatch_indirect(list, 0)?;
    }
    Ok(())
}

/// What lighting.comp binds, in its binding order; its blend variant binds the same.
struct LightingBindings {
    ubo: BufferId,
    /// Depth, albedo, normal, specular, shadow atlas.
    gbuffer: [ImageId; 5],
    hdr: ImageId,
    /// The LPV's grids, then the subsurface LPV's (or the same again), when the LPV is on.
    grids: Vec<ImageId>,
    blend_list: Option<BufferId>,
    spec: [u32; 4],
}

impl LightingBindings {
    /// Declares the bindings on `p`: the lighting pass writes the HDR image and the blend list,
    /// the blend pass (`blend`) adds into the image and reads the list.
    fn bind<'g, 'a>(&self, p: ComputePass<'g, 'a>, blend: bool) -> ComputePass<'g, 'a> {
        let p = p.uniform(self.ubo).each(self.gbuffer, |p, id| p.sampled(id, Sampling::Nearest));
        let p = if blend { p.read_write(self.hdr) } else { p.write(self.hdr) };
        let p = p.each(self.grids.iter().copied(), |p, id| p.read(id));
        let p = if blend {
            p.each(self.blend_list, |p, id| p.read(id))
        } else {
            p.each(self.blend_list, |p, id| p.read_write(id))
        };
        p.specialize(&self.spec)
    }
}

/// The blend list of lighting.comp for `pixels` pixels: its header (an empty list and its
/// indirect dispatch of 0 × 1 × 1 groups) written, then an entry of two words per pixel at most.
fn blend_list(g: &mut GraphBuilder<'_>, pixels: u64) -> Result<BufferId> {
    let list = g.create_buffer("cascade blend list", BufferDesc::new(16 + 8 * pixels));
    let mut p = g.add_transfer_pass("cascade blend list clear");
    p.write_buffer(list, Access::TransferDst)?;
    p.record(move |pc| {
        let header: [u32; 4] = [0, 1, 1, 0];
        // SAFETY: transfer pass writing the declared buffer; 16 bytes, a multiple of 4.
        unsafe { pc.device().cmd_update_buffer(pc.cmd, pc.buffer(list).raw, 0, bytemuck::bytes_of(&header)) };
        Ok(())
    });
    Ok(list)
}
