//! One frame of a mesh scene as frame-graph passes, composed of features (one file each):
//! shadow atlas (sun cascades + spot lights) → G-buffer → reflective shadow map and light
//! propagation volumes → deferred lighting (PCSS soft shadows and glossy LPV reflections are
//! shader variants) → sun rays → fog → tone map. Passes declare what they read and write; the
//! graph orders them and issues every barrier.

use super::camera::View;
use super::geometry::{Geometry, RasterPipelines};
use super::gpu_scene::GpuScene;
use super::lights::FrameLights;
use super::lpv_frame::{LpvGrids, LpvSources};
use crate::graph::execute::{record_graph, run_graph, GraphRun, Imports, RecordedGraph};
use crate::graph::{Access, BufferDesc, GraphBuilder, ImageId, ResourceState};
use crate::graph::{FrameOverlay, PresentTarget};
use crate::lpv::passes::{LpvOutput, LpvPipelines};
use crate::vk::{vk, Context};
use crate::Result;

pub use super::settings::MeshSettings;

pub use super::targets::{MeshTargets, RsmTargets};

/// Pipelines and samplers of the mesh renderer.
pub struct MeshRenderer {
    /// The G-buffer, depth-only and RSM pipelines.
    raster: RasterPipelines,
    lpv: LpvPipelines,
    /// What decides whether the LPV can run (subgroup ballots for the cascade-blend list,
    /// lighting.comp), whether views can be culled (mesh/cull.rs `supported`) and drawn with
    /// multi-draw indirect calls.
    device: crate::vk::DeviceInfo,
}

/// Images the frame produced (graph handles).
pub struct FrameImages {
    /// Linear HDR radiance.
    pub hdr: ImageId,
    /// Tone-mapped output.
    pub ldr: ImageId,
    /// Camera depth (for passes added after these, e.g. the LPV's geometry volume).
    pub depth: ImageId,
    /// G-buffer normal.
    pub normal: ImageId,
    /// RSM position, normal, flux, if rendered.
    pub rsm: Option<[ImageId; 3]>,
    /// The LPV's grids, if it ran this frame.
    pub lpv: Option<LpvOutput>,
    /// The packed LPV images the lighting read (fresh or reused).
    pub lpv_images: Option<[ImageId; 3]>,
    /// Whether the LPV was reused from an earlier frame (no RSM or LPV pass this frame).
    pub lpv_reused: bool,
}

impl MeshRenderer {
    /// Creates every pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(Self { raster: RasterPipelines::new(ctx)?, lpv: LpvPipelines::new(ctx)?, device: ctx.info.clone() })
    }

    /// Declares one frame's passes into `g`.
    #[allow(clippy::too_many_arguments)]
    pub fn add_passes<'a>(
        &'a self,
        g: &mut GraphBuilder<'a>,
        imports: &mut Imports,
        scene: &'a GpuScene,
        targets: &mut MeshTargets,
        view: &View,
        s: &MeshSettings,
    ) -> Result<FrameImages> {
        s.validate()?;
        if s.lpv.enabled && !self.device.subgroup_ballot {
            return Err(crate::Error::Input(format!(
                "lpv=1: the LPV read lists the pixels that blend two cascades with subgroup ballots in \
                 compute shaders, which {} lacks",
                self.device.name
            )));
        }
        let size = targets.size();
        let rsm_edge = targets.rsm.as_ref().map(|r| r.flux.info.extent[0]);
        // Cascades may stay where the cached LPV has them (`lpv_follow`) only while it is reused.
        let previous = match &targets.lpv_cache {
            Some(c) if s.lpv.reuse => &c.key.cascades[..],
            _ => &[][..],
        };
        let aspect = size[0] as f32 / size[1] as f32;
        let lights = super::lights::frame_lights(scene, view, aspect, s, rsm_edge, previous)?;
        let geo = self.geometry(g, imports, scene, targets, s, &lights)?;
        let atlas = super::shadow_atlas::shadow_atlas(
            g,
            &geo,
            &self.raster.depth,
            lights.atlas_size,
            &lights.rects,
            s.shadow_tile,
        )?;
        let gbuf = super::gbuffer::gbuffer(g, &geo, &self.raster.gbuffer, size)?;
        let rsm_key = super::rsm::rsm_key(scene, lights.rsm_view, &lights.frame, s);
        let plan = super::lpv_frame::plan(targets, s, &lights, rsm_key.clone());
        let rsm = match plan.reuse {
            true => None,
            false => {
                super::rsm::rsm(g, imports, &geo, &self.raster.rsm, targets, lights.rsm_view, rsm_key, s.lpv.reuse)?
            }
        };
        let lpv = match (rsm, lights.rsm_view) {
            _ if plan.reuse => super::lpv_frame::reused(g, imports, targets),
            (Some(rsm), Some(v)) if !lights.cascades.is_empty() => {
                let src = LpvSources { lights: &lights, view, gbuffer: gbuf, size, rsm, rsm_view_proj: v.view_proj };
                super::lpv_frame::compute(&self.lpv, &self.raster.depth, g, imports, &geo, targets, s, &src, &plan)?
            }
            _ => LpvGrids::default(),
        };
        targets.lpv_cascades = lights.cascades.clone();
        let hdr = targets.hdr.import(g, imports, "mesh hdr");
        let ldr = targets.ldr.import(g, imports, "mesh ldr");
        let limit = targets.blend_group_limit;
        super::lighting::lighting(g, scene, s, geo.ubo, gbuf, atlas, hdr, &lpv, size, limit)?;
        if s.fog.enabled {
            let input = super::fog::FogInputs {
                ubo: geo.ubo,
                depth: gbuf.depth,
                atlas,
                hdr,
                lpv: lpv.images,
                scene_bounds: scene.bounds,
                size,
                lights: u32::from(scene.sun.is_some()) + scene.spots.len().min(super::frame::MAX_SPOTS) as u32,
            };
            super::fog::add_fog_pass(g, &s.fog, input)?;
        }
        super::sun_rays::sun_rays(g, scene, view, &lights.frame, s, gbuf.depth, hdr, size)?;
        let params = s.tonemap.params(s.exposure);
        crate::post::add_tonemap_pass(g, hdr, ldr, params, [size[0].div_ceil(8), size[1].div_ceil(8), 1])?;
        let (depth, normal, lpv_images, lpv_reused) = (gbuf.depth, gbuf.normal, lpv.images, plan.reuse);
        Ok(FrameImages { hdr, ldr, depth, normal, rsm, lpv: lpv.out, lpv_images, lpv_reused })
    }

    /// The frame's uniform block (uploaded first) and what every raster pass binds.
    fn geometry<'a>(
        &'a self,
        g: &mut GraphBuilder<'a>,
        imports: &mut Imports,
        scene: &'a GpuScene,
        targets: &mut MeshTargets,
        s: &MeshSettings,
        lights: &FrameLights,
    ) -> Result<Geometry<'a>> {
        let frame_bytes = lights.frame.to_bytes();
        let ubo = g.create_buffer("frame", BufferDesc::new(frame_bytes.len() as u64));
        g.add_transfer_pass("upload frame").write_buffer(ubo, Access::TransferDst)?.record(move |pc| {
            // SAFETY: transfer pass outside rendering; the buffer is exactly as large as the data.
            unsafe { pc.device().cmd_update_buffer(pc.cmd, pc.buffer(ubo).raw, 0, &frame_bytes) };
            Ok(())
        });
        let vb = imports.buffer_readonly(g, "mesh vertices", &scene.vertices);
        let ib = imports.buffer_readonly(g, "mesh indices", &scene.indices);
        let read_only = ResourceState {
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            stage: vk::PipelineStageFlags2::FRAGMENT_SHADER,
            access: vk::AccessFlags2::NONE,
        };
        let textures: Vec<ImageId> =
            scene.textures.iter().map(|t| imports.image_readonly(g, "material texture", t, read_only)).collect();
        let positions = imports.buffer_readonly(g, "mesh positions", &scene.positions);
        let culling = if s.cull_triangles && super::cull::supported(&self.device, scene) {
            let chunks = imports.buffer_readonly(g, "mesh chunks", &scene.chunks);
            Some([chunks, targets.cull_stats.import(g, imports)?])
        } else {
            None
        };
        let (multi_draw, subgroup) = (self.device.multi_draw_indirect, self.device.min_subgroup_size);
        Ok(Geometry { scene, ubo, vb, positions, ib, textures, cull: s.cull, culling, multi_draw, subgroup })
    }
}

/// Builds and compiles one frame, exporting `hdr`, `ldr` (for `ldr_access`) and the RSM, and
/// records the targets' resulting states.
fn compile_frame<'a>(
    renderer: &'a MeshRenderer,
    scene: &'a GpuScene,
    targets: &mut MeshTargets,
    view: &View,
    settings: &MeshSettings,
    overlay: Option<&'a dyn FrameOverlay>,
    present: Option<PresentTarget>,
) -> Result<(crate::graph::CompiledGraph<'a>, Imports)> {
    let mut g = GraphBuilder::new();
    let mut imports = Imports::default();
    let out = renderer.add_passes(&mut g, &mut imports, scene, targets, view, settings)?;
    crate::graph::add_window_passes(&mut g, &mut imports, out.ldr, overlay, present)?;
    g.export_image(out.hdr, Some(Access::TransferSrc))?;
    g.export_image(out.ldr, Some(Access::TransferSrc))?;
    if let Some(ids) = out.rsm {
        for id in ids {
            g.export_image(id, Some(Access::TransferSrc))?;
        }
    }
    if let (Some(ids), false) = (out.lpv_images, out.lpv_reused) {
        for id in ids {
            g.export_image(id, None)?;
        }
    }
    Ok((g.compile()?, imports))
}

/// Renders one frame synchronously (headless rendering and tests).
pub fn render_frame(
    ctx: &Context,
    renderer: &MeshRenderer,
    scene: &GpuScene,
    targets: &mut MeshTargets,
    view: &View,
    settings: &MeshSettings,
) -> Result<GraphRun> {
    let (compiled, imports) = compile_frame(renderer, scene, targets, view, settings, None, None)?;
    run_graph(ctx, compiled, &imports, Default::default())
}

/// Records one frame into `cmd` for a window, ending in the present pass onto `target`;
/// `overlay` (the UI) is drawn on top of the tone-mapped image first.
#[allow(clippy::too_many_arguments)] // each is a separate input of the frame; a bundle would only rename the list
pub fn record_frame(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    renderer: &MeshRenderer,
    scene: &GpuScene,
    targets: &mut MeshTargets,
    view: &View,
    settings: &MeshSettings,
    overlay: Option<&dyn FrameOverlay>,
    target: PresentTarget,
) -> Result<RecordedGraph> {
    let (compiled, imports) = compile_frame(renderer, scene, targets, view, settings, overlay, Some(target))?;
    record_graph(ctx, cmd, compiled, &imports, Default::default())
}
