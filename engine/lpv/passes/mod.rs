//! The LPV's frame-graph passes: clear → inject (atomic int / float / gather / raster) → resolve
//! → geometry volume → propagate × steps (gather / scatter) into the accumulated grid, which
//! shading samples. Between passes the light lives in flat buffers (three padded channel blocks,
//! lpv/images.glsl) that gather steps read as texel buffers; the grids shading reads are three
//! RGBA32F 3D images, which the last linear gather step writes directly. Every step's grid is a
//! transient, so the graph's aliasing ping-pongs their memory. `add_passes` composes the
//! features, one file each: injection, geometry volume, sky, gather and scatter steps, the
//! sparse schedule, and the copies between flat buffers and images; `calibrate` measures on
//! the device which gather layout is faster.

pub mod calibrate;
mod copies;
pub(crate) mod gather;
mod geometry;
mod inject;
mod scatter;
mod schedule;
mod sky;

use super::grid::Cascade;
use super::settings::{FixedPoint, Injection, LpvSettings, Propagation, StepDispatch};
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, ImageKind};
use crate::shaders;
use crate::vk::{vk, Binding, Context, Pipeline};
use crate::{Error, Result};
use calibrate::Shape;
use glam::Mat4;

pub(crate) use copies::channel_region;
pub use copies::{flat_bytes, flat_channel, FLAT_PAD};
pub use inject::{gather_loop_iterations, GATHER_TILE};

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
    /// The device the layouts are measured on.
    ctx: Context,
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
            ctx: ctx.clone(),
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
        let tag = if input.subsurface { "sslpv" } else { "lpv" };
        let (ubo_bytes, scale) = params(s, cascades, input);
        let f = Frame::new(g, imports, stats, s, cascades.len().min(4) as u32, input, tag, ubo_bytes.len() as u64)?;
        let gv_sources = if s.occlusion { 1 + u32::from(input.camera.is_some()) } else { 0 };
        let targets = inject::AtomicTargets::new(g, &f, s, gv_sources);
        inject::clear(g, &f, ubo_bytes, &targets)?;
        let inj_flat = inject::inject(g, &f, self, s, &targets)?;
        let gv = geometry::geometry_volume(g, &f, &targets, gv_sources)?;
        let normals = geometry::normals(g, &f, &targets)?;
        // The accumulated grid (what shading samples): the caller's persistent slots or transients.
        let (accum, slots) = match packed {
            Some(p) if p.slots.len() == f.count as usize => (p.images, p.slots),
            Some(_) => return Err(Error::Graph("LPV: packed grids need one slot per cascade".into())),
            None => (f.grid(g, &format!("{tag} accumulated")), f.identity()),
        };
        // Its own start where it differs from the injected light (the sky pass adds to the two
        // differently) or is added into (scatter, directional gather).
        let directional = normals.is_some();
        let own_seed = input.sky.is_some() || s.propagation == Propagation::Scatter || directional;
        let seed = sky::seed(g, &f, inj_flat, own_seed)?;
        sky::sky(g, &f, inj_flat, seed)?;
        // The injected light as images, for scatter propagation and read-backs (culled when
        // nothing reads them).
        let injected = f.grid(g, &format!("{tag} injected"));
        f.copy_flat(g, "injected copy", inj_flat, injected, &f.identity())?;
        let x = gather::GatherGrids {
            ubo: f.ubo,
            injected: inj_flat,
            // Linear steps from the injection alone read integer injection's buffer itself (the
            // resolve into `inj_flat` is then culled: nothing reads it).
            injected_int: if own_seed { None } else { targets.int },
            accum: seed,
            gv,
            normals,
            gv_sources,
            grid_desc: f.grid_desc,
            cell_groups: f.cell_groups,
            sparse: s.sparse,
        };
        // Linear gather writes the images itself; the other variants leave a flat buffer.
        let flat = match s.propagation {
            Propagation::Gather if directional => Some(gather::directional_steps(g, tag, s.steps, &x)?),
            Propagation::Gather if s.steps > 0 => {
                let stacked = self.stacked(s, &f, gv_sources, x.injected_int.is_some())?;
                gather::horner_steps(g, tag, s.steps, &x, stacked, &gather::Target { images: accum, slots: &slots })?;
                None
            }
            Propagation::Gather => Some(seed),
            Propagation::Scatter => Some(scatter::scatter_steps(g, &f, s.steps, injected, seed, gv, gv_sources)?),
        };
        if let Some(flat) = flat {
            f.copy_flat(g, "accumulated copy", flat, accum, &slots)?;
        }
        Ok(LpvOutput { images: accum, injected, scale })
    }

    /// Whether gather steps dispatch every cascade at once: the setting, or where it leaves the
    /// choice to the device, whichever layout it ran faster (measured once per shape).
    fn stacked(&self, s: &LpvSettings, f: &Frame, gv_sources: u32, int_seed: bool) -> Result<bool> {
        match s.dispatch {
            StepDispatch::Stacked => return Ok(true),
            StepDispatch::Cascades => return Ok(false),
            // One cascade: the same dispatches either way, and only one layout runs sparse.
            StepDispatch::Auto if f.count < 2 => return Ok(false),
            StepDispatch::Auto => {}
        }
        let shape = Shape { n: f.n, cascades: f.count, steps: s.steps, gv_sources, int_seed };
        Ok(calibrate::cached(&self.ctx, shape)?.stacked())
    }
}

/// The uniform block's bytes and the fixed-point scale.
fn params(s: &LpvSettings, cascades: &[Cascade], input: &LpvInputs) -> (Vec<u8>, f32) {
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
    (bytemuck::bytes_of(&params).to_vec(), scale)
}

/// The light grids' images: `count` cascades of `n`³ cells stacked along z.
pub(crate) fn grid_desc(n: u32, count: u32) -> ImageDesc {
    ImageDesc {
        format: GRID_FORMAT,
        extent: [n, n, n * count],
        kind: ImageKind::D3,
        mip_levels: 1,
        extra_usage: vk::ImageUsageFlags::empty(),
    }
}

/// What every LPV pass of one frame shares.
pub(crate) struct Frame {
    /// Name prefix: `lpv`, or `sslpv` for the subsurface grids.
    tag: &'static str,
    ubo: BufferId,
    /// The counters the host reads after the frame.
    stats: BufferId,
    /// Cells per grid edge, and cascades computed.
    n: u32,
    count: u32,
    /// Cells of all computed cascades.
    cells: u64,
    /// All cascades stacked along z, four SH coefficients per texel.
    grid_desc: ImageDesc,
    /// Workgroups of a pass over every cell of every cascade: (8, 4, 2) cells each, full 8-lane
    /// rows on llvmpipe.
    cell_groups: [u32; 3],
    /// Workgroups of a pass over the RSM's texels, and the RSM (position, normal, flux).
    rsm_groups: [u32; 3],
    rsm: [ImageId; 3],
    rsm_size: u32,
    camera: Option<CameraSurfels>,
    sky: Option<SkyInput>,
}

impl Frame {
    #[allow(clippy::too_many_arguments)]
    fn new(
        g: &mut GraphBuilder<'_>,
        imports: &mut crate::graph::execute::Imports,
        stats: &LpvStats,
        s: &LpvSettings,
        count: u32,
        input: &LpvInputs,
        tag: &'static str,
        ubo_size: u64,
    ) -> Result<Self> {
        let n = s.size;
        let ubo = g.create_buffer(format!("{tag} params"), BufferDesc::new(ubo_size));
        let stats = imports.buffer(g, &format!("{tag} stats"), &stats.buffer, crate::graph::ResourceState::UNDEFINED);
        // The host reads the counters after the frame: the export is the device → host barrier.
        g.export_buffer(stats, Some(Access::HostRead))?;
        let grid_desc = grid_desc(n, count);
        Ok(Self {
            tag,
            ubo,
            stats,
            n,
            count,
            cells: u64::from(n).pow(3) * u64::from(count),
            grid_desc,
            cell_groups: [n.div_ceil(8), n.div_ceil(4), (n * count).div_ceil(2)],
            rsm_groups: [input.rsm_size.div_ceil(8), input.rsm_size.div_ceil(8), 1],
            rsm: input.rsm,
            rsm_size: input.rsm_size,
            camera: input.camera,
            sky: input.sky,
        })
    }

    /// Three channel images (red, green, blue) of every cascade.
    fn grid(&self, g: &mut GraphBuilder<'_>, name: &str) -> [ImageId; 3] {
        ["red", "green", "blue"].map(|ch| g.create_image(format!("{name} {ch}"), self.grid_desc))
    }

    /// The computed cascades in order: their slots in transient grids.
    fn identity(&self) -> Vec<u32> {
        (0..self.count).collect()
    }

    /// A transfer pass copying a flat buffer into three grid images at `slots`.
    fn copy_flat(
        &self,
        g: &mut GraphBuilder<'_>,
        what: &str,
        flat: BufferId,
        images: [ImageId; 3],
        slots: &[u32],
    ) -> Result<()> {
        copies::copy_to_images(g, format!("{} {what}", self.tag), flat, images, self.grid_desc.extent, slots)
    }
}
