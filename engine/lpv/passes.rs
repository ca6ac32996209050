//! The LPV's frame-graph passes: clear → inject (atomic int / float / gather / raster) → resolve
//! → geometry volume → propagate × steps (gather / scatter) into the accumulated grid, which
//! shading samples. Between passes the light lives in flat buffers (three padded channel blocks,
//! lpv/images.glsl) that gather steps read as texel buffers; the grids shading reads are three
//! RGBA32F 3D images. Every step's grid is a transient, so the graph's aliasing ping-pongs their
//! memory. One function declares them all because the variants share one uniform buffer, one
//! set of grid descriptors and one dispatch shape; each pass is a few lines of the shader-pass
//! builder.

use super::grid::Cascade;
use super::settings::{FixedPoint, Injection, LpvSettings, Propagation};
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, ImageKind, ShaderStage, Work};
use crate::shaders;
use crate::vk::{vk, Binding, Context, Descriptor, Pipeline, Sampling};
use crate::{Error, Result};
use glam::Mat4;

pub use super::frame::{
    CameraSurfels, LpvInputs, LpvOutput, LpvParams, LpvStats, PackedGrids, SkyInput, SkyPush, CAMERA_SURFEL_STRIDE,
};

/// Texel format of the light grids and the geometry volume image: four SH coefficients.
pub const GRID_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Fixed-point scale of the geometry volume (blocking potentials stay well below 2^11).
pub const GV_SCALE: f32 = 1048576.0;

/// The LPV's device-dependent state: the raster-injection pipeline (graphics pipelines are not
/// in the context's cache), and the device limits the variants need.
/// Every compute pass takes its pipeline from the context's cache by shader.
pub struct LpvPipelines {
    inject_raster: Option<Pipeline>,
    /// Grid slices a layered render may address on this device.
    raster_layers: u32,
    float_atomics: bool,
    /// Most bytes one storage-buffer descriptor may span (`maxStorageBufferRange`).
    max_storage_range: u64,
}

/// Copies three channel images whole, in transfer layouts: with `src_layers` > 1 a 2D array's
/// layers land on a 3D image's slices (Vulkan 1.1).
fn copy_channels(
    pc: &crate::graph::PassContext<'_>,
    src: [ImageId; 3],
    dst: [ImageId; 3],
    src_layers: u32,
    [width, height, depth]: [u32; 3],
) -> Result<()> {
    let sub = |layer_count| vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: 0,
        base_array_layer: 0,
        layer_count,
    };
    let region = [vk::ImageCopy {
        src_subresource: sub(src_layers),
        dst_subresource: sub(1),
        extent: vk::Extent3D { width, height, depth },
        ..Default::default()
    }];
    for (s, d) in src.into_iter().zip(dst) {
        // SAFETY: called from a transfer pass that declared `src` TransferSrc and `dst` TransferDst.
        unsafe {
            pc.device().cmd_copy_image(
                pc.cmd,
                pc.image(s).raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                pc.image(d).raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &region,
            )
        };
    }
    Ok(())
}

/// The buffer ↔ image copy of a whole 3D image of `extent` at byte `offset` of a flat buffer.
pub(crate) fn channel_region(offset: u64, [width, height, depth]: [u32; 3]) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        buffer_offset: offset,
        image_subresource: vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        image_extent: vk::Extent3D { width, height, depth },
        ..Default::default()
    }
}

/// Which way [`copy_flat`] copies.
#[derive(Clone, Copy)]
enum Flat {
    /// Flat buffer → the three images.
    ToImages,
    /// The three images → flat buffer.
    FromImages,
}

/// Copies between a flat buffer of three channel blocks (texel order, vec4 each) holding
/// `extent[2] / extent[0]` cascades of `extent[0]`³ cells and three 3D images whose cascade
/// slots `slots` name (cascade k of the buffer ↔ slot `slots[k]` of the images).
fn copy_flat(
    pc: &crate::graph::PassContext<'_>,
    dir: Flat,
    buffer: BufferId,
    images: [ImageId; 3],
    extent: [u32; 3],
    slots: &[u32],
) -> Result<()> {
    let channel_bytes = 16 * flat_channel(extent.iter().map(|&e| u64::from(e)).product::<u64>());
    let n = extent[0];
    let cascade_bytes = 16 * u64::from(n).pow(3);
    for (ch, img) in images.into_iter().enumerate() {
        let regions: Vec<vk::BufferImageCopy> = slots
            .iter()
            .enumerate()
            .map(|(k, &slot)| vk::BufferImageCopy {
                image_offset: vk::Offset3D { x: 0, y: 0, z: (slot * n) as i32 },
                ..channel_region(ch as u64 * channel_bytes + k as u64 * cascade_bytes, [n, n, n])
            })
            .collect();
        let (buf, image) = (pc.buffer(buffer).raw, pc.image(img).raw);
        // SAFETY: called from a transfer pass that declared the source TransferSrc and the
        // destination TransferDst; every slot lies inside the images.
        unsafe {
            match dir {
                Flat::ToImages => pc.device().cmd_copy_buffer_to_image(
                    pc.cmd,
                    buf,
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &regions,
                ),
                Flat::FromImages => pc.device().cmd_copy_image_to_buffer(
                    pc.cmd,
                    image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    buf,
                    &regions,
                ),
            }
        };
    }
    Ok(())
}

/// A pass over the RSM's texels: the parameters, the RSM images (nearest), then the buffers it
/// adds into with atomics.
fn rsm_pass<'g, 'a>(
    g: &'g mut GraphBuilder<'a>,
    name: String,
    shader: &'static crate::shaders::Shader,
    ubo: BufferId,
    rsm: &[ImageId],
    targets: &[BufferId],
) -> crate::graph::ComputePass<'g, 'a> {
    g.compute(name, shader)
        .uniform(ubo)
        .each(rsm.iter().copied(), |p, id| p.sampled(id, Sampling::Nearest))
        .each(targets.iter().copied(), |p, b| p.atomic(b))
}

/// Fixed-point scale for `flux_bound` (the most flux one cell can receive): the largest power of
/// two such that every coefficient of that cell still fits in an `i32` with a factor two to
/// spare; the thesis uses 1000.
pub fn fixed_point_scale(mode: FixedPoint, flux_bound: f32) -> f32 {
    match mode {
        FixedPoint::Thesis => 1000.0,
        FixedPoint::Auto => {
            let coeff = (flux_bound.max(1e-12) as f64) * super::sh::COS1 / std::f64::consts::PI;
            let room = (i32::MAX as f64) * 0.5 / coeff;
            2f64.powi(room.log2().floor().clamp(-60.0, 60.0) as i32) as f32
        }
    }
}

impl LpvPipelines {
    /// Checks what the device supports; builds the raster-injection pipeline where it can run.
    pub fn new(ctx: &Context) -> Result<Self> {
        // Raster injection blends 32-bit floats, which Vulkan leaves optional: ask the format.
        // SAFETY: the physical device belongs to this instance; a pure query.
        let props = unsafe {
            ctx.instance.get_physical_device_format_properties(ctx.physical_device, vk::Format::R32G32B32A32_SFLOAT)
        };
        let blendable = props
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND | vk::FormatFeatureFlags::SAMPLED_IMAGE);
        let limits = &ctx.info.limits;
        let inject_raster = if ctx.info.geometry_shader && blendable {
            let (ubo, tex) = (vk::DescriptorType::UNIFORM_BUFFER, vk::DescriptorType::COMBINED_IMAGE_SAMPLER);
            let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::GEOMETRY;
            let bindings = [
                Binding::new(0, ubo, stages),
                Binding::new(1, tex, vk::ShaderStageFlags::VERTEX),
                Binding::new(2, tex, vk::ShaderStageFlags::VERTEX),
                Binding::new(3, tex, vk::ShaderStageFlags::VERTEX),
            ];
            let desc = crate::vk::GraphicsDesc {
                color_formats: vec![vk::Format::R32G32B32A32_SFLOAT; 3],
                blend: crate::vk::Blend::Additive,
                topology: vk::PrimitiveTopology::POINT_LIST,
                ..Default::default()
            };
            let shaders =
                [&shaders::LPV_INJECT_RASTER_VERT, &shaders::LPV_INJECT_RASTER_GEOM, &shaders::LPV_INJECT_RASTER_FRAG];
            Some(Pipeline::graphics(ctx, &shaders, &bindings, 0, &desc)?)
        } else {
            None
        };
        Ok(Self {
            inject_raster,
            raster_layers: limits.max_framebuffer_layers.min(limits.max_image_array_layers),
            float_atomics: ctx.info.float_atomics,
            max_storage_range: u64::from(limits.max_storage_buffer_range),
        })
    }

    /// The variant's device requirements, as one clear error each.
    fn check_support(&self, s: &LpvSettings, cascades: usize) -> Result<()> {
        if s.injection == Injection::Raster && self.inject_raster.is_none() {
            return Err(Error::Input(
                "LPV: raster injection needs geometry shaders and RGBA32F blending, which this device lacks; use lpv_injection=atomic"
                    .into(),
            ));
        }
        let slices = s.size * cascades.min(4) as u32;
        if s.injection == Injection::Raster && slices > self.raster_layers {
            return Err(Error::Input(format!(
                "LPV: raster injection renders {slices} grid slices (lpv_size × cascades) but the device allows {} layers; lower lpv_size or lpv_cascades",
                self.raster_layers
            )));
        }
        let needs_float = s.injection == Injection::AtomicFloat || s.propagation == Propagation::Scatter;
        if needs_float && !self.float_atomics {
            return Err(Error::Input(
                "LPV: float-atomic injection and scatter propagation need VK_EXT_shader_atomic_float, which this device lacks; use lpv_injection=atomic and lpv_propagation=gather".into(),
            ));
        }
        // The light grids of all cascades are bound whole as storage buffers (48 bytes a cell).
        let bytes = flat_bytes(u64::from(s.size).pow(3) * cascades.min(4) as u64);
        if bytes > self.max_storage_range {
            return Err(Error::Input(format!(
                "LPV: lpv_size={} with {} cascades needs {} MiB light buffers, but this device binds at most {} MiB of a storage buffer (maxStorageBufferRange); lower lpv_size or lpv_cascades",
                s.size,
                cascades.min(4),
                bytes >> 20,
                self.max_storage_range >> 20
            )));
        }
        if s.directional && s.propagation == Propagation::Scatter {
            return Err(Error::Input(
                "LPV: directional propagation re-projects each cell's whole step, which only gather propagation computes in one place; use lpv_propagation=gather".into(),
            ));
        }
        Ok(())
    }

    /// Declares the LPV passes for `cascades` (at least one) and returns the accumulated grid, written
    /// into `packed`'s slots when given (persistent images that later frames may reuse) or into
    /// transients.
    #[allow(clippy::too_many_arguments)]
    pub fn add_passes<'a>(
        &'a self,
        g: &mut GraphBuilder<'a>,
        imports: &mut crate::graph::execute::Imports,
        stats: &LpvStats,
        s: &LpvSettings,
        cascades: &[Cascade],
        input: &LpvInputs,
        packed: Option<PackedGrids>,
    ) -> Result<LpvOutput> {
        s.validate()?;
        if cascades.is_empty() {
            return Err(Error::Input("LPV: no cascade overlaps the scene".into()));
        }
        self.check_support(s, cascades.len())?;
        let n = s.size;
        let count = cascades.len().min(4) as u32;
        let scale = match s.injection {
            Injection::AtomicInt => fixed_point_scale(s.fixed_point, input.flux_bound),
            _ => 1.0,
        };
        let flags = u32::from(s.occlusion)
            | (u32::from(s.fixed_point == FixedPoint::Thesis) << 1)
            | (u32::from(s.swap_face_weights) << 2)
            | (u32::from(input.subsurface) << 3);
        let tag = if input.subsurface { "sslpv" } else { "lpv" };
        let cam = input.camera;
        let (cam_pos, pixel_angle) = cam.map_or(([0.0; 3], 0.0), |c| (c.position, c.pixel_angle));
        let gbuffer = cam.map_or([0, 0], |c| c.size);
        let params = LpvParams {
            cascade: std::array::from_fn(|i| {
                let c = cascades.get(i).copied().unwrap_or(cascades[0]);
                [c.origin[0], c.origin[1], c.origin[2], c.cell]
            }),
            dims: [n, count, input.rsm_size, flags],
            params: [s.vpl_offset, scale, 1.0 / scale, GV_SCALE],
            rsm_vp: input.rsm_vp.to_cols_array(),
            rsm_light: input.rsm_light,
            light: [input.light[0], input.light[1], input.light[2], 0.0],
            inv_view_proj: cam.map_or(Mat4::IDENTITY, |c| c.inv_view_proj).to_cols_array(),
            camera: [cam_pos[0], cam_pos[1], cam_pos[2], pixel_angle],
            gbuffer: [gbuffer[0], gbuffer[1], CAMERA_SURFEL_STRIDE, u32::from(cam.is_some() && s.occlusion)],
        };
        let ubo_bytes = bytemuck::bytes_of(&params).to_vec();
        let ubo = g.create_buffer(format!("{tag} params"), BufferDesc::new(ubo_bytes.len() as u64));
        let stats_id =
            imports.buffer(g, &format!("{tag} stats"), &stats.buffer, crate::graph::ResourceState::UNDEFINED);
        // The host reads the counters after the frame: the export is the device → host barrier.
        g.export_buffer(stats_id, Some(Access::HostRead))?;

        let cells = (n as u64).pow(3) * count as u64;
        // Flat buffers for the passes that add with atomics: 12 values per cell (common.glsl).
        let flat_desc = BufferDesc::new(12 * cells * 4);
        let grid_desc = ImageDesc {
            format: GRID_FORMAT,
            extent: [n, n, n * count],
            kind: ImageKind::D3,
            mip_levels: 1,
            extra_usage: vk::ImageUsageFlags::empty(),
        };
        let grid = |g: &mut GraphBuilder<'a>, name: &str| -> [ImageId; 3] {
            ["red", "green", "blue"].map(|ch| g.create_image(format!("{name} {ch}"), grid_desc))
        };
        let int_grid =
            (s.injection == Injection::AtomicInt).then(|| g.create_buffer(format!("{tag} fixed point"), flat_desc));
        let float_grid =
            (s.injection == Injection::AtomicFloat).then(|| g.create_buffer(format!("{tag} float atomics"), flat_desc));
        // Geometry volume: integer atomics per source (RSM texels, camera pixels), 4 per lattice
        // point, then one padded float block per source and cascade (common.glsl).
        let gv_sources = if s.occlusion { 1 + u32::from(input.camera.is_some()) } else { 0 };
        let gv_buf =
            s.occlusion.then(|| g.create_buffer(format!("{tag} geometry volume"), BufferDesc::new(2 * 4 * cells * 4)));
        // Directional propagation: summed VPL normals, 4 integers per cell.
        let directional = s.directional && s.steps > 0;
        let normal_sums =
            directional.then(|| g.create_buffer(format!("{tag} normal sums"), BufferDesc::new(4 * cells * 4)));
        let m = n + 1;
        let gv_image = s.occlusion.then(|| {
            let desc = ImageDesc { extent: [m, m, m * count * gv_sources], ..grid_desc };
            g.create_image(format!("{tag} geometry volume (filtered)"), desc)
        });
        // Work the shaders issue, for profiles (bytes requested, not unique bytes: neighbours are
        // re-read by adjacent cells and mostly hit the cache).
        let texels = (input.rsm_size as u64).pow(2);
        // Per cell and step: the cell's 8 GV corners per source.
        let gv_bytes = 8 * 16 * u64::from(gv_sources);
        let scatter_work = Work { bytes: texels * 3 * 16, atomics: texels * count as u64 * 12, ..Default::default() };
        // Per step, averaged over a pair: 6 neighbours, the step, half an accumulation RMW and
        // half a previous-step read.
        let gather_step_work = Work { bytes: cells * (6 * 48 + 48 + 48 + 24 + gv_bytes), ..Default::default() };
        let scatter_step_work = Work { bytes: cells * (48 + gv_bytes), atomics: cells * 6 * 12, ..Default::default() };

        {
            let mut p = g.add_transfer_pass(format!("{tag} clear"));
            p.write_buffer(ubo, Access::TransferDst)?;
            p.write_buffer(stats_id, Access::TransferDst)?;
            let cleared: Vec<BufferId> =
                int_grid.into_iter().chain(float_grid).chain(gv_buf).chain(normal_sums).collect();
            for &b in &cleared {
                p.write_buffer(b, Access::TransferDst)?;
            }
            p.record(move |pc| {
                // SAFETY: transfer pass; every buffer was declared as written here.
                unsafe {
                    pc.device().cmd_update_buffer(pc.cmd, pc.buffer(ubo).raw, 0, &ubo_bytes);
                    pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(stats_id).raw, 0, vk::WHOLE_SIZE, 0);
                    for &b in &cleared {
                        pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(b).raw, 0, vk::WHOLE_SIZE, 0);
                    }
                }
                Ok(())
            });
        }

        let [pos, nrm, flux] = input.rsm;
        let near = Sampling::Nearest;
        let rsm_groups = [input.rsm_size.div_ceil(8), input.rsm_size.div_ceil(8), 1];
        // Cell passes run (8, 4, 2) workgroups (see the shaders): full 8-lane rows on llvmpipe.
        let cell_groups = [n.div_ceil(8), n.div_ceil(4), (n * count).div_ceil(2)];
        let rsm_pass =
            |g: &'_ mut GraphBuilder<'a>, name, shader, rsm: &[ImageId], targets: &[BufferId]| -> Result<()> {
                rsm_pass(g, name, shader, ubo, rsm, targets).dispatch(rsm_groups)?;
                Ok(())
            };
        // Injection ends in `inj_flat`, the injected light as a flat buffer (lpv/images.glsl) that
        // gather propagation reads; raster and gather injection write images and copy them there.
        let inj_flat = g.create_buffer(format!("{tag} injected (flat)"), BufferDesc::new(flat_bytes(cells)));
        let stacked = [n, n, n * count];
        // Transient grids hold the computed cascades in order.
        let identity: Vec<u32> = (0..count).collect();
        let mut raw = None;
        match s.injection {
            Injection::Raster => {
                let desc = ImageDesc { extent: [n, n, 1], kind: ImageKind::D2Array(n * count), ..grid_desc };
                let slices = ["red", "green", "blue"].map(|ch| g.create_image(format!("{tag} slices {ch}"), desc));
                let injected = grid(g, &format!("{tag} injection"));
                raw = Some(injected);
                if let Some(pipe) = &self.inject_raster {
                    let mut p = g.add_raster_pass(format!("{tag} inject (raster)"));
                    for id in slices {
                        p.color_attachment(id, crate::graph::LoadOp::Clear, [0.0; 4])?;
                    }
                    p.read_buffer(ubo, Access::UniformRead(ShaderStage::AllGraphics))?;
                    for id in [pos, nrm, flux] {
                        p.read_image(id, Access::Sampled(ShaderStage::Vertex))?;
                    }
                    let (points, instances) = (input.rsm_size * input.rsm_size, count);
                    p.record(move |pc| {
                        let nearest = pc.ctx.pipelines().sampler(pc.ctx, near)?;
                        let t = |id| Descriptor::CombinedImageSampler(pc.image(id).view, nearest);
                        let ds = [Descriptor::UniformBuffer(pc.buffer(ubo).raw), t(pos), t(nrm), t(flux)];
                        pipe.bind(pc.cmd, &ds, &[])?;
                        // SAFETY: inside the pass's rendering scope; the pipeline takes no vertex buffers.
                        unsafe { pc.device().cmd_draw(pc.cmd, points, instances, 0, 0) };
                        Ok(())
                    });
                }
                // Layers of a 2D array copy straight onto the slices of a 3D image (Vulkan 1.1).
                let mut p = g.add_transfer_pass(format!("{tag} resolve (raster)"));
                for i in 0..3 {
                    p.read_image(slices[i], Access::TransferSrc)?;
                    p.write_image(injected[i], Access::TransferDst)?;
                }
                let layers = n * count;
                p.record(move |pc| copy_channels(pc, slices, injected, layers, [n, n, layers]));
            }
            Injection::Gather => {
                let injected = grid(g, &format!("{tag} injection"));
                raw = Some(injected);
                // One dispatch per RSM tile (bounded loops, see gather_loop_iterations); the first
                // writes the grid, the others add to it.
                let tiles = input.rsm_size.div_ceil(GATHER_TILE).max(1);
                for ty in 0..tiles {
                    for tx in 0..tiles {
                        let first = tx == 0 && ty == 0;
                        let push = GatherTile {
                            origin: [(tx * GATHER_TILE) as i32, (ty * GATHER_TILE) as i32],
                            size: GATHER_TILE as i32,
                            accumulate: u32::from(!first),
                        };
                        let name = match tiles {
                            1 => format!("{tag} inject (gather)"),
                            _ => format!("{tag} inject (gather) tile {tx},{ty}"),
                        };
                        g.compute(name, &shaders::LPV_INJECT_GATHER_COMP)
                            .uniform(ubo)
                            .each([pos, nrm, flux], |p, id| p.sampled(id, near))
                            .each(injected, |p, id| if first { p.write(id) } else { p.read_write(id) })
                            .constants(&push)
                            .loop_bound(gather_loop_iterations(GATHER_TILE))
                            .dispatch(cell_groups)?;
                    }
                }
            }
            Injection::AtomicInt | Injection::AtomicFloat => {
                let int = s.injection == Injection::AtomicInt;
                let (shader, resolve, kind) = if int {
                    (&shaders::LPV_INJECT_COMP__INT, &shaders::LPV_RESOLVE_COMP__INT, "int")
                } else {
                    (&shaders::LPV_INJECT_COMP, &shaders::LPV_RESOLVE_COMP, "float")
                };
                let Some(target) = int_grid.or(float_grid) else {
                    return Err(Error::Graph("LPV: scatter injection without its buffer".into()));
                };
                let name = format!("{tag} inject (atomic {kind})");
                self::rsm_pass(g, name, shader, ubo, &[pos, nrm, flux], &[target, stats_id])
                    .work(scatter_work)
                    .dispatch(rsm_groups)?;
                let texel = if int { vk::Format::R32G32B32A32_SINT } else { GRID_FORMAT };
                g.compute(format!("{tag} resolve"), resolve)
                    .uniform(ubo)
                    .read_texels(target, texel)
                    .write(inj_flat)
                    .dispatch(cell_groups)?;
            }
        }
        if let Some(images) = raw {
            let mut p = g.add_transfer_pass(format!("{tag} injection flat copy"));
            for img in images {
                p.read_image(img, Access::TransferSrc)?;
            }
            p.write_buffer(inj_flat, Access::TransferDst)?;
            let slots = identity.clone();
            p.record(move |pc| copy_flat(pc, Flat::FromImages, inj_flat, images, stacked, &slots));
        }
        if let Some(gv) = gv_buf {
            let shader = &shaders::LPV_GV_INJECT_COMP;
            rsm_pass(g, format!("{tag} geometry volume"), shader, &[pos, nrm], &[gv])?;
        }
        if let (Some(gv), Some(cam)) = (gv_buf, input.camera) {
            let groups = cam.size.map(|v| v.div_ceil(CAMERA_SURFEL_STRIDE).div_ceil(8));
            g.compute(format!("{tag} geometry volume (camera)"), &shaders::LPV_GV_CAMERA_COMP)
                .uniform(ubo)
                .sampled(cam.depth, near)
                .sampled(cam.normal, near)
                .atomic(gv)
                .dispatch([groups[0], groups[1], 1])?;
        }
        // Sampled by propagation; none with occlusion off (its variants declare no GV binding).
        let gv_read = match (gv_buf, gv_image) {
            (Some(buf), Some(img)) => {
                g.compute(format!("{tag} geometry volume resolve"), &shaders::LPV_GV_RESOLVE_COMP)
                    .uniform(ubo)
                    .read(buf)
                    .write(img)
                    .dispatch([m.div_ceil(8), m.div_ceil(4), (m * count * gv_sources).div_ceil(2)])?;
                Some(img)
            }
            _ => None,
        };
        // Directional propagation's normal grid, before any dilation.
        let mut normals = None;
        if let Some(sums) = normal_sums {
            let shader = &shaders::LPV_NORMALS_COMP;
            rsm_pass(g, format!("{tag} normals"), shader, &[pos, nrm, flux], &[sums])?;
            let image = g.create_image(format!("{tag} normals"), grid_desc);
            g.compute(format!("{tag} normals resolve"), &shaders::LPV_DILATE_COMP__RESOLVE)
                .uniform(ubo)
                .read(sums)
                .write(image)
                .dispatch(cell_groups)?;
            normals = Some(image);
        }
        // The accumulated grid (what shading samples) starts as the injected light. Steps add
        // into a flat buffer (see lpv/images.glsl); one copy at the end makes the images.
        let (accum, slots) = match packed {
            Some(p) if p.slots.len() == count as usize => (p.images, p.slots),
            Some(_) => return Err(Error::Graph("LPV: packed grids need one slot per cascade".into())),
            None => (grid(g, &format!("{tag} accumulated")), identity.clone()),
        };
        // Its own copy where it differs from the injected light (the sky pass adds to the two
        // differently) or is added into (scatter, directional gather); plain gather starts from
        // the injected buffer itself (see gather_steps).
        let own_seed = input.sky.is_some() || s.propagation == Propagation::Scatter || directional;
        let seed = if !own_seed {
            inj_flat
        } else {
            let seed = g.create_buffer(format!("{tag} accumulated (flat)"), BufferDesc::new(flat_bytes(cells)));
            let mut p = g.add_transfer_pass(format!("{tag} seed"));
            p.read_buffer(inj_flat, Access::TransferSrc)?;
            p.write_buffer(seed, Access::TransferDst)?;
            p.record(move |pc| {
                let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size: flat_bytes(cells) }];
                // SAFETY: transfer pass; the source is declared TransferSrc, the target TransferDst.
                unsafe { pc.device().cmd_copy_buffer(pc.cmd, pc.buffer(inj_flat).raw, pc.buffer(seed).raw, &region) };
                Ok(())
            });
            seed
        };
        if let Some(sky) = input.sky {
            // One map texel per coarsest cell, keeping each block's highest surface.
            let reduced =
                g.create_image(format!("{tag} sky height (per cell)"), ImageDesc::d2(vk::Format::R32_SFLOAT, n, n));
            g.compute(format!("{tag} sky reduce"), &shaders::LPV_SKY_REDUCE_COMP)
                .sampled(sky.height, near)
                .write(reduced)
                // A cell's k × k texels, k ≤ 16, with the loops' exits.
                .loop_bound(16 * 17 + 1)
                .dispatch([n.div_ceil(8), n.div_ceil(8), 1])?;
            let [r, gr, b] = sky.radiance;
            let push = SkyPush { view_proj: sky.view_proj.to_cols_array(), radiance: [r, gr, b, sky.cell] };
            g.compute(format!("{tag} inject sky"), &shaders::LPV_SKY_COMP)
                .uniform(ubo)
                .sampled(reduced, near)
                .read_write(inj_flat)
                .read_write(seed)
                .constants(&push)
                // 4 elevation bands × 8 azimuths, each ray marched ≤ 511 steps, then 6 faces:
                // every loop with its exit.
                .loop_bound(4 * (8 * 513 + 1) + 1 + 7)
                .dispatch(cell_groups)?;
        }
        // The injected light as images, for scatter propagation and read-backs (culled when
        // nothing reads them).
        let injected = grid(g, &format!("{tag} injected"));
        {
            let mut p = g.add_transfer_pass(format!("{tag} injected copy"));
            p.read_buffer(inj_flat, Access::TransferSrc)?;
            for img in injected {
                p.write_image(img, Access::TransferDst)?;
            }
            let slots = identity.clone();
            p.record(move |pc| copy_flat(pc, Flat::ToImages, inj_flat, injected, stacked, &slots));
        }
        let accumulated = match s.propagation {
            Propagation::Gather => {
                let grids = GatherGrids {
                    ubo,
                    injected: inj_flat,
                    // Linear steps from the injection alone read integer injection's buffer
                    // itself (the resolve into `inj_flat` is then culled: nothing reads it).
                    injected_int: if own_seed { None } else { int_grid },
                    accum: seed,
                    gv: gv_read,
                    normals,
                    gv_sources,
                    grid_desc,
                    cell_groups,
                    sparse: s.sparse,
                };
                gather_steps(g, tag, s.steps, &grids, gather_step_work)?
            }
            Propagation::Scatter => {
                let mut src = injected;
                for step in 1..=s.steps {
                    let dst = grid(g, &format!("{tag} step {step}"));
                    let flat = g.create_buffer(format!("{tag} step {step} (scatter)"), flat_desc);
                    zero_fill(g, format!("{tag} clear step {step}"), [flat])?;
                    let shader = match gv_sources {
                        0 => &shaders::LPV_PROPAGATE_COMP__SCATTER,
                        1 => &shaders::LPV_PROPAGATE_COMP__SCATTER_OCC1,
                        _ => &shaders::LPV_PROPAGATE_COMP__SCATTER_OCC2,
                    };
                    g.compute(format!("{tag} propagate {step} (scatter)"), shader)
                        .work(scatter_step_work)
                        .uniform(ubo)
                        .each(src, |p, id| p.read(id))
                        .atomic(flat)
                        .each(gv_read, |p, id| p.read(id))
                        .dispatch(cell_groups)?;
                    g.compute(format!("{tag} accumulate {step}"), &shaders::LPV_RESOLVE_COMP__ACCUMULATE)
                        .uniform(ubo)
                        .read_texels(flat, GRID_FORMAT)
                        .each(dst, |p, id| p.write(id))
                        .read_write(seed)
                        .dispatch(cell_groups)?;
                    src = dst;
                }
                seed
            }
        };
        {
            let mut p = g.add_transfer_pass(format!("{tag} accumulated copy"));
            p.read_buffer(accumulated, Access::TransferSrc)?;
            for img in accum {
                p.write_image(img, Access::TransferDst)?;
            }
            p.record(move |pc| copy_flat(pc, Flat::ToImages, accumulated, accum, stacked, &slots));
        }
        Ok(LpvOutput { images: accum, injected, scale })
    }
}

/// Edge of the RSM tile one gather-injection dispatch reads: 128² texels, 16,650 loop iterations
/// per SIMD row at worst ([`gather_loop_iterations`]), a quarter of llvmpipe's limit; a 256² RSM
/// takes 4 dispatches, 512² 16.
pub const GATHER_TILE: u32 = 128;

/// Worst-case loop iterations of one SIMD row in one gather-injection dispatch over a `tile`²
/// tile: the projected box's 8 corners (+1 exit test), then at most `tile` rows (+1) of at most
/// `tile` texels (+1) each. Every lane's texel rectangle lies inside the tile, so the row's
/// loops, which run while any lane still loops, never run longer than one lane reading all of it.
pub fn gather_loop_iterations(tile: u32) -> u64 {
    let t = u64::from(tile);
    9 + (t + 1) + t * (t + 1)
}

/// Push constants of `inject_gather.comp`: the tile this dispatch reads.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GatherTile {
    origin: [i32; 2],
    size: i32,
    accumulate: u32,
}

/// Texels between a flat grid's channel blocks beyond the grid's size (`FLAT_PAD` in
/// lpv/common.glsl: a power-of-two stride put a cell's channels into the same cache sets).
pub const FLAT_PAD: u64 = 68;

/// Texels from one channel block of a flat grid of `texels` cells to the next.
pub fn flat_channel(texels: u64) -> u64 {
    texels + FLAT_PAD
}

/// Bytes of a flat grid of `texels` cells: three channel blocks of vec4.
pub fn flat_bytes(texels: u64) -> u64 {
    3 * 16 * flat_channel(texels)
}

/// What gather propagation reads and writes besides its own step grids.
struct GatherGrids {
    ubo: BufferId,
    /// The injected light of all cascades as a flat buffer (lpv/images.glsl).
    injected: BufferId,
    /// Integer injection's fixed-point buffer (12 values per cell, lpv/common.glsl), when the
    /// accumulation starts from the injected light alone (so never with directional steps):
    /// linear steps then read it in place of `injected` and `accum` (propagate.comp, SEED_INT).
    injected_int: Option<BufferId>,
    /// The accumulation's start as a flat buffer (lpv/images.glsl): the injected light, or its
    /// copy with the sky's share; the directional steps add into it.
    accum: BufferId,
    gv: Option<ImageId>,
    /// Directional propagation's undilated normal grid.
    normals: Option<ImageId>,
    gv_sources: u32,
    /// All cascades stacked along z.
    grid_desc: ImageDesc,
    /// Workgroups of a pass over every cell of every cascade.
    cell_groups: [u32; 3],
    /// Linear steps skip the bricks light has not reached (`lpv_sparse`).
    sparse: bool,
}

/// A transfer pass that fills `buffers` with zeros.
fn zero_fill<const N: usize>(g: &mut GraphBuilder<'_>, name: String, buffers: [BufferId; N]) -> Result<()> {
    let mut p = g.add_transfer_pass(name);
    for b in buffers {
        p.write_buffer(b, Access::TransferDst)?;
    }
    p.record(move |pc| {
        for b in buffers {
            // SAFETY: transfer pass writing the declared buffers.
            unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(b).raw, 0, vk::WHOLE_SIZE, 0) };
        }
        Ok(())
    });
    Ok(())
}

/// Bricks, the workgroups of a propagation step (8 × 4 × 2 cells), per cascade along each axis
/// (`brick_grid` in lpv/common.glsl).
fn brick_grid(n: u32) -> [u32; 3] {
    [n.div_ceil(8), n.div_ceil(4), n.div_ceil(2)]
}

/// Most bricks the activation pass looks at around each brick; longer step counts propagate
/// every brick (light has then reached most of the grid anyway).
const MAX_BRICK_WINDOW: u32 = 1024;

/// Push constants of `lpv/schedule.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SchedulePush {
    /// xyz: the radius in bricks within which an occupied brick's light arrives in the steps;
    /// w: the steps.
    window: [i32; 4],
}

/// What sparse steps read: per cascade and step, the list of bricks the step runs (in index
/// order) and its indirect dispatch.
#[derive(Clone, Copy)]
struct SparseSchedule {
    list: BufferId,
    commands: BufferId,
    /// Entries per list: a cascade's bricks.
    per_list: u32,
}

/// The passes of lpv/schedule.comp for `steps` linear gather steps over `count` cascades of
/// `n`³ cells; None when every step runs dense (a window past MAX_BRICK_WINDOW, or too many
/// bricks for the list pass's loop).
fn sparse_schedule(
    g: &mut GraphBuilder<'_>,
    tag: &str,
    x: &GatherGrids,
    steps: u32,
    n: u32,
    count: u32,
) -> Result<Option<SparseSchedule>> {
    let grid = brick_grid(n);
    // An occupied brick d bricks away along an axis of brick edge e is (d − 1)·e + 1 cells away.
    let window = [8, 4, 2].map(|edge| (steps.saturating_sub(1) / edge + 1) as i32);
    let scanned: u32 = window.iter().map(|r| (2 * r + 1) as u32).product();
    // The list pass loops over a cascade's bricks in one invocation (llvmpipe's loop limit).
    if scanned > MAX_BRICK_WINDOW || grid.iter().product::<u32>() >= 65_535 {
        return Ok(None);
    }
    let push = SchedulePush { window: [window[0], window[1], window[2], steps as i32] };
    let per = grid.iter().product::<u32>();
    let bricks = per * count;
    let buffer = |g: &mut GraphBuilder<'_>, what: &str, bytes: u32| {
        g.create_buffer(format!("{tag} bricks ({what})"), BufferDesc::new(u64::from(bytes)))
    };
    let occupied = buffer(g, "occupied", 4 * bricks);
    let first = buffer(g, "first step", 4 * bricks);
    let list = buffer(g, "lists", 4 * bricks * steps);
    let commands = buffer(g, "dispatches", 12 * count * steps);
    let groups = [bricks.div_ceil(8), 1, 1];
    let (occupancy, injected, format) = match x.injected_int {
        Some(b) => (&shaders::LPV_SCHEDULE_COMP__OCCUPANCY_INT, b, vk::Format::R32G32B32A32_SINT),
        None => (&shaders::LPV_SCHEDULE_COMP__OCCUPANCY, x.injected, GRID_FORMAT),
    };
    g.compute(format!("{tag} bricks occupied"), occupancy)
        .uniform(x.ubo)
        .read_texels(injected, format)
        .write(occupied)
        .constants(&push)
        .loop_bound(65)
        .dispatch(groups)?;
    let [rx, ry, rz] = window.map(|r| 2 * r as u64 + 1);
    g.compute(format!("{tag} bricks first step"), &shaders::LPV_SCHEDULE_COMP__ACTIVATION)
        .uniform(x.ubo)
        .read_texels(occupied, vk::Format::R32_UINT)
        .write(first)
        .constants(&push)
        // Three nested loops over the window, each with its exits.
        .loop_bound(rz * (ry * (rx + 1) + 1) + 1)
        .dispatch(groups)?;
    // One invocation per cascade and step, each looping over its cascade's bricks.
    g.compute(format!("{tag} bricks listed"), &shaders::LPV_SCHEDULE_COMP)
        .uniform(x.ubo)
        .read(first)
        .write(list)
        .write(commands)
        .constants(&push)
        .loop_bound(u64::from(per) + 1)
        .dispatch([(count * steps).div_ceil(8), 1, 1])?;
    Ok(Some(SparseSchedule { list, commands, per_list: per }))
}

/// Gather propagation: each step a dispatch that reads the previous step's flat buffer as
/// texels and writes its own (see lpv/images.glsl). Every step of a cascade runs before the next
/// cascade's first, so the cascade's grids and GV stay in the caches (with the GV 0.66× the time
/// at 4 × 32³). Linear steps accumulate by Horner's rule (propagate.comp: each adds the
/// injected light, the last the accumulation's start, into the returned buffer); directional
/// steps add pairs of steps into `x.accum`. With `x.sparse`, linear steps run only the bricks
/// light can have reached ([`sparse_schedule`]). Returns the accumulated grid's flat buffer.
fn gather_steps<'a>(
    g: &mut GraphBuilder<'a>,
    tag: &str,
    steps: u32,
    x: &GatherGrids,
    stacked_work: Work,
) -> Result<BufferId> {
    let [n, _, stacked] = x.grid_desc.extent;
    if steps == 0 {
        return Ok(x.accum);
    }
    let count = stacked / n;
    // Directional: the normal grid dilated one cell per step, for all cascades at once.
    let mut step_normals = Vec::new();
    let mut normals = x.normals;
    for step in 1..=steps {
        if let Some(prev) = normals {
            let next = g.create_image(format!("{tag} normals step {step}"), x.grid_desc);
            g.compute(format!("{tag} dilate {step}"), &shaders::LPV_DILATE_COMP)
                .uniform(x.ubo)
                .read(prev)
                .write(next)
                .dispatch(x.cell_groups)?;
            normals = Some(next);
        }
        step_normals.push(normals);
    }
    // Linear steps (all but directional) accumulate by Horner's rule (propagate.comp).
    let horner = x.normals.is_none();
    // Integer injection read in place.
    let int_seed = x.injected_int;
    let shader = match (x.normals.is_some(), x.gv_sources) {
        (false, 0) if int_seed.is_some() => &shaders::LPV_PROPAGATE_COMP__HORNER_INT,
        (false, 1) if int_seed.is_some() => &shaders::LPV_PROPAGATE_COMP__HORNER_INT_OCC1,
        (false, _) if int_seed.is_some() => &shaders::LPV_PROPAGATE_COMP__HORNER_INT_OCC2,
        (false, 0) => &shaders::LPV_PROPAGATE_COMP__HORNER,
        (false, 1) => &shaders::LPV_PROPAGATE_COMP__HORNER_OCC1,
        (false, _) => &shaders::LPV_PROPAGATE_COMP__HORNER_OCC2,
        (true, 0) => &shaders::LPV_PROPAGATE_COMP__DIRECTIONAL,
        (true, 1) => &shaders::LPV_PROPAGATE_COMP__DIRECTIONAL_OCC1,
        (true, _) => &shaders::LPV_PROPAGATE_COMP__DIRECTIONAL_OCC2,
    };
    // Linear steps run only the bricks light can have reached (lpv/schedule.comp). Their last
    // steps then write the accumulation in place of its start: a brick they skip holds what it
    // would compute, and each reads its own cells' start before writing them (any other reader
    // of that buffer, the injected light's when plain gather starts from it, was declared
    // earlier, and a cascade's steps read only its own part). Where the start is the fixed-point
    // buffer, or the source of a single step (which reads its neighbours), they write a zeroed
    // grid instead (a brick they skip has no injected light within reach: it computes zero).
    let sparse = match horner && x.sparse {
        true => sparse_schedule(g, tag, x, steps, n, count)?,
        false => None,
    };
    let total_bytes = flat_bytes(u64::from(n).pow(3) * u64::from(count));
    let in_place = int_seed.is_none() && !(steps == 1 && x.accum == x.injected);
    let accumulated = match (horner, sparse) {
        (true, Some(_)) if in_place => x.accum,
        (true, sparse) => {
            let acc = g.create_buffer(format!("{tag} accumulated (flat)"), BufferDesc::new(total_bytes));
            if sparse.is_some() {
                zero_fill(g, format!("{tag} clear accumulated"), [acc])?;
            }
            acc
        }
        (false, _) => x.accum,
    };
    // The float injected light and the accumulation's start, or the fixed-point buffer that
    // stands for both (step 1 then reads it through the seed binding, not its float source's).
    let (injected, seed, seed_format) = match int_seed {
        Some(b) => (b, b, vk::Format::R32G32B32A32_SINT),
        None => (x.injected, x.accum, GRID_FORMAT),
    };

    // Cascade by cascade: all steps of one cascade run before the next cascade's first, so its
    // step grids stay in the caches (every cascade in one dispatch saves ~0.13 ms of fixed cost
    // per dispatch, but on a 2-core EPYC with 1 MiB L2 per core its 4 × 32³ steps ran 0.8× as fast).
    let cells = u64::from(n).pow(3);
    let work = Work { bytes: stacked_work.bytes / u64::from(count), ..stacked_work };
    for c in 0..count {
        let suffix = if count == 1 { String::new() } else { format!(", cascade {c}") };
        let gather_name = |step: u32| format!("{tag} propagate {step} (gather{suffix})");
        // Sparse steps write a pair of buffers in turn, cleared first: the bricks a step skips
        // hold zeros, as they did two steps before (the bricks reached only grow).
        let pair = match sparse {
            Some(_) if steps > 1 => {
                let pair = [0, 1].map(|i| {
                    g.create_buffer(format!("{tag} steps {i} cascade {c} (flat)"), BufferDesc::new(flat_bytes(cells)))
                });
                zero_fill(g, format!("{tag} clear steps{suffix}"), pair)?;
                Some(pair)
            }
            _ => None,
        };
        // Step 1 reads the injected grid (all cascades); later steps the last step's grid.
        let mut src = (injected, true);
        for (step, step_normals) in (1..=steps).zip(step_normals.iter().copied()) {
            // Accumulate in pairs of steps (see propagate.comp); an odd last step alone.
            let accumulate = match (step % 2, step == steps) {
                (1, false) => 0,
                (1, true) => 1,
                _ => 2,
            };
            // The last step writes only the accumulation.
            let store = step < steps;
            let name = match count {
                1 => format!("{tag} step {step} (flat)"),
                _ => format!("{tag} step {step} cascade {c} (flat)"),
            };
            let last = step == steps;
            let out = match (horner, last, pair) {
                (true, true, _) => accumulated,
                (_, _, Some(pair)) => pair[(step % 2) as usize],
                _ => g.create_buffer(name, BufferDesc::new(flat_bytes(cells))),
            };
            let spec =
                [accumulate, u32::from(store), c, u32::from(src.1), u32::from(last), u32::from(sparse.is_some())];
            let pass = g.compute(gather_name(step), shader).work(work).specialize(&spec).uniform(x.ubo);
            let pass = pass.read_texels(src.0, GRID_FORMAT);
            // A sparse step leaves what it skips as it was.
            let pass = if sparse.is_some() { pass.read_write(out) } else { pass.write(out) };
            let pass = match horner {
                // Every step adds the injected light, the last one the accumulation's start.
                true => pass.read_texels(if last { seed } else { injected }, seed_format),
                false => pass.read_write(x.accum).read_texels(x.accum, GRID_FORMAT),
            };
            let pass = pass.each(x.gv, |p, id| p.read(id)).each(step_normals, |p, id| p.read(id));
            // Every Horner variant declares the brick list; dense steps never read it.
            let pass = match (horner, sparse) {
                (true, Some(s)) => pass.read(s.list),
                (true, None) => pass.read(injected),
                _ => pass,
            };
            // Step `step` of cascade c: list and dispatch c · steps + step − 1.
            let at = c * steps + step - 1;
            let pass = match (horner, sparse) {
                (true, Some(s)) => pass.constants(&(at * s.per_list)),
                (true, None) => pass.constants(&0u32),
                _ => pass,
            };
            match sparse {
                Some(s) => pass.dispatch_indirect(s.commands, 12 * u64::from(at))?,
                None => pass.dispatch([n.div_ceil(8), n.div_ceil(4), n.div_ceil(2)])?,
            }
            src = (out, false);
        }
    }
    Ok(accumulated)
}
