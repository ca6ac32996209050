//! One frame of a mesh scene as frame-graph passes: shadow atlas (sun cascades + spot lights) →
//! G-buffer → optional reflective shadow map → deferred lighting (optionally with PCSS soft
//! shadows and glossy LPV reflections, both shader variants) → optional sun rays → optional fog
//! → tone map.
//! Passes declare what they read and write; the graph orders them and issues every barrier.
//! Size: the raster passes and the LPV's reuse decision are one frame's order of events; the
//! light setup (`lights`), targets (`targets`) and fog (`fog`) already live beside it, and the
//! raster passes move to their own modules when they get the shader-pass builder.

use super::camera::View;
use super::cull::{add_cull_pass, CullView, CulledDraws, DRAW_STRIDE};
use super::frame::{draw_constants, FrameData, MAX_SPOTS, VIEW_CAMERA, VIEW_RSM, VIEW_SKY};
use super::gpu_scene::{GpuMaterial, GpuScene, FLAG_ALPHA_MASK, FLAG_NORMAL_MAP, POSITION_BYTES, WHITE};
use super::lights::FrameLights;
use crate::graph::execute::{record_graph, run_graph, GraphRun, Imports, PassContext, RecordedGraph};
use crate::graph::shader_pass::ComputePass;
use crate::graph::{
    Access, BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, LoadOp, PersistentImage, ResourceState,
    ShaderStage, Work,
};
use crate::graph::{FrameOverlay, PresentTarget};
use crate::lpv::passes::{LpvInputs, LpvOutput, LpvPipelines, PackedGrids};
use crate::lpv::settings::LpvSettings;
use crate::shaders;
use crate::vk::{vk, Binding, Context, Descriptor, GraphicsDesc, Image, ImageInfo, Pipeline, Sampling};
use crate::Result;
use glam::{Vec3, Vec4Swizzles};

/// G-buffer albedo format.
pub const ALBEDO_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
/// G-buffer world-normal format.
pub const NORMAL_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// G-buffer specular format (rgb colour, a = log2(shininess) / 12: 3.3 % steps over [1, 4096]).
pub const SPECULAR_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
/// Depth format of every depth buffer and shadow map.
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// RSM world position, normal and flux: 32-bit float so summed flux stays exact.
pub const RSM_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

pub use super::settings::MeshSettings;

pub(crate) use super::targets::{LpvCache, LpvKey, RsmKey};
pub use super::targets::{MeshTargets, RsmTargets};

/// Largest soft-shadow filter radius in texels: bounds the penumbra (and the blocker search)
/// so a pixel never costs more than 7² + 12² shadow-map taps.
pub const MAX_PENUMBRA_TEXELS: f32 = 16.0;

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

/// Pipelines and samplers of the mesh renderer.
pub struct MeshRenderer {
    /// The G-buffer: with and without the normal- and specular-map lookups.
    gbuffer: GbufferPipelines,
    /// Depth-only draws: opaque materials without a fragment stage, alpha-masked ones with one.
    depth: DepthPipelines,
    rsm: Pipeline,
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

const DRAW_PUSH: u32 = 48;

/// The two pipelines of a depth-only pass (`Geometry::draw_depth`).
struct DepthPipelines {
    /// Position only, no fragment stage.
    opaque: Pipeline,
    /// mesh.vert and shadow.frag, which discards below the alpha cutoff.
    masked: Pipeline,
}

/// The two pipelines of the G-buffer pass (`Geometry::draw_gbuffer`).
struct GbufferPipelines {
    /// gbuffer.frag with its normal- and specular-map lookups.
    maps: Pipeline,
    /// Its NO_MAPS variant, for materials with neither map.
    no_maps: Pipeline,
}

fn vertex_layout(desc: &mut GraphicsDesc) {
    desc.vertex_bindings = vec![vk::VertexInputBindingDescription {
        binding: 0,
        stride: (super::gpu_scene::VERTEX_FLOATS * 4) as u32,
        input_rate: vk::VertexInputRate::VERTEX,
    }];
    let attr = |location, format, offset| vk::VertexInputAttributeDescription { location, binding: 0, format, offset };
    desc.vertex_attributes = vec![
        attr(0, vk::Format::R32G32B32_SFLOAT, 0),
        attr(1, vk::Format::R32G32B32_SFLOAT, 12),
        attr(2, vk::Format::R32G32_SFLOAT, 24),
        attr(3, vk::Format::R32G32B32A32_SFLOAT, 32),
    ];
}

impl MeshRenderer {
    /// Creates every pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let (vs, fs) = (vk::ShaderStageFlags::VERTEX, vk::ShaderStageFlags::FRAGMENT);
        let sampler = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
        let raster_bindings = [
            Binding::new(0, vk::DescriptorType::UNIFORM_BUFFER, vs | fs),
            Binding::new(1, sampler, fs),
            Binding::new(2, sampler, fs),
            Binding::new(3, sampler, fs),
        ];
        let desc = |colors: Vec<vk::Format>| GraphicsDesc {
            color_formats: colors,
            depth_format: Some(DEPTH_FORMAT),
            depth_test: true,
            depth_write: true,
            dynamic_cull: true,
            ..Default::default()
        };
        let raster = |frag, colors: Vec<vk::Format>| -> Result<Pipeline> {
            let mut d = desc(colors);
            vertex_layout(&mut d);
            Pipeline::graphics(ctx, &[&shaders::MESH_MESH_VERT, frag], &raster_bindings, DRAW_PUSH, &d)
        };
        // Opaque depth draws read the scene's compact positions (16 bytes a vertex, as culling
        // does) rather than the interleaved vertices' 48: a third of the cache lines, in passes
        // that start the frame with caches the previous frame's LPV and lighting have emptied.
        let mut position_only = desc(vec![]);
        vertex_layout(&mut position_only);
        position_only.vertex_attributes.truncate(1);
        position_only.vertex_bindings[0].stride = POSITION_BYTES;
        let opaque =
            Pipeline::graphics(ctx, &[&shaders::MESH_DEPTH_VERT], &raster_bindings, DRAW_PUSH, &position_only)?;
        Ok(Self {
            gbuffer: GbufferPipelines {
                maps: raster(&shaders::MESH_GBUFFER_FRAG, vec![ALBEDO_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT])?,
                no_maps: raster(
                    &shaders::MESH_GBUFFER_FRAG__NO_MAPS,
                    vec![ALBEDO_FORMAT, NORMAL_FORMAT, SPECULAR_FORMAT],
                )?,
            },
            depth: DepthPipelines { opaque, masked: raster(&shaders::MESH_SHADOW_FRAG, vec![])? },
            rsm: raster(&shaders::MESH_RSM_FRAG, vec![RSM_FORMAT; 3])?,
            lpv: LpvPipelines::new(ctx)?,
            device: ctx.info.clone(),
        })
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
        let [w, h] = targets.size();
        let aspect = w as f32 / h as f32;
        let rsm_edge = targets.rsm.as_ref().map(|r| r.flux.info.extent[0]);
        // Cascades may stay where the cached LPV has them (`lpv_follow`) only while it is reused.
        let previous = match &targets.lpv_cache {
            Some(c) if s.lpv.reuse => &c.key.cascades[..],
            _ => &[][..],
        };
        let FrameLights { frame, atlas_size, rects, rsm_view, rsm_light_pos, flux_bound, cascades, sslpv_on, sky_vp } =
            super::lights::frame_lights(scene, view, aspect, s, rsm_edge, previous)?;

        let frame_bytes = frame.to_bytes();
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
        let multi_draw = self.device.multi_draw_indirect;
        let subgroup = self.device.min_subgroup_size;
        let geometry =
            Geometry { scene, ubo, vb, positions, ib, textures, cull: s.cull, culling, multi_draw, subgroup };

        // Shadow atlas: one depth image, a viewport per tile.
        let atlas = g.create_image("shadow atlas", ImageDesc::d2(DEPTH_FORMAT, atlas_size[0], atlas_size[1]));
        {
            let pipes = &self.depth;
            let geo = geometry.clone();
            let tile_px: Vec<[u32; 4]> = rects
                .iter()
                .map(|r| {
                    let o = [r[0] * atlas_size[0] as f32, r[1] * atlas_size[1] as f32];
                    [o[0] as u32, o[1] as u32, s.shadow_tile, s.shadow_tile]
                })
                .collect();
            let culled = (tile_px.iter().enumerate())
                .map(|(i, &t)| geo.cull_view(g, format!("shadow tile {i}"), 1 + i as u32, t))
                .collect::<Result<Vec<_>>>()?;
            let mut p = g.add_raster_pass("shadow maps");
            p.depth_attachment(atlas, LoadOp::Clear, 1.0, true)?;
            geo.declare_reads(&mut p)?;
            for c in culled.iter().flatten() {
                c.declare_reads(&mut p)?;
            }
            p.record(move |pc| {
                for (i, t) in tile_px.iter().enumerate() {
                    let vp = vk::Viewport {
                        x: t[0] as f32,
                        y: t[1] as f32,
                        width: t[2] as f32,
                        height: t[3] as f32,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    };
                    let sc = vk::Rect2D {
                        offset: vk::Offset2D { x: t[0] as i32, y: t[1] as i32 },
                        extent: vk::Extent2D { width: t[2], height: t[3] },
                    };
                    // SAFETY: inside the pass's rendering scope; the tile lies within the atlas.
                    unsafe {
                        pc.device().cmd_set_viewport(pc.cmd, 0, &[vp]);
                        pc.device().cmd_set_scissor(pc.cmd, 0, &[sc]);
                    }
                    geo.draw_depth(pc, pipes, 1 + i as u32, culled[i])?;
                }
                Ok(())
            });
        }

        // G-buffer.
        let desc = |f| ImageDesc::d2(f, w, h);
        let albedo = g.create_image("gbuffer albedo", desc(ALBEDO_FORMAT));
        let normal = g.create_image("gbuffer normal", desc(NORMAL_FORMAT));
        let specular = g.create_image("gbuffer specular", desc(SPECULAR_FORMAT));
        let depth = g.create_image("depth", desc(DEPTH_FORMAT));
        {
            let pipes = &self.gbuffer;
            let geo = geometry.clone();
            let culled = geo.cull_view(g, "gbuffer".into(), VIEW_CAMERA, [0, 0, w, h])?;
            let mut p = g.add_raster_pass("gbuffer");
            for id in [albedo, normal, specular] {
                p.color_attachment(id, LoadOp::Clear, [0.0; 4])?;
            }
            p.depth_attachment(depth, LoadOp::Clear, 1.0, true)?;
            geo.declare_reads_culled(&mut p, culled)?;
            p.record(move |pc| geo.draw_gbuffer(pc, pipes, VIEW_CAMERA, culled));
        }

        // What the RSM shows: the scene seen from its light.
        let rsm_key = rsm_view.map(|v| RsmKey {
            scene: scene.id,
            view_proj: v.view_proj,
            rsm_light: frame.rsm_light,
            sun: scene.sun,
            spot: scene.sun.is_none().then(|| scene.spots.first().copied()).flatten(),
            cull: s.cull,
        });
        // An LPV computed from the same RSM and cascades is still valid: reuse it, and skip the
        // RSM it came from (unless someone asked to read the grids back).
        // With occlusion on, the camera's depth buffer feeds the geometry volume, so the view
        // is part of what the LPV depends on.
        let lpv_key = LpvKey {
            cascades: cascades.clone(),
            settings: s.lpv,
            rsm: rsm_key.clone(),
            flux_bound,
            camera: s.lpv.occlusion.then_some(frame.view_proj),
            sky: s.sky,
        };
        // The subsurface LPV runs only when some material lets light in; it is not cached.
        // A camera that moved some cascades to new cells leaves the others valid: only the
        // moved ones are computed (`stale`), into their slots of the cached images.
        let reusable =
            s.lpv.enabled && s.lpv.reuse && !sslpv_on && !cascades.is_empty() && targets.lpv_readback.is_none();
        let moved = match (&targets.lpv_cache, reusable) {
            (Some(c), true) => c.key.moved_cascades(&lpv_key),
            _ => None,
        };
        let reuse_lpv = moved.as_ref().is_some_and(|m| m.is_empty());
        let stale: Vec<usize> = moved.unwrap_or_else(|| (0..cascades.len()).collect());

        // Reflective shadow map, into the persistent RSM targets; one rendered from the same
        // light, view and geometry is read as it is.
        let mut rsm_ids = None;
        if let (Some(r), Some(v), false) = (targets.rsm.as_mut(), rsm_view, reuse_lpv) {
            let n = r.flux.info.extent[0];
            let ids = [
                r.position.import(g, imports, "rsm position"),
                r.normal.import(g, imports, "rsm normal"),
                r.flux.import(g, imports, "rsm flux"),
            ];
            // `lpv_reuse=false` renders it every frame too, as a moving light would.
            if !s.lpv.reuse || r.key.is_none() || r.key != rsm_key {
                let rsm_depth = g.create_image("rsm depth", ImageDesc::d2(DEPTH_FORMAT, n, n));
                let pipe = &self.rsm;
                let geo = geometry.clone();
                let culled = geo.cull_view(g, "rsm".into(), VIEW_RSM, [0, 0, n, n])?;
                let mut p = g.add_raster_pass("rsm");
                for id in ids {
                    p.color_attachment(id, LoadOp::Clear, [0.0; 4])?;
                }
                p.depth_attachment(rsm_depth, LoadOp::Clear, 1.0, true)?;
                geo.declare_reads_culled(&mut p, culled)?;
                p.record(move |pc| geo.draw_all(pc, pipe, VIEW_RSM, culled));
                r.key = rsm_key.clone();
            }
            r.view = Some(v);
            rsm_ids = Some(ids);
        }

        // Light propagation volumes from the RSM.
        let mut lpv_out = None;
        let mut lpv_images = None;
        let mut sslpv_images: Option<[ImageId; 3]> = None;
        if reuse_lpv {
            if let Some(c) = &targets.lpv_cache {
                let names = ["lpv red (reused)", "lpv green (reused)", "lpv blue (reused)"];
                lpv_images = Some(std::array::from_fn(|i| {
                    imports.image_readonly(g, names[i], c.images[i].image(), c.images[i].state())
                }));
            }
        } else if let (Some(rsm), Some(v), false) = (rsm_ids, rsm_view, cascades.is_empty()) {
            // The sky light's height map: the scene's depth seen from straight above.
            let sky = match sky_vp {
                Some(view_proj) => {
                    // Whole texels per cell, so the per-cell reduction tiles the map exactly.
                    let texels_per_cell = (512 / s.lpv.size).clamp(1, 16);
                    let edge = s.lpv.size * texels_per_cell;
                    let height = g.create_image("lpv sky height", ImageDesc::d2(DEPTH_FORMAT, edge, edge));
                    let pipes = &self.depth;
                    let geo = geometry.clone();
                    let culled = geo.cull_view(g, "lpv sky height".into(), VIEW_SKY, [0, 0, edge, edge])?;
                    let mut p = g.add_raster_pass("lpv sky height");
                    p.depth_attachment(height, LoadOp::Clear, 1.0, true)?;
                    geo.declare_reads_culled(&mut p, culled)?;
                    p.record(move |pc| {
                        // A plain viewport, as the shadow tiles use, so texel (u, v) is NDC
                        // (2u − 1, 2v − 1) when the LPV pass samples it with the same matrix.
                        let vp = vk::Viewport {
                            x: 0.0,
                            y: 0.0,
                            width: edge as f32,
                            height: edge as f32,
                            min_depth: 0.0,
                            max_depth: 1.0,
                        };
                        let sc = vk::Rect2D {
                            offset: vk::Offset2D { x: 0, y: 0 },
                            extent: vk::Extent2D { width: edge, height: edge },
                        };
                        // SAFETY: inside the pass's rendering scope; the rectangle is the whole map.
                        unsafe {
                            pc.device().cmd_set_viewport(pc.cmd, 0, &[vp]);
                            pc.device().cmd_set_scissor(pc.cmd, 0, &[sc]);
                        }
                        geo.draw_depth(pc, pipes, VIEW_SKY, culled)?;
                        Ok(())
                    });
                    let radiance = s.sky.map(|c| c * s.lpv.sky);
                    let cell = cascades.last().map_or(1.0, |c| c.cell);
                    Some(crate::lpv::passes::SkyInput { height, view_proj, radiance, cell })
                }
                None => None,
            };
            let input = LpvInputs {
                sky,
                subsurface: false,
                rsm,
                rsm_size: targets.rsm.as_ref().map_or(0, |r| r.flux.info.extent[0]),
                rsm_vp: v.view_proj,
                rsm_light: frame.rsm_light,
                light: rsm_light_pos,
                flux_bound,
                camera: Some(crate::lpv::passes::CameraSurfels {
                    depth,
                    normal,
                    inv_view_proj: frame.view_proj.inverse(),
                    position: view.position,
                    pixel_angle: 2.0 * (view.fov_y * 0.5).tan() / h as f32,
                    size: [w, h],
                }),
            };
            // Persistent packed images, so the next frame can reuse them.
            let extent = [s.lpv.size, s.lpv.size, s.lpv.size * cascades.len() as u32];
            if targets.lpv_cache.as_ref().is_none_or(|c| c.images[0].info.extent != extent) {
                // Written by the seed copy and propagation, sampled by shading, copied by readback.
                let usage = vk::ImageUsageFlags::STORAGE
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_DST
                    | vk::ImageUsageFlags::TRANSFER_SRC;
                let info = ImageInfo::d3(crate::lpv::passes::GRID_FORMAT, extent, usage);
                let ctx = targets.hdr.context().clone();
                let img = |name| -> Result<PersistentImage> { Ok(PersistentImage::new(Image::new(&ctx, name, info)?)) };
                targets.lpv_cache = Some(LpvCache {
                    key: lpv_key.clone(),
                    images: [img("lpv red")?, img("lpv green")?, img("lpv blue")?],
                });
            }
            let packed = targets.lpv_cache.as_mut().map(|c| {
                c.key = lpv_key.clone();
                let names = ["lpv red", "lpv green", "lpv blue"];
                let images = std::array::from_fn(|i| c.images[i].import(g, imports, names[i]));
                PackedGrids { images, slots: stale.iter().map(|&i| i as u32).collect() }
            });
            let computed: Vec<_> = stale.iter().map(|&i| cascades[i]).collect();
            let out = self.lpv.add_passes(g, imports, &targets.lpv_stats, &s.lpv, &computed, &input, packed)?;
            if let Some([a, b]) = &targets.lpv_readback {
                let ids = [
                    imports.buffer(g, "lpv injected readback", a, ResourceState::UNDEFINED),
                    imports.buffer(g, "lpv accumulated readback", b, ResourceState::UNDEFINED),
                ];
                let src = [out.injected, out.images];
                let channel_bytes = a.size.min(b.size) / 3;
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
            }
            if sslpv_on {
                let sub = LpvSettings { occlusion: false, directional: false, sky: 0.0, ..s.lpv };
                let input = LpvInputs { camera: None, sky: None, subsurface: true, ..input };
                let out = self.lpv.add_passes(g, imports, &targets.sslpv_stats, &sub, &cascades, &input, None)?;
                sslpv_images = Some(out.images);
            }
            targets.lpv_scale = out.scale;
            lpv_images = Some(out.images);
            lpv_out = Some(out);
        }
        targets.lpv_cascades = cascades;

        // Deferred lighting.
        let hdr = targets.hdr.import(g, imports, "mesh hdr");
        let ldr = targets.ldr.import(g, imports, "mesh ldr");
        {
            // Texels each pixel reads: 4 G-buffer texels (~8 B), (2r+2)² shadow taps per light,
            // and 8 cells × 3 RGBA32F textures per LPV lookup (twice with damping).
            let pixels = u64::from(targets.size()[0]) * u64::from(targets.size()[1]);
            let lights = u64::from(scene.sun.is_some()) + scene.spots.len() as u64;
            let taps = u64::from(2 * s.pcf_radius + 2).pow(2);
            let lpv_bytes = if lpv_images.is_some() { 8 * 3 * 16 * (1 + u64::from(s.lpv.damping)) } else { 0 };
            // The subsurface grids, or (never read: LPV_SUBSURFACE false) the surface ones again.
            let lpv_grids = lpv_images.map(|imgs| [imgs, sslpv_images.unwrap_or(imgs)]);
            let shader = lighting_shader(lpv_images.is_some(), s.lpv_glossy, s.soft_shadows);
            // The pixels that blend two cascades, listed for the blend pass (lighting.comp).
            let blend_list = lpv_images.is_some().then(|| blend_list(g, pixels)).transpose()?;
            // The blend pass's dispatch needs rows of groups past the group limit × 64 pixels
            // (lighting.comp).
            let limit = targets.blend_group_limit.clamp(1, 65_535);
            let rows = pixels > u64::from(limit) * 64;
            let spec = [u32::from(s.lpv.damping), u32::from(sslpv_on), u32::from(rows), limit];
            let grids: Vec<ImageId> = lpv_grids.into_iter().flatten().flatten().collect();
            let b = LightingBindings {
                ubo,
                gbuffer: [depth, albedo, normal, specular, atlas],
                hdr,
                grids,
                blend_list,
                spec,
            };
            let work = Work { bytes: pixels * (4 * 8 + lights * taps * 4 + lpv_bytes + 16), ..Default::default() };
            b.bind(g.compute("lighting", shader).work(work), false).dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
            if let Some(list) = blend_list {
                b.bind(g.compute("cascade blend", &shaders::MESH_LIGHTING_COMP__LPV_BLEND), true)
                    .dispatch_indirect(list, 0)?;
            }
        }
        if s.fog.enabled {
            let input = super::fog::FogInputs {
                ubo,
                depth,
                atlas,
                hdr,
                lpv: lpv_images,
                scene_bounds: scene.bounds,
                size: [w, h],
                lights: u32::from(scene.sun.is_some()) + scene.spots.len().min(MAX_SPOTS) as u32,
            };
            super::fog::add_fog_pass(g, &s.fog, input)?;
        }
        if let Some(push) = sun_rays_constants(scene, view, &frame, s) {
            // Reads only the camera depth and each pixel's own HDR value, so it can add in place.
            let pixels = u64::from(w) * u64::from(h);
            g.compute("sun rays", &shaders::MESH_SUN_RAYS_COMP)
                .work(Work::bytes(pixels * (u64::from(s.sun_rays_samples) * 4 + 32)))
                .sampled(depth, Sampling::Nearest)
                .read_write(hdr)
                .push_bytes(push)
                .dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
        }
        let params = s.tonemap.params(s.exposure);
        crate::post::add_tonemap_pass(g, hdr, ldr, params, [w.div_ceil(8), h.div_ceil(8), 1])?;
        Ok(FrameImages { hdr, ldr, depth, normal, rsm: rsm_ids, lpv: lpv_out, lpv_images, lpv_reused: reuse_lpv })
    }
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

/// Push constants of the sun-rays pass, or `None` when it is off or the sun is absent or behind
/// the camera. Behind the camera the sun projects through the camera's centre to the wrong side
/// of the screen, so a blur toward that point would streak away from the real sun: no pass is
/// added rather than one that adds garbage (or zero at the cost of a full-screen dispatch).
fn sun_rays_constants(scene: &GpuScene, view: &View, frame: &FrameData, s: &MeshSettings) -> Option<Vec<u8>> {
    let sun = scene.sun.filter(|_| s.sun_rays)?;
    let to_sun = Vec3::from(sun.to_sun).normalize_or_zero();
    // Fade out over the last ~12° before the sun leaves the front hemisphere, so the rays do
    // not pop off as the pass stops being added.
    let fade = (to_sun.dot(Vec3::from(view.forward)) / 0.2).clamp(0.0, 1.0);
    if fade <= 0.0 {
        return None;
    }
    let clip = frame.view_proj * to_sun.extend(0.0);
    let uv = clip.xy() / clip.w * 0.5 + 0.5;
    let k = s.sun_rays_intensity * fade / s.sun_rays_samples as f32;
    // The `Rays` block: two vec4 and the sample count, 36 bytes.
    let words: [u32; 9] = [
        uv.x.to_bits(),
        uv.y.to_bits(),
        0,
        0,
        (sun.irradiance[0] * k).to_bits(),
        (sun.irradiance[1] * k).to_bits(),
        (sun.irradiance[2] * k).to_bits(),
        s.sun_rays_decay.to_bits(),
        s.sun_rays_samples,
    ];
    Some(words.iter().flat_map(|x| x.to_le_bytes()).collect())
}

/// What every raster pass binds: the frame buffer, vertices, indices and material textures.
#[derive(Clone)]
struct Geometry<'a> {
    scene: &'a GpuScene,
    ubo: BufferId,
    vb: BufferId,
    /// The scene's compact positions ([`GpuScene::positions`]), which opaque depth draws read.
    positions: BufferId,
    ib: BufferId,
    textures: Vec<ImageId>,
    /// Cull the back faces of single-sided materials.
    cull: bool,
    /// The scene's culling chunks and the counters of kept triangles, when each view's
    /// triangles are culled before it draws.
    culling: Option<[BufferId; 2]>,
    /// The device draws a mesh's chunks in one indirect call.
    multi_draw: bool,
    /// The device's least subgroup size (the culling passes' workgroup).
    subgroup: u32,
}

impl<'a> Geometry<'a> {
    fn declare_reads(&self, p: &mut crate::graph::PassBuilder<'_, 'a>) -> Result<()> {
        p.read_buffer(self.ubo, Access::UniformRead(ShaderStage::AllGraphics))?;
        p.read_buffer(self.vb, Access::VertexBuffer)?;
        p.read_buffer(self.positions, Access::VertexBuffer)?;
        p.read_buffer(self.ib, Access::IndexBuffer)?;
        for &t in &self.textures {
            p.read_image(t, Access::Sampled(ShaderStage::Fragment))?;
        }
        Ok(())
    }

    /// [`Geometry::declare_reads`] plus a view's culled draws.
    fn declare_reads_culled(
        &self,
        p: &mut crate::graph::PassBuilder<'_, 'a>,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        self.declare_reads(p)?;
        culled.map_or(Ok(()), |c| c.declare_reads(p))
    }

    /// The faces `view`'s pipelines cull on single-sided materials. The camera's projection flips
    /// y so images come out upright; the light views' do not. A reflection swaps the framebuffer
    /// winding, so the same world-space back face is clockwise in one and counter-clockwise in
    /// the other.
    fn culled_faces(&self, view: u32) -> vk::CullModeFlags {
        match (self.cull, view == VIEW_CAMERA) {
            (false, _) => vk::CullModeFlags::NONE,
            (true, true) => vk::CullModeFlags::BACK,
            (true, false) => vk::CullModeFlags::FRONT,
        }
    }

    /// Adds `view`'s culling pass (named `{name} cull`) when views are culled.
    fn cull_view(
        &self,
        g: &mut GraphBuilder<'a>,
        name: String,
        view: u32,
        viewport: [u32; 4],
    ) -> Result<Option<CulledDraws>> {
        let Some([chunks, stats]) = self.culling else { return Ok(None) };
        // With the pipelines' counter-clockwise front face, back faces have negative area.
        let facing = match self.culled_faces(view) {
            vk::CullModeFlags::BACK => 1.0,
            vk::CullModeFlags::FRONT => -1.0,
            _ => 0.0,
        };
        let v = CullView { view, viewport, facing };
        let buffers = [self.positions, self.ib, chunks, stats];
        add_cull_pass(g, format!("{name} cull"), self.subgroup, self.scene, self.ubo, buffers, v).map(Some)
    }

    /// Draws every mesh from `view` with its material's textures and constants.
    fn draw_all(&self, pc: &PassContext<'_>, pipe: &Pipeline, view: u32, culled: Option<CulledDraws>) -> Result<()> {
        self.draw_with(pc, |_| (pipe, false), view, culled)
    }

    /// Draws every mesh's depth from `view`: a fragment stage only where an alpha mask needs it.
    fn draw_depth(
        &self,
        pc: &PassContext<'_>,
        pipes: &DepthPipelines,
        view: u32,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        let pick = |m: &GpuMaterial| {
            if m.flags & FLAG_ALPHA_MASK != 0 {
                (&pipes.masked, false)
            } else {
                (&pipes.opaque, true)
            }
        };
        self.draw_with(pc, pick, view, culled)
    }

    /// Draws every mesh's G-buffer from `view`: the map lookups only where a material has a map.
    fn draw_gbuffer(
        &self,
        pc: &PassContext<'_>,
        pipes: &GbufferPipelines,
        view: u32,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        let has_maps = |m: &GpuMaterial| m.flags & FLAG_NORMAL_MAP != 0 || m.specular_tex != WHITE;
        self.draw_with(pc, |m| (if has_maps(m) { &pipes.maps } else { &pipes.no_maps }, false), view, culled)
    }

    /// Draws every mesh from `view` with the pipeline `pick` gives its material (and whether
    /// that pipeline reads the compact positions instead of the interleaved vertices): all its
    /// triangles, or the survivors of `view`'s culling.
    fn draw_with<'p>(
        &self,
        pc: &PassContext<'_>,
        pick: impl Fn(&GpuMaterial) -> (&'p Pipeline, bool),
        view: u32,
        culled: Option<CulledDraws>,
    ) -> Result<()> {
        let dev = pc.device();
        let ib = culled.map_or(self.ib, |c| c.indices);
        // SAFETY: inside a rendering scope; the buffer was declared as read by this pass.
        unsafe { dev.cmd_bind_index_buffer(pc.cmd, pc.buffer(ib).raw, 0, vk::IndexType::UINT32) };
        let mut bound = None;
        // Material textures repeat and are mipmapped.
        let sampler = pc.ctx.pipelines().sampler(pc.ctx, Sampling::Repeat)?;
        let ubo = pc.buffer(self.ubo).raw;
        let faces = self.culled_faces(view);
        for d in &self.scene.draws {
            let m = &self.scene.materials[d.material];
            let cull = if m.double_sided { vk::CullModeFlags::NONE } else { faces };
            // SAFETY: every mesh pipeline has dynamic cull mode (`raster` in `MeshRenderer::new`).
            unsafe { dev.cmd_set_cull_mode(pc.cmd, cull) };
            let tex = |slot: usize| Descriptor::CombinedImageSampler(pc.image(self.textures[slot]).view, sampler);
            let ds = [Descriptor::UniformBuffer(ubo), tex(m.base_color_tex), tex(m.normal_tex), tex(m.specular_tex)];
            let push = draw_constants(m.base_color, m.specular, view, m.flags, m.cutoff, m.translucency);
            let (pipe, positions_only) = pick(m);
            let vertices = if positions_only { self.positions } else { self.vb };
            if bound != Some(vertices) {
                // SAFETY: inside the rendering scope; both vertex buffers are declared read.
                unsafe { dev.cmd_bind_vertex_buffers(pc.cmd, 0, &[pc.buffer(vertices).raw], &[0]) };
                bound = Some(vertices);
            }
            pipe.bind(pc.cmd, &ds, &push)?;
            match culled {
                // SAFETY: pipeline, descriptors and buffers bound above.
                None => unsafe { dev.cmd_draw_indexed(pc.cmd, d.index_count, 1, d.first_index, 0, 0) },
                Some(c) => {
                    let (buf, first) = (pc.buffer(c.draws).raw, u64::from(d.first_chunk) * u64::from(DRAW_STRIDE));
                    if self.multi_draw {
                        // SAFETY: as above; the mesh's chunks are its commands, declared IndirectArgs.
                        unsafe { dev.cmd_draw_indexed_indirect(pc.cmd, buf, first, d.chunk_count, DRAW_STRIDE) };
                    } else {
                        for k in 0..u64::from(d.chunk_count) {
                            // SAFETY: as above, one chunk's command at a time.
                            unsafe {
                                dev.cmd_draw_indexed_indirect(
                                    pc.cmd,
                                    buf,
                                    first + k * u64::from(DRAW_STRIDE),
                                    1,
                                    DRAW_STRIDE,
                                )
                            };
                        }
                    }
                }
            }
        }
        Ok(())
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
