//! The LPV's frame-graph passes: clear → inject (atomic int / float / gather / raster) → resolve
//! → geometry volume → propagate × steps (gather / scatter) into the accumulated grid, which
//! shading samples. Light grids are three RGBA32F 3D images (the layout `device_limits` measured
//! fastest); every step's grid is a transient, so the graph's aliasing ping-pongs their memory.

use super::grid::Cascade;
use super::settings::{FixedPoint, Injection, LpvSettings, Propagation};
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, ImageKind, ShaderStage, Work};
use crate::shaders;
use crate::vk::pipeline::push_words;
use crate::vk::{vk, Binding, Buffer, Context, Descriptor, Image, ImageInfo, MemoryLocation, Pipeline, Sampler};
use crate::{Error, Result};
use glam::Mat4;

/// Texel format of the light grids and the geometry volume image: four SH coefficients.
pub const GRID_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// How the LPV leaves the read-only images it samples between frames.
const READ_ONLY: crate::graph::ResourceState = crate::graph::ResourceState {
    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
    access: vk::AccessFlags2::NONE,
};

/// Fixed-point scale of the geometry volume (blocking potentials stay well below 2^11).
pub const GV_SCALE: f32 = 1048576.0;

/// Compute pipelines of every LPV variant.
pub struct LpvPipelines {
    inject_int: Pipeline,
    inject_float: Option<Pipeline>,
    inject_gather: Pipeline,
    inject_raster: Option<Pipeline>,
    /// Grid slices a layered render may address on this device.
    raster_layers: u32,
    resolve_int: Pipeline,
    resolve_float: Pipeline,
    resolve_accumulate: Pipeline,
    gv: Pipeline,
    gv_camera: Pipeline,
    gv_resolve: Pipeline,
    propagate_gather: Pipeline,
    propagate_scatter: Option<Pipeline>,
    propagate_directional: Pipeline,
    normals: Pipeline,
    normals_resolve: Pipeline,
    dilate: Pipeline,
    sky: Pipeline,
    sky_reduce: Pipeline,
    nearest: Sampler,
    linear: Sampler,
    /// A zero 1³ geometry volume, bound when occlusion is off (the shaders never read it then).
    no_gv: Image,
    float_atomics: bool,
}

/// The host-visible counters an LPV frame leaves behind.
pub struct LpvStats {
    buffer: Buffer,
}

impl LpvStats {
    /// Allocates the counters.
    pub fn new(ctx: &Context) -> Result<Self> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        Ok(Self { buffer: Buffer::new(ctx, "lpv stats", 8, usage, MemoryLocation::GpuToCpu)? })
    }

    fn word(&self, i: usize) -> u32 {
        self.buffer
            .mapped()
            .and_then(|b| b.get(4 * i..4 * i + 4))
            .map_or(0, |w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
    }

    /// Fixed-point additions that overflowed in the last frame (0 unless the scale is wrong).
    pub fn overflows(&self) -> u32 {
        self.word(0)
    }

    /// VPLs injected into the finest cascade in the last frame (scatter injection only).
    pub fn injected(&self) -> u32 {
        self.word(1)
    }
}

/// What the passes read: the RSM and its light.
#[derive(Clone, Copy, Debug)]
pub struct LpvInputs {
    /// RSM position, normal, flux.
    pub rsm: [ImageId; 3],
    /// RSM edge in texels.
    pub rsm_size: u32,
    /// The RSM light's world → clip.
    pub rsm_vp: Mat4,
    /// `[kind (0 sun, 1 spot), sun texel area or spot tan(half angle), RSM edge, 0]`.
    pub rsm_light: [f32; 4],
    /// Sun: direction the light travels; spot: position.
    pub light: [f32; 3],
    /// Upper bound of the flux per channel that can land in one cell (sets the fixed-point scale).
    pub flux_bound: f32,
    /// The camera's depth and normal buffers, for the geometry volume's second source.
    pub camera: Option<CameraSurfels>,
    /// Sky light, when on.
    pub sky: Option<SkyInput>,
    /// Build the subsurface LPV (the thesis' SSLPV): only translucent RSM texels, normals turned
    /// into the object, no geometry volume; its passes are named `sslpv …`.
    pub subsurface: bool,
}

/// What the sky-light pass reads.
#[derive(Clone, Copy, Debug)]
pub struct SkyInput {
    /// Depth of the scene seen from straight above (the height map).
    pub height: ImageId,
    /// The height map's world → clip.
    pub view_proj: Mat4,
    /// Sky radiance (RGB).
    pub radiance: [f32; 3],
    /// The coarsest cascade's cell edge in metres (the reduced map's texel).
    pub cell: f32,
}

/// What the camera-depth geometry volume reads.
#[derive(Clone, Copy, Debug)]
pub struct CameraSurfels {
    /// Depth (D32) and world normal images of the G-buffer.
    pub depth: ImageId,
    /// World normals.
    pub normal: ImageId,
    /// Camera clip → world.
    pub inv_view_proj: Mat4,
    /// Camera position.
    pub position: [f32; 3],
    /// One pixel's angle: 2·tan(fov/2)/height.
    pub pixel_angle: f32,
    /// G-buffer size.
    pub size: [u32; 2],
}

/// Every this-many pixels (per axis) of the depth buffer is a camera surfel.
pub const CAMERA_SURFEL_STRIDE: u32 = 2;

/// The light grids the passes leave: R, G, B SH images (RGBA32F 3D, cascades stacked along z).
#[derive(Clone, Debug)]
pub struct LpvOutput {
    /// The accumulated grid, which shading samples.
    pub images: [ImageId; 3],
    /// The injected grid before propagation (tests and tools).
    pub injected: [ImageId; 3],
    /// The fixed-point scale used (1 for float variants).
    pub scale: f32,
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
    /// Creates every pipeline the device supports (scatter variants need float atomics).
    pub fn new(ctx: &Context) -> Result<Self> {
        let c = vk::ShaderStageFlags::COMPUTE;
        let (ubo, ssbo, tex, img) = (
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::STORAGE_BUFFER,
            vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            vk::DescriptorType::STORAGE_IMAGE,
        );
        let b = |list: &[vk::DescriptorType]| -> Vec<Binding> {
            list.iter().enumerate().map(|(i, &t)| Binding::new(i as u32, t, c)).collect()
        };
        let inject_b = b(&[ubo, tex, tex, tex, ssbo, ssbo]);
        let float_atomics = ctx.info.float_atomics;
        let pipe = |s, bindings: &[Binding], push| Pipeline::compute(ctx, s, bindings, push);
        // Raster injection blends 32-bit floats, which Vulkan leaves optional: ask the format.
        // SAFETY: the physical device belongs to this instance; a pure query.
        let props = unsafe {
            ctx.instance.get_physical_device_format_properties(ctx.physical_device, vk::Format::R32G32B32A32_SFLOAT)
        };
        let blendable = props
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND | vk::FormatFeatureFlags::SAMPLED_IMAGE);
        let limits = &ctx.info.limits;
        Ok(Self {
            inject_int: pipe(&shaders::LPV_INJECT_COMP__INT, &inject_b, 0)?,
            inject_float: if float_atomics { Some(pipe(&shaders::LPV_INJECT_COMP, &inject_b, 0)?) } else { None },
            inject_gather: pipe(&shaders::LPV_INJECT_GATHER_COMP, &b(&[ubo, tex, tex, tex, img, img, img]), 0)?,
            inject_raster: if ctx.info.geometry_shader && blendable {
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
                let shaders = [
                    &shaders::LPV_INJECT_RASTER_VERT,
                    &shaders::LPV_INJECT_RASTER_GEOM,
                    &shaders::LPV_INJECT_RASTER_FRAG,
                ];
                Some(Pipeline::graphics(ctx, &shaders, &bindings, 0, &desc)?)
            } else {
                None
            },
            raster_layers: limits.max_framebuffer_layers.min(limits.max_image_array_layers),
            resolve_int: pipe(&shaders::LPV_RESOLVE_COMP__INT, &b(&[ubo, ssbo, img, img, img]), 0)?,
            resolve_float: pipe(&shaders::LPV_RESOLVE_COMP, &b(&[ubo, ssbo, img, img, img]), 0)?,
            resolve_accumulate: pipe(
                &shaders::LPV_RESOLVE_COMP__ACCUMULATE,
                &b(&[ubo, ssbo, img, img, img, img, img, img]),
                0,
            )?,
            gv: pipe(&shaders::LPV_GV_INJECT_COMP, &b(&[ubo, tex, tex, tex, ssbo]), 0)?,
            gv_camera: pipe(&shaders::LPV_GV_CAMERA_COMP, &b(&[ubo, tex, tex, tex, ssbo]), 0)?,
            gv_resolve: pipe(&shaders::LPV_GV_RESOLVE_COMP, &b(&[ubo, ssbo, img]), 0)?,
            propagate_gather: pipe(
                &shaders::LPV_PROPAGATE_COMP,
                &b(&[ubo, img, img, img, img, img, img, img, img, img, tex]),
                0,
            )?,
            propagate_scatter: if float_atomics {
                Some(pipe(&shaders::LPV_PROPAGATE_COMP__SCATTER, &b(&[ubo, img, img, img, ssbo, tex]), 0)?)
            } else {
                None
            },
            propagate_directional: pipe(
                &shaders::LPV_PROPAGATE_COMP__DIRECTIONAL,
                &b(&[ubo, img, img, img, img, img, img, img, img, img, tex, img]),
                0,
            )?,
            normals: pipe(&shaders::LPV_NORMALS_COMP, &b(&[ubo, tex, tex, tex, ssbo]), 0)?,
            normals_resolve: pipe(&shaders::LPV_DILATE_COMP__RESOLVE, &b(&[ubo, ssbo, img]), 0)?,
            dilate: pipe(&shaders::LPV_DILATE_COMP, &b(&[ubo, img, img]), 0)?,
            sky: pipe(&shaders::LPV_SKY_COMP, &b(&[ubo, tex, img, img, img, img, img, img]), 80)?,
            sky_reduce: pipe(&shaders::LPV_SKY_REDUCE_COMP, &b(&[tex, img]), 0)?,
            nearest: Sampler::clamped(ctx, false)?,
            linear: Sampler::clamped(ctx, true)?,
            no_gv: {
                let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
                let image = Image::new(ctx, "lpv no geometry volume", ImageInfo::d3(GRID_FORMAT, [1, 1, 1], usage))?;
                let s = READ_ONLY;
                ctx.upload_image(&image, &[0u8; 16], s.layout, s.stage, s.access)?;
                image
            },
            float_atomics,
        })
    }

    /// Declares the LPV passes for `cascades` (at least one) and returns the accumulated grid, written
    /// into `packed` when given (persistent images that later frames may reuse) or into transients.
    #[allow(clippy::too_many_arguments)]
    pub fn add_passes<'a>(
        &'a self,
        g: &mut GraphBuilder<'a>,
        imports: &mut crate::graph::execute::Imports,
        stats: &LpvStats,
        s: &LpvSettings,
        cascades: &[Cascade],
        input: &LpvInputs,
        packed: Option<[ImageId; 3]>,
    ) -> Result<LpvOutput> {
        s.validate()?;
        if cascades.is_empty() {
            return Err(Error::Input("LPV: no cascade overlaps the scene".into()));
        }
        if s.injection == Injection::Raster && self.inject_raster.is_none() {
            return Err(Error::Input(
                "LPV: raster injection needs geometry shaders and RGBA32F blending, which this device lacks; use lpv_injection=atomic"
                    .into(),
            ));
        }
        let slices = s.size * cascades.len().min(4) as u32;
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
        if s.directional && s.propagation == Propagation::Scatter {
            return Err(Error::Input(
                "LPV: directional propagation re-projects each cell's whole step, which only gather propagation computes in one place; use lpv_propagation=gather".into(),
            ));
        }
        let n = s.size;
        let count = cascades.len().min(4) as u32;
        let scale = match s.injection {
            Injection::AtomicInt => fixed_point_scale(s.fixed_point, input.flux_bound),
            _ => 1.0,
        };
        // The uniform block (common.glsl).
        let mut f: Vec<f32> = Vec::with_capacity(64);
        for i in 0..4 {
            let c = cascades.get(i).copied().unwrap_or(cascades[0]);
            f.extend([c.origin[0], c.origin[1], c.origin[2], c.cell]);
        }
        let flags = u32::from(s.occlusion)
            | (u32::from(s.fixed_point == FixedPoint::Thesis) << 1)
            | (u32::from(s.swap_face_weights) << 2)
            | (u32::from(input.subsurface) << 3);
        let tag = if input.subsurface { "sslpv" } else { "lpv" };
        let mut words: Vec<u32> = f.iter().map(|x| x.to_bits()).collect();
        words.extend([n, count, input.rsm_size, flags]);
        words.extend([s.vpl_offset, scale, 1.0 / scale, GV_SCALE].map(f32::to_bits));
        words.extend(input.rsm_vp.to_cols_array().map(f32::to_bits));
        words.extend(input.rsm_light.map(f32::to_bits));
        words.extend([input.light[0], input.light[1], input.light[2], 0.0].map(f32::to_bits));
        let cam = input.camera;
        words.extend(cam.map_or(Mat4::IDENTITY, |c| c.inv_view_proj).to_cols_array().map(f32::to_bits));
        let (p, a) = cam.map_or(([0.0; 3], 0.0), |c| (c.position, c.pixel_angle));
        words.extend([p[0], p[1], p[2], a].map(f32::to_bits));
        let size = cam.map_or([0, 0], |c| c.size);
        words.extend([size[0], size[1], CAMERA_SURFEL_STRIDE, u32::from(cam.is_some() && s.occlusion)]);
        let ubo_bytes = push_words(&words);
        let ubo = g.create_buffer(format!("{tag} params"), BufferDesc::new(ubo_bytes.len() as u64));
        let stats_id =
            imports.buffer(g, &format!("{tag} stats"), &stats.buffer, crate::graph::ResourceState::UNDEFINED);

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
        let cs = ShaderStage::Compute;
        let int_grid =
            (s.injection == Injection::AtomicInt).then(|| g.create_buffer(format!("{tag} fixed point"), flat_desc));
        let float_grid =
            (s.injection == Injection::AtomicFloat).then(|| g.create_buffer(format!("{tag} float atomics"), flat_desc));
        let injected = grid(g, &format!("{tag} injected"));
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
        let gv_fetches = 6 * u64::from(gv_sources); // per cell: one filtered fetch per face and source
        let scatter_work = Work { bytes: texels * 3 * 16, atomics: texels * count as u64 * 12, ..Default::default() };
        let gather_step_work =
            Work { bytes: cells * (6 * 48 + 48 + 2 * 48), texel_fetches: cells * gv_fetches, ..Default::default() };
        let scatter_step_work = Work {
            bytes: cells * 48,
            texel_fetches: cells * gv_fetches,
            atomics: cells * 6 * 12,
            ..Default::default()
        };

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

        let (nearest, linear) = (self.nearest.raw, self.linear.raw);
        let [pos, nrm, flux] = input.rsm;
        let rsm_groups = input.rsm_size.div_ceil(8);
        let cell_groups = [n.div_ceil(4), n.div_ceil(4), (n * count).div_ceil(4)];
        let dispatch = |pc: &crate::graph::PassContext<'_>, gx: u32, gy: u32, gz: u32| {
            // SAFETY: called right after a successful bind in a compute pass.
            unsafe { pc.device().cmd_dispatch(pc.cmd, gx, gy, gz) };
        };
        let storage = |pc: &crate::graph::PassContext<'_>, ids: &[ImageId]| -> Vec<Descriptor> {
            ids.iter().map(|&id| Descriptor::StorageImage(pc.image(id).view)).collect()
        };
        // A pass over the RSM's texels: the parameters, the RSM, then buffers it adds into.
        let rsm_pass = |g: &mut GraphBuilder<'a>,
                        name: String,
                        pipe: &'a Pipeline,
                        targets: Vec<BufferId>,
                        work: Option<Work>|
         -> Result<()> {
            let mut p = g.add_compute_pass(name);
            if let Some(w) = work {
                p.work(w);
            }
            p.read_buffer(ubo, Access::UniformRead(cs))?;
            for id in [pos, nrm, flux] {
                p.read_image(id, Access::Sampled(cs))?;
            }
            for &b in &targets {
                p.write_buffer(b, Access::StorageAtomic(cs))?;
            }
            p.record(move |pc| {
                let t = |id| Descriptor::CombinedImageSampler(pc.image(id).view, nearest);
                let mut ds = vec![Descriptor::UniformBuffer(pc.buffer(ubo).raw), t(pos), t(nrm), t(flux)];
                ds.extend(targets.iter().map(|&b| Descriptor::StorageBuffer(pc.buffer(b).raw)));
                pipe.bind(pc.cmd, &ds, &[])?;
                dispatch(pc, rsm_groups, rsm_groups, 1);
                Ok(())
            });
            Ok(())
        };
        // Injection.
        match s.injection {
            Injection::Raster => {
                let desc = ImageDesc { extent: [n, n, 1], kind: ImageKind::D2Array(n * count), ..grid_desc };
                let slices = [
                    g.create_image(format!("{tag} slices red"), desc),
                    g.create_image(format!("{tag} slices green"), desc),
                    g.create_image(format!("{tag} slices blue"), desc),
                ];
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
                let pipe = &self.inject_gather;
                let mut p = g.add_compute_pass(format!("{tag} inject (gather)"));
                p.read_buffer(ubo, Access::UniformRead(cs))?;
                for id in [pos, nrm, flux] {
                    p.read_image(id, Access::Sampled(cs))?;
                }
                for id in injected {
                    p.write_image(id, Access::StorageWrite(cs))?;
                }
                p.record(move |pc| {
                    let t = |id| Descriptor::CombinedImageSampler(pc.image(id).view, nearest);
                    let mut ds = vec![Descriptor::UniformBuffer(pc.buffer(ubo).raw), t(pos), t(nrm), t(flux)];
                    ds.extend(storage(pc, &injected));
                    pipe.bind(pc.cmd, &ds, &[])?;
                    dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                    Ok(())
                });
            }
            Injection::AtomicInt | Injection::AtomicFloat => {
                let int = s.injection == Injection::AtomicInt;
                let (pipe, resolve, name) = if int {
                    (&self.inject_int, &self.resolve_int, format!("{tag} inject (atomic int)"))
                } else {
                    (
                        self.inject_float.as_ref().unwrap_or(&self.inject_int),
                        &self.resolve_float,
                        format!("{tag} inject (atomic float)"),
                    )
                };
                let Some(target) = int_grid.or(float_grid) else {
                    return Err(Error::Input("LPV: scatter injection without its buffer".into()));
                };
                rsm_pass(g, name, pipe, vec![target, stats_id], Some(scatter_work))?;
                let mut p = g.add_compute_pass(format!("{tag} resolve"));
                p.read_buffer(ubo, Access::UniformRead(cs))?;
                p.read_buffer(target, Access::StorageRead(cs))?;
                for id in injected {
                    p.write_image(id, Access::StorageWrite(cs))?;
                }
                p.record(move |pc| {
                    let mut ds = vec![
                        Descriptor::UniformBuffer(pc.buffer(ubo).raw),
                        Descriptor::StorageBuffer(pc.buffer(target).raw),
                    ];
                    ds.extend(storage(pc, &injected));
                    resolve.bind(pc.cmd, &ds, &[])?;
                    dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                    Ok(())
                });
            }
        }
        if let Some(gv) = gv_buf {
            rsm_pass(g, format!("{tag} geometry volume"), &self.gv, vec![gv], None)?;
        }
        if let (Some(gv), Some(cam)) = (gv_buf, input.camera) {
            let pipe = &self.gv_camera;
            let mut p = g.add_compute_pass(format!("{tag} geometry volume (camera)"));
            p.read_buffer(ubo, Access::UniformRead(cs))?;
            for id in [cam.depth, cam.normal] {
                p.read_image(id, Access::Sampled(cs))?;
            }
            p.write_buffer(gv, Access::StorageAtomic(cs))?;
            let groups = cam.size.map(|v| v.div_ceil(CAMERA_SURFEL_STRIDE).div_ceil(8));
            p.record(move |pc| {
                let t = |id| Descriptor::CombinedImageSampler(pc.image(id).view, nearest);
                let ds = [
                    Descriptor::UniformBuffer(pc.buffer(ubo).raw),
                    t(cam.depth),
                    t(cam.normal),
                    t(cam.normal),
                    Descriptor::StorageBuffer(pc.buffer(gv).raw),
                ];
                pipe.bind(pc.cmd, &ds, &[])?;
                dispatch(pc, groups[0], groups[1], 1);
                Ok(())
            });
        }
        let gv_sampled = match (gv_buf, gv_image) {
            (Some(buf), Some(img)) => {
                let pipe = &self.gv_resolve;
                let mut p = g.add_compute_pass(format!("{tag} geometry volume resolve"));
                p.read_buffer(ubo, Access::UniformRead(cs))?;
                p.read_buffer(buf, Access::StorageRead(cs))?;
                p.write_image(img, Access::StorageWrite(cs))?;
                let groups = [m.div_ceil(4), m.div_ceil(4), (m * count * gv_sources).div_ceil(4)];
                p.record(move |pc| {
                    let ds = [
                        Descriptor::UniformBuffer(pc.buffer(ubo).raw),
                        Descriptor::StorageBuffer(pc.buffer(buf).raw),
                        Descriptor::StorageImage(pc.image(img).view),
                    ];
                    pipe.bind(pc.cmd, &ds, &[])?;
                    dispatch(pc, groups[0], groups[1], groups[2]);
                    Ok(())
                });
                img
            }
            _ => imports.image_readonly(g, "lpv no geometry volume", &self.no_gv, READ_ONLY),
        };
        // Directional propagation's normal grid, before any dilation.
        let mut normals = None;
        if let Some(sums) = normal_sums {
            rsm_pass(g, format!("{tag} normals"), &self.normals, vec![sums], None)?;
            let image = g.create_image(format!("{tag} normals"), grid_desc);
            let pipe = &self.normals_resolve;
            let mut p = g.add_compute_pass(format!("{tag} normals resolve"));
            p.read_buffer(ubo, Access::UniformRead(cs))?;
            p.read_buffer(sums, Access::StorageRead(cs))?;
            p.write_image(image, Access::StorageWrite(cs))?;
            p.record(move |pc| {
                let ds = [
                    Descriptor::UniformBuffer(pc.buffer(ubo).raw),
                    Descriptor::StorageBuffer(pc.buffer(sums).raw),
                    Descriptor::StorageImage(pc.image(image).view),
                ];
                pipe.bind(pc.cmd, &ds, &[])?;
                dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                Ok(())
            });
            normals = Some(image);
        }
        // The accumulated grid (what shading samples) starts as the injected light.
        let accum = match packed {
            Some(images) => images,
            None => grid(g, &format!("{tag} accumulated")),
        };
        {
            let mut p = g.add_transfer_pass(format!("{tag} seed"));
            for i in 0..3 {
                p.read_image(injected[i], Access::TransferSrc)?;
                p.write_image(accum[i], Access::TransferDst)?;
            }
            p.record(move |pc| copy_channels(pc, injected, accum, 1, [n, n, n * count]));
        }
        if let Some(sky) = input.sky {
            // One map texel per coarsest cell, keeping each block's highest surface.
            let reduced =
                g.create_image(format!("{tag} sky height (per cell)"), ImageDesc::d2(vk::Format::R32_SFLOAT, n, n));
            {
                let pipe = &self.sky_reduce;
                let mut p = g.add_compute_pass(format!("{tag} sky reduce"));
                p.read_image(sky.height, Access::Sampled(cs))?;
                p.write_image(reduced, Access::StorageWrite(cs))?;
                p.record(move |pc| {
                    let ds = [
                        Descriptor::CombinedImageSampler(pc.image(sky.height).view, nearest),
                        Descriptor::StorageImage(pc.image(reduced).view),
                    ];
                    pipe.bind(pc.cmd, &ds, &[])?;
                    dispatch(pc, n.div_ceil(8), n.div_ceil(8), 1);
                    Ok(())
                });
            }
            let pipe = &self.sky;
            let mut p = g.add_compute_pass(format!("{tag} inject sky"));
            p.read_buffer(ubo, Access::UniformRead(cs))?;
            p.read_image(reduced, Access::Sampled(cs))?;
            for id in injected.into_iter().chain(accum) {
                p.write_image(id, Access::StorageReadWrite(cs))?;
            }
            let mut push = sky.view_proj.to_cols_array().to_vec();
            push.extend([sky.radiance[0], sky.radiance[1], sky.radiance[2], sky.cell]);
            let push = push_words(&push.iter().map(|x| x.to_bits()).collect::<Vec<u32>>());
            p.record(move |pc| {
                let mut ds = vec![
                    Descriptor::UniformBuffer(pc.buffer(ubo).raw),
                    Descriptor::CombinedImageSampler(pc.image(reduced).view, nearest),
                ];
                ds.extend(storage(pc, &[injected, accum].concat()));
                pipe.bind(pc.cmd, &ds, &push)?;
                dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                Ok(())
            });
        }
        let mut src = injected;
        for step in 0..s.steps {
            let dst = grid(g, &format!("{tag} step {}", step + 1));
            let gv_fetch = move |pc: &crate::graph::PassContext<'_>| {
                Descriptor::CombinedImageSampler(pc.image(gv_sampled).view, linear)
            };
            // Directional: dilate the normal grid one cell before the step uses it.
            let step_normals = match normals {
                Some(prev) => {
                    let next = g.create_image(format!("{tag} normals step {}", step + 1), grid_desc);
                    let pipe = &self.dilate;
                    let mut p = g.add_compute_pass(format!("{tag} dilate {}", step + 1));
                    p.read_buffer(ubo, Access::UniformRead(cs))?;
                    p.read_image(prev, Access::StorageRead(cs))?;
                    p.write_image(next, Access::StorageWrite(cs))?;
                    p.record(move |pc| {
                        let mut ds = vec![Descriptor::UniformBuffer(pc.buffer(ubo).raw)];
                        ds.extend(storage(pc, &[prev, next]));
                        pipe.bind(pc.cmd, &ds, &[])?;
                        dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                        Ok(())
                    });
                    normals = Some(next);
                    Some(next)
                }
                None => None,
            };
            match s.propagation {
                Propagation::Gather => {
                    let pipe =
                        if step_normals.is_some() { &self.propagate_directional } else { &self.propagate_gather };
                    let mut p = g.add_compute_pass(format!("{tag} propagate {} (gather)", step + 1));
                    p.work(gather_step_work);
                    if let Some(id) = step_normals {
                        p.read_image(id, Access::StorageRead(cs))?;
                    }
                    p.read_buffer(ubo, Access::UniformRead(cs))?;
                    for i in 0..3 {
                        p.read_image(src[i], Access::StorageRead(cs))?;
                        p.write_image(dst[i], Access::StorageWrite(cs))?;
                        p.write_image(accum[i], Access::StorageReadWrite(cs))?;
                    }
                    p.read_image(gv_sampled, Access::Sampled(cs))?;
                    p.record(move |pc| {
                        let mut ds = vec![Descriptor::UniformBuffer(pc.buffer(ubo).raw)];
                        ds.extend(storage(pc, &[src, dst, accum].concat()));
                        ds.push(gv_fetch(pc));
                        ds.extend(storage(pc, step_normals.as_slice()));
                        pipe.bind(pc.cmd, &ds, &[])?;
                        dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                        Ok(())
                    });
                }
                Propagation::Scatter => {
                    let pipe = self.propagate_scatter.as_ref().unwrap_or(&self.propagate_gather);
                    let flat = g.create_buffer(format!("{tag} step {} (scatter)", step + 1), flat_desc);
                    g.add_transfer_pass(format!("{tag} clear step {}", step + 1))
                        .write_buffer(flat, Access::TransferDst)?
                        .record(move |pc| {
                            // SAFETY: transfer pass writing the declared buffer.
                            unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(flat).raw, 0, vk::WHOLE_SIZE, 0) };
                            Ok(())
                        });
                    let mut p = g.add_compute_pass(format!("{tag} propagate {} (scatter)", step + 1));
                    p.work(scatter_step_work);
                    p.read_buffer(ubo, Access::UniformRead(cs))?;
                    for id in src {
                        p.read_image(id, Access::StorageRead(cs))?;
                    }
                    p.read_image(gv_sampled, Access::Sampled(cs))?;
                    p.write_buffer(flat, Access::StorageAtomic(cs))?;
                    p.record(move |pc| {
                        let mut ds = vec![Descriptor::UniformBuffer(pc.buffer(ubo).raw)];
                        ds.extend(storage(pc, &src));
                        ds.push(Descriptor::StorageBuffer(pc.buffer(flat).raw));
                        ds.push(gv_fetch(pc));
                        pipe.bind(pc.cmd, &ds, &[])?;
                        dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                        Ok(())
                    });
                    let acc = &self.resolve_accumulate;
                    let mut p = g.add_compute_pass(format!("{tag} accumulate {}", step + 1));
                    p.read_buffer(ubo, Access::UniformRead(cs))?;
                    p.read_buffer(flat, Access::StorageRead(cs))?;
                    for i in 0..3 {
                        p.write_image(dst[i], Access::StorageWrite(cs))?;
                        p.write_image(accum[i], Access::StorageReadWrite(cs))?;
                    }
                    p.record(move |pc| {
                        let mut ds = vec![
                            Descriptor::UniformBuffer(pc.buffer(ubo).raw),
                            Descriptor::StorageBuffer(pc.buffer(flat).raw),
                        ];
                        ds.extend(storage(pc, &[dst, accum].concat()));
                        acc.bind(pc.cmd, &ds, &[])?;
                        dispatch(pc, cell_groups[0], cell_groups[1], cell_groups[2]);
                        Ok(())
                    });
                }
            }
            src = dst;
        }
        Ok(LpvOutput { images: accum, injected, scale })
    }
}
