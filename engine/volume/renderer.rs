//! The volume renderers as frame-graph passes, plus the GPU state one volume carries: its
//! images in either layout (`layout`), the transfer-function table and the occupancy and
//! majorant grids. The uniform blocks are filled in `uniforms`, the marchers' bounds are in
//! `march_bounds`, the frame driver is in `frame`.

use super::camera::Camera;
use super::data::Volume;
use super::layout::{upload_ro, LayoutReport, VolumeImages, VolumeLayout};
use super::march_bounds::MarchKey;
use super::mc_loops::{check_loop_budget, BoundedPush};
use super::occlusion::{march_pass, MarchInputs};
use super::tf::{TransferFunction, TF_GRADIENTS, TF_VALUES};
use crate::error::{Error, Result};
use crate::graph::execute::Imports;
use crate::graph::{Access, BufferDesc, GraphBuilder, ImageDesc, ImageId, ResourceState};
use crate::shaders;
use crate::vk::{vk, Context, Image, ImageInfo, Sampling};
use glam::Vec3;

pub use super::settings::{McSettings, RenderSettings, RendererKind, TransmittanceEstimator};
pub use crate::post::ToneMap;

/// Voxels per occupancy block edge.
pub const BLOCK: u32 = 8;

/// GPU state of one volume: texture, transfer-function table, occupancy grid, pipelines.
pub struct VolumeRenderer {
    volume: Image,
    tf: Image,
    occupancy: Image,
    gradients: Image,
    /// The sparse layout's page table (a 1³ placeholder in the dense one).
    page_table: Image,
    majorants: Image,
    pub(crate) global_majorant: [f32; 2],
    stats: crate::vk::Buffer,
    pub(crate) dims: [u32; 3],
    pub(crate) grid: [u32; 3],
    /// Min/max normalized value per block, dilated by one voxel (trilinear footprint).
    block_ranges: Vec<[f32; 2]>,
    pub(crate) box_half: Vec3,
    /// Image-based lighting: the environment map on the GPU, if one is set.
    pub(crate) env: Option<super::envmap::EnvLight>,
    env_generation: u64,
    /// Largest |∇v| of the volume (hybrid scattering normalizes by it).
    pub(crate) max_gradient: f32,
    /// Voxel counts per transfer-function table cell (value along x, normalized gradient
    /// magnitude along y, `TF_VALUES × TF_GRADIENTS`): what the TF editor draws behind its widgets.
    pub histogram: Vec<u32>,
    tf_generation: u64,
    /// The transfer function's table differs between gradient rows: the Monte Carlo medium
    /// lookup must fetch the gradient magnitude (otherwise a specialization leaves it out).
    tf_gradient: bool,
    /// `march_samples` of the last (view-projection bits, size, step): a still camera, as in
    /// headless and progressive runs, pays for the per-pixel sum once.
    pub(crate) march_cache: std::sync::Mutex<Option<(MarchKey, u64)>>,
    /// Tracking steps per second measured on this device by Monte Carlo frames (f64 bits; 0:
    /// none yet), for `mc_budget=auto` (`super::mc_mode`).
    pub(crate) measured_steps_per_s: std::sync::atomic::AtomicU64,
    /// Fraction of occupancy blocks that are empty under the current transfer function.
    pub empty_fraction: f32,
    /// The layout the volume was stored in and what it takes on the device.
    pub layout: LayoutReport,
}

/// The images one frame produced.
#[derive(Clone, Copy, Debug)]
pub struct FrameImages {
    /// Linear HDR radiance: the progressive mean of this and earlier unchanged frames.
    pub hdr: ImageId,
    /// Tone-mapped sRGB.
    pub ldr: ImageId,
    /// ISO only: hit position (texture space, xyz) and ray distance (w, < 0 for a miss).
    pub iso_hit: Option<ImageId>,
    /// With `depth_threshold` set (EAM, LAO, DOS): (ray distance, NDC depth, hit 1/0, 0) per pixel.
    pub depth: Option<ImageId>,
}

const READ_ONLY: ResourceState = ResourceState {
    layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
    access: vk::AccessFlags2::NONE,
};

/// Where the page table stays: a storage image the marchers read.
const PAGE_TABLE_STATE: ResourceState = ResourceState {
    layout: vk::ImageLayout::GENERAL,
    stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
    access: vk::AccessFlags2::NONE,
};

/// Binding of `volume/common.glsl`'s page table (past every shader's own bindings).
pub const PAGE_TABLE_BINDING: u32 = 15;

impl VolumeRenderer {
    /// Uploads `volume` (normalized to [0,1] by its value range, R16_UNORM) and `tf`, in the
    /// layout `volume_layout=auto` chooses.
    pub fn new(ctx: &Context, volume: &Volume, tf: &TransferFunction) -> Result<Self> {
        Self::with_layout(ctx, volume, tf, VolumeLayout::Auto)
    }

    /// [`Self::new`] in `layout`.
    pub fn with_layout(ctx: &Context, volume: &Volume, tf: &TransferFunction, layout: VolumeLayout) -> Result<Self> {
        let dims = volume.dims;
        let images = VolumeImages::new(ctx, volume, layout)?;
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let grid = dims.map(|d| d.div_ceil(BLOCK));
        let occupancy = Image::new(ctx, "occupancy", ImageInfo::d3(vk::Format::R8_UINT, grid, usage))?;
        let majorants = Image::new(ctx, "majorant grid", ImageInfo::d3(vk::Format::R32G32_SFLOAT, grid, usage))?;
        let mut stats = crate::vk::Buffer::new(
            ctx,
            "volume stats",
            8,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            crate::vk::MemoryLocation::GpuToCpu,
        )?;
        stats.write_bytes(&[0; 8])?;
        let tf_img = Image::new(
            ctx,
            "transfer function",
            ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, TF_VALUES as u32, TF_GRADIENTS as u32, usage),
        )?;
        let ext = volume.extent();
        let largest = ext.iter().cloned().fold(f32::MIN, f32::max).max(f32::MIN_POSITIVE);
        let box_half = Vec3::from(ext) / largest * 0.5;
        let mut me = Self {
            tf_generation: 0,
            tf_gradient: true,
            env: None,
            env_generation: 0,
            max_gradient: images.max_gradient,
            histogram: images.histogram,
            volume: images.volume,
            tf: tf_img,
            occupancy,
            gradients: images.gradients,
            page_table: images.page_table,
            majorants,
            global_majorant: [0.0; 2],
            stats,
            dims,
            grid,
            block_ranges: images.block_ranges,
            box_half,
            empty_fraction: 0.0,
            march_cache: std::sync::Mutex::new(None),
            measured_steps_per_s: std::sync::atomic::AtomicU64::new(0),
            layout: images.report,
        };
        me.set_transfer_function(ctx, tf)?;
        Ok(me)
    }

    /// Replaces the transfer function: re-uploads its table and rebuilds the occupancy grid.
    pub fn set_transfer_function(&mut self, ctx: &Context, tf: &TransferFunction) -> Result<()> {
        tf.validate().map_err(|e| Error::Input(format!("transfer function: {e}")))?;
        let table = tf.bake();
        let bytes: Vec<u8> = table.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        upload_ro(ctx, &self.tf, &bytes)?;
        let max_ext = tf.max_extinction_per_value();
        let n = (TF_VALUES - 1) as f32;
        let occ: Vec<u8> = self
            .block_ranges
            .iter()
            .map(|&[lo, hi]| {
                let (a, b) = ((lo * n).floor() as usize, ((hi * n).ceil() as usize).min(TF_VALUES - 1));
                u8::from(max_ext[a..=b].iter().any(|&e| e > 0.0))
            })
            .collect();
        self.tf_gradient = table.chunks(TF_VALUES).any(|row| row != &table[..TF_VALUES]);
        // Majorant grid: per cell (min, max) extinction over every table texel the cell's
        // dilated value range touches, across all gradient rows — conservative for trilinear
        // interpolation of both the volume and the table.
        let (mut gmax, mut gmin) = (0.0f32, f32::MAX);
        let mut maj = Vec::with_capacity(self.block_ranges.len() * 8);
        for &[lo, hi] in &self.block_ranges {
            let (a, b) = ((lo * n).floor() as usize, ((hi * n).ceil() as usize).min(TF_VALUES - 1));
            let (mut mn, mut mx) = (f32::MAX, 0.0f32);
            for row in 0..TF_GRADIENTS {
                for texel in &table[row * TF_VALUES + a..=row * TF_VALUES + b] {
                    mn = mn.min(texel[3]);
                    mx = mx.max(texel[3]);
                }
            }
            gmax = gmax.max(mx);
            gmin = gmin.min(mn);
            maj.extend(mn.to_le_bytes());
            maj.extend(mx.to_le_bytes());
        }
        upload_ro(ctx, &self.majorants, &maj)?;
        self.global_majorant = [gmax, gmin.min(gmax)];
        self.tf_generation += 1;
        self.empty_fraction = occ.iter().filter(|&&o| o == 0).count() as f32 / occ.len().max(1) as f32;
        upload_ro(ctx, &self.occupancy, &occ)
    }

    /// Sets (or with `None` removes) the environment map the MC renderers use when
    /// `McSettings::env_map` is on: uploads it with its sampling distribution.
    pub fn set_environment(&mut self, ctx: &Context, map: Option<&super::envmap::EnvMap>) -> Result<()> {
        self.env = map.map(|m| super::envmap::EnvLight::new(ctx, m)).transpose()?;
        self.env_generation += 1;
        Ok(())
    }

    /// Half-extent of the volume's box in world units (largest axis spans 1).
    pub fn box_half(&self) -> Vec3 {
        self.box_half
    }

    /// Majorant violations counted by the Monte Carlo renderers so far (0 unless the grid is wrong).
    pub fn majorant_violations(&self) -> u32 {
        self.stats.mapped().map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).unwrap_or(0)
    }

    /// Filtered texel fetches the Monte Carlo renderers have counted so far (wrapping).
    pub(crate) fn fetch_counter(&self) -> u32 {
        self.stats.mapped().map(|b| u32::from_le_bytes([b[4], b[5], b[6], b[7]])).unwrap_or(0)
    }

    /// Global (max, min) extinction of the current transfer function over the volume.
    pub fn global_majorant(&self) -> [f32; 2] {
        self.global_majorant
    }

    /// Declares this frame's passes: parameter upload, the renderer, and tone mapping into the
    /// imported `ldr` (and `hdr`, persistent so it can be read back as linear HDR).
    pub fn add_passes<'a>(
        &'a self,
        g: &mut GraphBuilder<'a>,
        imports: &mut Imports,
        targets: &mut Targets,
        camera: &Camera,
        s: &RenderSettings,
        frame: u64,
    ) -> Result<FrameImages> {
        s.validate()?;
        if s.mc.budget == super::settings::BUDGET_AUTO && matches!(s.renderer, RendererKind::Mcs | RendererKind::Mcm) {
            // One whole path per frame would be unbounded; render_frame and record_frame resolve.
            return Err(Error::Input(
                "mc_budget=auto must be resolved (VolumeRenderer::resolve_mc) before a frame is built".into(),
            ));
        }
        let size = [targets.hdr.info.extent[0], targets.hdr.info.extent[1]];
        // Any change of what is rendered restarts the progressive mean. Bounded work's budget,
        // path cap and interleaving change only how much work a frame does, not the image the
        // paths converge to: a frame-time knob turned mid-run keeps the mean (switching bounded
        // work on or off does not, as the two keep different state).
        let what = match s.mc_bounded() {
            true => RenderSettings {
                mc: McSettings { budget: 1, paths_per_frame: 1, frame_ms: 0.0, interleave: 1, ..s.mc },
                ..*s
            },
            false => *s,
        };
        let key = format!("{camera:?}{what:?}{}{size:?}{}", self.tf_generation, self.env_generation);
        if key != targets.key {
            targets.key = key;
            targets.samples = 0;
        }
        targets.samples = targets.samples.saturating_add(1);
        let n = targets.samples;
        let groups = [size[0].div_ceil(8), size[1].div_ceil(8), 1];
        let params_bytes = bytemuck::bytes_of(&self.params(camera, s, size, frame)).to_vec();
        let params = g.create_buffer("volume params", BufferDesc::new(params_bytes.len() as u64));
        let mc = self.mc_params(s);
        let mc_bytes = bytemuck::bytes_of(&mc).to_vec();
        let mc_params = g.create_buffer("mc params", BufferDesc::new(mc_bytes.len() as u64));
        let is_mc = matches!(s.renderer, RendererKind::Mcs | RendererKind::Mcm);
        let mut up = g.add_transfer_pass("upload params");
        up.write_buffer(params, Access::TransferDst)?;
        if is_mc {
            up.write_buffer(mc_params, Access::TransferDst)?;
        }
        up.record(move |pc| {
            // SAFETY: transfer pass outside rendering; each buffer is exactly as large as its data.
            unsafe {
                pc.device().cmd_update_buffer(pc.cmd, pc.buffer(params).raw, 0, &params_bytes);
                if is_mc {
                    pc.device().cmd_update_buffer(pc.cmd, pc.buffer(mc_params).raw, 0, &mc_bytes);
                }
            }
            Ok(())
        });
        let vol = imports.image_readonly(g, "volume", &self.volume, READ_ONLY);
        let tf = imports.image_readonly(g, "transfer function", &self.tf, READ_ONLY);
        let occ = imports.image_readonly(g, "occupancy", &self.occupancy, READ_ONLY);
        let grads = imports.image_readonly(g, "gradient magnitude", &self.gradients, READ_ONLY);
        let page_table = imports.image_readonly(g, "page table", &self.page_table, PAGE_TABLE_STATE);
        let accum = targets.hdr.import(g, imports, "accumulation");
        let ldr = targets.ldr.import(g, imports, "ldr");
        // Bounded-work Monte Carlo keeps its own mean (of completed paths) and writes it straight
        // into the accumulation: a copy pass would cost 3 ms a frame at 512².
        let bounded_mean = is_mc && s.mc_bounded();
        let hdr = match bounded_mean {
            true => accum,
            false => g.create_image("frame", ImageDesc::d2(vk::Format::R32G32B32A32_SFLOAT, size[0], size[1])),
        };
        let mut iso_hit = None;
        let depth = match (s.occlusion.depth_threshold, s.renderer) {
            (None, _) => None,
            (Some(_), RendererKind::Eam) if !s.precomputed_gradients => {
                return Err(Error::Input(
                    "--set depth_threshold: eam writes depth only with precomputed gradients".into(),
                ))
            }
            (Some(_), RendererKind::Eam | RendererKind::Lao | RendererKind::Dos) => {
                s.occlusion.validate()?;
                let img = targets.depth.as_ref().ok_or_else(|| {
                    Error::Input("depth_threshold: the targets have no depth image (Targets::enable_depth)".into())
                })?;
                Some(img.import(g, imports, "depth"))
            }
            (Some(_), r) => {
                return Err(Error::Input(format!(
                    "--set depth_threshold: only the eam, lao and dos renderers write depth, not {}",
                    r.name()
                )))
            }
        };
        let march = MarchInputs {
            params,
            volume: vol,
            tf,
            gradients: grads,
            occupancy: occ,
            hdr,
            size,
            exact_filter: s.exact_filter,
            page_table,
            sparse: self.layout.layout == VolumeLayout::Sparse,
        };
        // Filtered fetches per march sample (volume, transfer function, gradient) times the
        // samples of rays that neither terminate early nor skip: an upper bound.
        let samples = if matches!(s.renderer, RendererKind::Mcs | RendererKind::Mcm | RendererKind::Dos) {
            0
        } else {
            self.march_samples(camera, s, size)
        };
        let march_work =
            |per_sample: u64| crate::graph::Work { texel_fetches: samples * per_sample, ..Default::default() };
        // The plain marchers' loops are bounded by the box's diagonal over the step.
        let bounded_march = |per_sample: u64| crate::graph::Work {
            loop_iterations: self.march_loop_iterations(s),
            ..march_work(per_sample)
        };
        match s.renderer {
            RendererKind::Lao => {
                // Upper bound: volume, transfer function and gradient per march sample; the
                // occlusion rays' fetches depend on opacity and are not counted.
                let steps = self.march_steps(s);
                super::occlusion::add_lao_pass(g, march, &s.occlusion, depth, march_work(3), steps)?;
            }
            RendererKind::Dos => {
                super::occlusion::add_dos_passes(g, march, &s.occlusion, camera, self.box_half, depth)?;
            }
            RendererKind::Eam if s.precomputed_gradients && depth.is_some() => {
                let (d, t) = (depth.unwrap_or(hdr), s.occlusion.depth_threshold.unwrap_or(0.5));
                super::occlusion::add_eam_depth_pass(g, march, d, t, bounded_march(3))?;
            }
            RendererKind::Mip => {
                march_pass(g, "mip", &shaders::VOLUME_MIP_COMP, &march)
                    .work(bounded_march(1))
                    .write(hdr)
                    .dispatch(groups)?;
            }
            RendererKind::Iso => {
                let hit = g.create_image("iso hit", ImageDesc::d2(vk::Format::R32G32B32A32_SFLOAT, size[0], size[1]));
                iso_hit = Some(hit);
                march_pass(g, "iso hit", &shaders::VOLUME_ISO_COMP, &march)
                    .work(bounded_march(1))
                    .write(hit)
                    .dispatch(groups)?;
                march_pass(g, "iso shade", &shaders::VOLUME_ISO_SHADE_COMP, &march)
                    .read(hit)
                    .write(hdr)
                    .dispatch(groups)?;
            }
            RendererKind::Mcs | RendererKind::Mcm => {
                let maj = imports.image_readonly(g, "majorant grid", &self.majorants, READ_ONLY);
                let stats = imports.buffer(g, "volume stats", &self.stats, ResourceState::UNDEFINED);
                let env = match (&self.env, s.mc.env_map) {
                    (Some(e), true) => Some((
                        imports.image_readonly(g, "environment map", &e.texture, READ_ONLY),
                        imports.buffer_readonly(g, "environment cdf", &e.cdf),
                    )),
                    (None, true) => return Err(Error::Input("env_map is on but no environment map was loaded".into())),
                    _ => None,
                };
                let bounded = s.mc_bounded();
                let shader = match (bounded, env.is_some(), s.mc.hybrid > 0.0) {
                    (false, true, false) => &shaders::VOLUME_MC_COMP__ENV_MAP,
                    (false, true, true) => &shaders::VOLUME_MC_COMP__ENV_MAP_HYBRID,
                    (false, false, false) => &shaders::VOLUME_MC_COMP,
                    (false, false, true) => &shaders::VOLUME_MC_COMP__HYBRID,
                    (true, true, false) => &shaders::VOLUME_MC_BOUNDED_COMP__ENV_MAP,
                    (true, true, true) => &shaders::VOLUME_MC_BOUNDED_COMP__ENV_MAP_HYBRID,
                    (true, false, false) => &shaders::VOLUME_MC_BOUNDED_COMP,
                    (true, false, true) => &shaders::VOLUME_MC_BOUNDED_COMP__HYBRID,
                };
                let env_size = self.env.as_ref().filter(|_| env.is_some()).map(|e| e.size);
                let loops = if bounded { check_loop_budget(s.mc.budget, env_size)? } else { 0 };
                let paths = match (bounded, &targets.paths) {
                    (false, _) => None,
                    (true, Some(b)) => Some(imports.buffer(g, "mc paths", b, ResourceState::UNDEFINED)),
                    (true, None) => {
                        return Err(Error::Input(
                            "mc_budget: the targets have no path buffer (Targets::enable_paths)".into(),
                        ))
                    }
                };
                // The first frame of a mean starts every pixel's path afresh.
                // Interleaving: the first frame of a mean advances every tile by 1/interleave of
                // the budget (so it is no longer than the others), the next ones the tiles of one
                // subset each in turn by the whole budget.
                let k = s.mc.interleave.clamp(1, 16);
                let (interleave, budget) = match n == 1 {
                    true => (1, s.mc.first_budget()),
                    false => (k, s.mc.budget),
                };
                let push = BoundedPush {
                    budget,
                    reset: u32::from(n == 1),
                    cap: s.mc.paths_per_frame,
                    regroup: s.mc.regroup_percent.clamp(1, 100),
                    interleave,
                    subset: n.saturating_sub(2) % interleave,
                };
                let mc_groups = [groups[0].div_ceil(interleave), groups[1], 1];
                // Bounded work reads nothing of the image, but keeps the pixels it does not
                // advance this frame (interleaving): read-write, not write-only.
                let pass = march_pass(g, s.renderer.name(), shader, &march);
                let pass = if bounded { pass.read_write(hdr) } else { pass.write(hdr) };
                pass.sampled(maj, Sampling::Nearest)
                    .sampled(grads, Sampling::Linear)
                    .uniform(mc_params)
                    .atomic(stats)
                    .each(env, |p, (tex, cdf)| p.sampled(tex, Sampling::Nearest).read(cdf))
                    .each(paths, |p, b| p.read_write(b))
                    .each(paths.map(|_| push), |p, push| p.constants(&push))
                    .specialize(&[
                        u32::from(self.tf_gradient),
                        Self::mc_features(&mc, env.is_some()),
                        u32::from(s.exact_filter),
                        u32::from(march.sparse),
                    ])
                    .loop_bound(loops)
                    .dispatch(if bounded { mc_groups } else { groups })?;
                // The host reads the violation counter after the frame.
                g.export_buffer(stats, Some(Access::HostRead))?;
            }
            RendererKind::Eam if s.precomputed_gradients => {
                march_pass(g, "eam", &shaders::VOLUME_EAM_COMP__GRADIENT_TEXTURE, &march)
                    .work(bounded_march(3))
                    .write(hdr)
                    .sampled(occ, Sampling::Nearest)
                    .sampled(grads, Sampling::Linear)
                    .dispatch(groups)?;
            }
            RendererKind::Eam | RendererKind::EamBackToFront => {
                let shader = match s.renderer {
                    RendererKind::Eam => &shaders::VOLUME_EAM_COMP,
                    _ => &shaders::VOLUME_EAM_COMP__BACK_TO_FRONT,
                };
                // Volume, transfer function and six central-difference taps for |∇v|.
                march_pass(g, s.renderer.name(), shader, &march)
                    .work(bounded_march(8))
                    .write(hdr)
                    .sampled(occ, Sampling::Nearest)
                    .dispatch(groups)?;
            }
        }
        if !bounded_mean {
            g.compute("accumulate", &shaders::POST_ACCUMULATE_COMP)
                .read(hdr)
                .read_write(accum)
                .constants(&n)
                .dispatch(groups)?;
        }
        let params = s.tonemap.params(s.exposure);
        crate::post::add_tonemap_pass(g, accum, ldr, params, groups)?;
        Ok(FrameImages { hdr: accum, ldr, iso_hit, depth })
    }
}

pub use super::frame::{record_frame, render_frame, Targets};
pub use super::mc_loops::{mc_loop_iterations, LOOP_LIMIT};
pub use super::uniforms::{McParams, VolumeParams};
