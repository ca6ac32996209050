//! The mesh frame's light propagation volumes: whether the cached LPV serves this frame (or
//! which of its cascades must be recomputed), the sky light's height map, the LPV passes into
//! the persistent packed images, the subsurface LPV, and the tests' read-back.

use super::camera::View;
use super::formats::DEPTH_FORMAT;
use super::frame::VIEW_SKY;
use super::gbuffer::Gbuffer;
use super::geometry::{set_viewport, DepthPipelines, Geometry};
use super::lights::FrameLights;
use super::settings::MeshSettings;
use super::targets::{LpvCache, LpvKey, MeshTargets, RsmKey};
use crate::graph::execute::Imports;
use crate::graph::{Access, GraphBuilder, ImageDesc, ImageId, LoadOp, PersistentImage, ResourceState};
use crate::lpv::passes::{CameraSurfels, LpvInputs, LpvOutput, LpvPipelines, PackedGrids, SkyInput};
use crate::lpv::settings::LpvSettings;
use crate::vk::{vk, Image, ImageInfo};
use crate::Result;

/// Whether the cached LPV serves this frame, and which cascades it computes otherwise.
pub(super) struct LpvPlan {
    /// What this frame's LPV depends on.
    pub key: LpvKey,
    /// The cached LPV holds this frame's answer: no RSM or LPV pass.
    pub reuse: bool,
    /// The cascades to compute, into their slots of the cached images.
    pub stale: Vec<usize>,
}

/// An LPV computed from the same RSM and cascades is still valid: reuse it (unless someone
/// asked to read the grids back). With occlusion on, the camera's depth buffer feeds the
/// geometry volume, so the view is part of what the LPV depends on. The subsurface LPV runs only
/// when some material lets light in, and is not cached. A camera that moved some cascades to new
/// cells leaves the others valid: only the moved ones are computed.
pub(super) fn plan(targets: &MeshTargets, s: &MeshSettings, lights: &FrameLights, rsm: Option<RsmKey>) -> LpvPlan {
    let key = LpvKey {
        cascades: lights.cascades.clone(),
        settings: s.lpv,
        rsm,
        flux_bound: lights.flux_bound,
        camera: s.lpv.occlusion.then_some(lights.frame.view_proj),
        sky: s.sky,
    };
    let reusable = s.lpv.enabled
        && s.lpv.reuse
        && !lights.sslpv_on
        && !lights.cascades.is_empty()
        && targets.lpv_readback.is_none();
    let moved = match (&targets.lpv_cache, reusable) {
        (Some(c), true) => c.key.moved_cascades(&key),
        _ => None,
    };
    let reuse = moved.as_ref().is_some_and(|m| m.is_empty());
    let stale = moved.unwrap_or_else(|| (0..lights.cascades.len()).collect());
    LpvPlan { key, reuse, stale }
}

/// The grids lighting reads this frame.
#[derive(Default)]
pub(super) struct LpvGrids {
    /// What the LPV passes left, when they ran.
    pub out: Option<LpvOutput>,
    /// The packed images (fresh or reused).
    pub images: Option<[ImageId; 3]>,
    /// The subsurface LPV's images.
    pub sslpv: Option<[ImageId; 3]>,
}

/// The cached LPV, read as it is.
pub(super) fn reused(g: &mut GraphBuilder<'_>, imports: &mut Imports, targets: &MeshTargets) -> LpvGrids {
    let images = targets.lpv_cache.as_ref().map(|c| {
        let names = ["lpv red (reused)", "lpv green (reused)", "lpv blue (reused)"];
        std::array::from_fn(|i| imports.image_readonly(g, names[i], c.images[i].image(), c.images[i].state()))
    });
    LpvGrids { images, ..Default::default() }
}

/// What the LPV passes of this frame read besides the RSM.
pub(super) struct LpvSources<'s> {
    pub lights: &'s FrameLights,
    pub view: &'s View,
    pub gbuffer: Gbuffer,
    pub size: [u32; 2],
    pub rsm: [ImageId; 3],
    pub rsm_view_proj: glam::Mat4,
}

/// The LPV passes of the plan's stale cascades into the persistent packed images, the
/// subsurface LPV, and the read-back where the targets ask for one.
#[allow(clippy::too_many_arguments)]
pub(super) fn compute<'a>(
    lpv: &'a LpvPipelines,
    depth: &'a DepthPipelines,
    g: &mut GraphBuilder<'a>,
    imports: &mut Imports,
    geo: &Geometry<'a>,
    targets: &mut MeshTargets,
    s: &MeshSettings,
    src: &LpvSources<'_>,
    plan: &LpvPlan,
) -> Result<LpvGrids> {
    let (lights, view, [w, h]) = (src.lights, src.view, src.size);
    let cascades = &lights.cascades;
    let sky = sky_height(g, geo, depth, s, lights)?;
    let input = LpvInputs {
        sky,
        subsurface: false,
        rsm: src.rsm,
        rsm_size: targets.rsm.as_ref().map_or(0, |r| r.flux.info.extent[0]),
        rsm_vp: src.rsm_view_proj,
        rsm_light: lights.frame.rsm_light,
        light: lights.rsm_light_pos,
        flux_bound: lights.flux_bound,
        camera: Some(CameraSurfels {
            depth: src.gbuffer.depth,
            normal: src.gbuffer.normal,
            inv_view_proj: lights.frame.view_proj.inverse(),
            position: view.position,
            pixel_angle: 2.0 * (view.fov_y * 0.5).tan() / h as f32,
            size: [w, h],
        }),
    };
    let packed = packed_images(g, imports, targets, s, cascades.len() as u32, plan)?;
    let computed: Vec<_> = plan.stale.iter().map(|&i| cascades[i]).collect();
    let out = lpv.add_passes(g, imports, &targets.lpv_stats, &s.lpv, &computed, &input, packed)?;
    if let Some([a, b]) = &targets.lpv_readback {
        let ids = [
            imports.buffer(g, "lpv injected readback", a, ResourceState::UNDEFINED),
            imports.buffer(g, "lpv accumulated readback", b, ResourceState::UNDEFINED),
        ];
        readback(g, [out.injected, out.images], ids, a.size.min(b.size) / 3)?;
    }
    let sslpv = match lights.sslpv_on {
        true => {
            let sub = LpvSettings { occlusion: false, directional: false, sky: 0.0, ..s.lpv };
            let input = LpvInputs { camera: None, sky: None, subsurface: true, ..input };
            Some(lpv.add_passes(g, imports, &targets.sslpv_stats, &sub, cascades, &input, None)?.images)
        }
        false => None,
    };
    targets.lpv_scale = out.scale;
    Ok(LpvGrids { images: Some(out.images), out: Some(out), sslpv })
}

/// The sky light's height map: the scene's depth seen from straight above (sky light on).
fn sky_height<'a>(
    g: &mut GraphBuilder<'a>,
    geo: &Geometry<'a>,
    pipes: &'a DepthPipelines,
    s: &MeshSettings,
    lights: &FrameLights,
) -> Result<Option<SkyInput>> {
    let Some(view_proj) = lights.sky_vp else { return Ok(None) };
    // Whole texels per cell, so the per-cell reduction tiles the map exactly.
    let texels_per_cell = (512 / s.lpv.size).clamp(1, 16);
    let edge = s.lpv.size * texels_per_cell;
    let height = g.create_image("lpv sky height", ImageDesc::d2(DEPTH_FORMAT, edge, edge));
    let geo = geo.clone();
    let culled = geo.cull_view(g, "lpv sky height".into(), VIEW_SKY, [0, 0, edge, edge])?;
    let mut p = g.add_raster_pass("lpv sky height");
    p.depth_attachment(height, LoadOp::Clear, 1.0, true)?;
    geo.declare_reads_culled(&mut p, culled)?;
    p.record(move |pc| {
        set_viewport(pc, [0, 0, edge, edge]);
        geo.draw_depth(pc, pipes, VIEW_SKY, culled)
    });
    let radiance = s.sky.map(|c| c * s.lpv.sky);
    let cell = lights.cascades.last().map_or(1.0, |c| c.cell);
    Ok(Some(SkyInput { height, view_proj, radiance, cell }))
}

/// The persistent packed images (made or remade at this frame's size), imported, with the
/// stale cascades' slots: the next frame can reuse them.
fn packed_images(
    g: &mut GraphBuilder<'_>,
    imports: &mut Imports,
    targets: &mut MeshTargets,
    s: &MeshSettings,
    cascades: u32,
    plan: &LpvPlan,
) -> Result<Option<PackedGrids>> {
    let extent = [s.lpv.size, s.lpv.size, s.lpv.size * cascades];
    if targets.lpv_cache.as_ref().is_none_or(|c| c.images[0].info.extent != extent) {
        // Written by propagation's last step or a copy, sampled by shading, copied by readback.
        let usage = vk::ImageUsageFlags::STORAGE
            | vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_DST
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let info = ImageInfo::d3(crate::lpv::passes::GRID_FORMAT, extent, usage);
        let ctx = targets.hdr.context().clone();
        let img = |name| -> Result<PersistentImage> { Ok(PersistentImage::new(Image::new(&ctx, name, info)?)) };
        targets.lpv_cache =
            Some(LpvCache { key: plan.key.clone(), images: [img("lpv red")?, img("lpv green")?, img("lpv blue")?] });
    }
    Ok(targets.lpv_cache.as_mut().map(|c| {
        c.key = plan.key.clone();
        let names = ["lpv red", "lpv green", "lpv blue"];
        let images = std::array::from_fn(|i| c.images[i].import(g, imports, names[i]));
        PackedGrids { images, slots: plan.stale.iter().map(|&i| i as u32).collect() }
    }))
}

/// Copies the injected and accumulated grids into the read-back buffers (`channel_bytes` per
/// channel image).
fn readback(
    g: &mut GraphBuilder<'_>,
    src: [[ImageId; 3]; 2],
    ids: [crate::graph::BufferId; 2],
    channel_bytes: u64,
) -> Result<()> {
    let mut p = g.add_transfer_pass("lpv readback");
    for (grid, id) in src.iter().zip(ids) {
        for &image in grid {
            p.read_image(image, Access::TransferSrc)?;
        }
        p.write_buffer(id, Access::TransferDst)?;
    }
    p.side_effect();
    p.record(move |pc| {
        for (grid, id) in src.iter().zip(ids) {
            for (ch, &image) in grid.iter().enumerate() {
                let offset = ch as u64 * channel_bytes;
                let region = [crate::lpv::passes::channel_region(offset, pc.image(image).info.extent)];
                // SAFETY: transfer pass; the readback holds three channel images of this grid.
                unsafe {
                    pc.device().cmd_copy_image_to_buffer(
                        pc.cmd,
                        pc.image(image).raw,
                        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                        pc.buffer(id).raw,
                        &region,
                    )
                };
            }
        }
        Ok(())
    });
    Ok(())
}
