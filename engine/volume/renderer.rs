//! The MIP / ISO / EAM volume renderers as frame-graph passes, plus the GPU copies of the
//! volume, its transfer-function table and the occupancy grid used for empty-space skipping.
//! Size: half of it is the GPU state one volume carries (uploads, occupancy and majorant grids,
//! the uniform blocks); the passes are a few lines each, the frame driver is in `frame`.

use super::camera::Camera;
use super::data::Volume;
use super::occlusion::{march_pass, MarchInputs};
use super::tf::{TransferFunction, TF_GRADIENTS, TF_VALUES};
use crate::error::{Error, Result};
use crate::graph::execute::Imports;
use crate::graph::{Access, BufferDesc, GraphBuilder, ImageDesc, ImageId, ResourceState};
use crate::shaders;
use crate::vk::{vk, Context, Image, ImageInfo, Sampling};
use glam::{Mat4, Vec3};

pub use super::settings::{McSettings, RenderSettings, RendererKind, TransmittanceEstimator};
pub use crate::post::ToneMap;

/// The `Params` uniform block every volume renderer reads (`shaders_glsl/volume/common.glsl`);
/// `tests/shader_pass.rs` checks each offset against the reflected block.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VolumeParams {
    /// Camera clip → world.
    pub inv_view_proj: [f32; 16],
    /// Box minimum (xyz), ray-march step (w).
    pub box_min: [f32; 4],
    /// Box maximum (xyz), iso value (w).
    pub box_max: [f32; 4],
    /// Towards the light (xyz), early-termination transmittance (w).
    pub light_dir: [f32; 4],
    /// Background (rgb), light intensity (a).
    pub background: [f32; 4],
    /// 1 / dims (xyz).
    pub voxel: [f32; 4],
    /// Empty-space skipping | jitter << 1, frame, block size.
    pub flags: [u32; 4],
    /// Occupancy grid dims.
    pub grid: [u32; 4],
}

/// The Monte Carlo renderers' `Mc` uniform block (`shaders_glsl/volume/tracking.glsl`, with the
/// `ENV_MAP`/`HYBRID` tail the plain variants do not declare).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct McParams {
    /// Towards the sun (xyz), on (w).
    pub sun_dir: [f32; 4],
    /// Sun radiance (rgb).
    pub sun_radiance: [f32; 4],
    /// Environment radiance (rgb), density scale (a).
    pub env_radiance: [f32; 4],
    /// Phase function kind, g, g2, w (floats as bits).
    pub phase: [u32; 4],
    /// Max events, transmittance debug mode | view-ray estimate << 1 | next-flight environment << 2,
    /// majorant grid, shadow estimator.
    pub opts: [u32; 4],
    /// Global majorant max/min, Russian-roulette start, majorant multiplier.
    pub global_majorant: [f32; 4],
    /// Point light position (xyz), on (w).
    pub point_pos: [f32; 4],
    /// Point light intensity (rgb).
    pub point_intensity: [f32; 4],
    /// Environment map intensity, cos/sin of its rotation, on.
    pub env_map: [f32; 4],
    /// Hybrid blend factor, 1 / max gradient magnitude.
    pub hybrid: [f32; 4],
}

/// Voxels per occupancy block edge.
pub const BLOCK: u32 = 8;

/// What `VolumeRenderer::march_samples` depends on: view-projection bits, size, step bits.
type MarchKey = ([u32; 16], [u32; 2], u32);

/// GPU state of one volume: texture, transfer-function table, occupancy grid, pipelines.
pub struct VolumeRenderer {
    volume: Image,
    tf: Image,
    occupancy: Image,
    gradients: Image,
    majorants: Image,
    global_majorant: [f32; 2],
    stats: crate::vk::Buffer,
    dims: [u32; 3],
    grid: [u32; 3],
    /// Min/max normalized value per block, dilated by one voxel (trilinear footprint).
    block_ranges: Vec<[f32; 2]>,
    box_half: Vec3,
    /// Image-based lighting: the environment map on the GPU, if one is set.
    env: Option<super::envmap::EnvLight>,
    env_generation: u64,
    /// Largest |∇v| of the volume (hybrid scattering normalizes by it).
    max_gradient: f32,
    /// Voxel counts per transfer-function table cell (value along x, normalized gradient
    /// magnitude along y, `TF_VALUES × TF_GRADIENTS`): what the TF editor draws behind its widgets.
    pub histogram: Vec<u32>,
    tf_generation: u64,
    /// The transfer function's table differs between gradient rows: the Monte Carlo medium
    /// lookup must fetch the gradient magnitude (otherwise a specialization leaves it out).
    tf_gradient: bool,
    /// `march_samples` of the last (view-projection bits, size, step): a still camera, as in
    /// headless and progressive runs, pays for the per-pixel sum once.
    march_cache: std::sync::Mutex<Option<(MarchKey, u64)>>,
    /// Tracking steps per second measured on this device by Monte Carlo frames (f64 bits; 0:
    /// none yet), for `mc_budget=auto` (`super::mc_mode`).
    pub(crate) measured_steps_per_s: std::sync::atomic::AtomicU64,
    /// Fraction of occupancy blocks that are empty under the current transfer function.
    pub empty_fraction: f32,
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

fn upload_ro(ctx: &Context, img: &Image, bytes: &[u8]) -> Result<()> {
    ctx.upload_image(
        img,
        bytes,
        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        vk::PipelineStageFlags2::COMPUTE_SHADER,
        vk::AccessFlags2::SHADER_SAMPLED_READ,
    )
}

impl VolumeRenderer {
    /// Uploads `volume` (normalized to [0,1] by its value range, R16_UNORM) and `tf`.
    pub fn new(ctx: &Context, volume: &Volume, tf: &TransferFunction) -> Result<Self> {
        let dims = volume.dims;
        let max3d = ctx.info.limits.max_image_dimension3_d;
        if dims.iter().any(|&d| d > max3d) {
            return Err(Error::Input(format!(
                "{}: {}x{}x{} exceeds this device's 3D texture limit {max3d}",
                volume.source, dims[0], dims[1], dims[2]
            )));
        }
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let vol_img = Image::new(ctx, "volume", ImageInfo::d3(vk::Format::R16_UNORM, dims, usage))?;
        let normalized = volume.normalized_u16();
        let bytes: Vec<u8> = normalized.iter().flat_map(|v| v.to_le_bytes()).collect();
        upload_ro(ctx, &vol_img, &bytes)?;
        let gradients = Image::new(ctx, "gradient magnitude", ImageInfo::d3(vk::Format::R16_UNORM, dims, usage))?;
        let grad = gradient_magnitudes(&normalized, dims);
        let max_gradient = grad.iter().copied().max().unwrap_or(0) as f32 / 65535.0;
        let grad_bytes: Vec<u8> = grad.iter().flat_map(|v| v.to_le_bytes()).collect();
        upload_ro(ctx, &gradients, &grad_bytes)?;
        let histogram = histogram(&normalized, &grad, max_gradient);
        let grid = dims.map(|d| d.div_ceil(BLOCK));
        let block_ranges = block_ranges(&normalized, dims, grid);
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
            max_gradient,
            histogram,
            volume: vol_img,
            tf: tf_img,
            occupancy,
            gradients,
            majorants,
            global_majorant: [0.0; 2],
            stats,
            dims,
            grid,
            block_ranges,
            box_half,
            empty_fraction: 0.0,
            march_cache: std::sync::Mutex::new(None),
            measured_steps_per_s: std::sync::atomic::AtomicU64::new(0),
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

    /// Most segments a camera ray can take through the box: its diagonal over the step.
    fn march_steps(&self, s: &RenderSettings) -> u64 {
        let step = f64::from(s.step.unwrap_or_else(|| self.default_step())).max(1e-12);
        (f64::from(self.diagonal()) / step).ceil().min(1e18) as u64
    }

    /// Length of the box's diagonal in world units.
    pub(crate) fn diagonal(&self) -> f32 {
        (2.0 * self.box_half).length()
    }

    /// Worst-case loop iterations of one SIMD row of the MIP, ISO and EAM passes: a camera ray
    /// crosses the box in at most [`Self::march_steps`] segments, plus each loop's exit (ISO adds
    /// its 12 bisection steps); 0 for the other renderers, which declare their own (LAO and DOS
    /// in their passes, bounded MC by its budget) or have none (one path per frame).
    pub fn march_loop_iterations(&self, s: &RenderSettings) -> u64 {
        let n = self.march_steps(s);
        match s.renderer {
            RendererKind::Mip | RendererKind::Eam | RendererKind::EamBackToFront => n + 1,
            RendererKind::Iso => n + 1 + 13,
            _ => 0,
        }
    }

    /// Default step: half a voxel along the largest axis.
    pub fn default_step(&self) -> f32 {
        0.5 / *self.dims.iter().max().unwrap_or(&1) as f32
    }

    /// Ray-march samples of one frame if no ray terminated early or skipped empty space: the
    /// sum over pixel-centre rays of (length inside the box / step). An upper bound on the
    /// samples the marchers take, for profiles.
    pub fn march_samples(&self, camera: &Camera, s: &RenderSettings, size: [u32; 2]) -> u64 {
        let inv = camera.inverse_view_projection(size[0] as f32 / size[1] as f32);
        let step = s.step.unwrap_or_else(|| self.default_step()).max(1e-6);
        let key: MarchKey = (inv.to_cols_array().map(f32::to_bits), size, step.to_bits());
        let mut cache = self.march_cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((k, total)) = *cache {
            if k == key {
                return total;
            }
        }
        let total = self.sum_chords(inv, step, size);
        *cache = Some((key, total));
        total
    }

    fn sum_chords(&self, inv: Mat4, step: f32, size: [u32; 2]) -> u64 {
        let (lo, hi) = (-self.box_half, self.box_half);
        let mut total = 0u64;
        for y in 0..size[1] {
            for x in 0..size[0] {
                let ndc = glam::Vec2::new(
                    (x as f32 + 0.5) / size[0] as f32 * 2.0 - 1.0,
                    -((y as f32 + 0.5) / size[1] as f32 * 2.0 - 1.0),
                );
                let o = inv.project_point3(ndc.extend(0.0));
                let d = (inv.project_point3(ndc.extend(1.0)) - o).normalize_or_zero();
                let (t0, t1) = ((lo - o) / d, (hi - o) / d);
                let near = t0.min(t1).max_element().max(0.0);
                let far = t0.max(t1).min_element();
                if far > near {
                    total += ((far - near) / step).ceil() as u64;
                }
            }
        }
        total
    }

    fn params(&self, camera: &Camera, s: &RenderSettings, size: [u32; 2], frame: u64) -> VolumeParams {
        let inv = camera.inverse_view_projection(size[0] as f32 / size[1] as f32);
        let (lo, hi) = (-self.box_half, self.box_half);
        let l = Vec3::from(s.light_dir).normalize_or(Vec3::Y);
        let step = s.step.unwrap_or_else(|| self.default_step());
        let [vx, vy, vz] = self.dims.map(|d| 1.0 / d as f32);
        let [bg_r, bg_g, bg_b] = s.background;
        VolumeParams {
            inv_view_proj: inv.to_cols_array(),
            box_min: [lo.x, lo.y, lo.z, step],
            box_max: [hi.x, hi.y, hi.z, s.iso],
            light_dir: [l.x, l.y, l.z, s.termination],
            background: [bg_r, bg_g, bg_b, s.light_intensity],
            voxel: [vx, vy, vz, 0.0],
            flags: [u32::from(s.empty_space_skipping) | (u32::from(s.jitter) << 1), frame as u32, BLOCK, s.mc.seed],
            grid: [self.grid[0], self.grid[1], self.grid[2], 0],
        }
    }

    fn mc_params(&self, s: &RenderSettings) -> McParams {
        let m = &s.mc;
        let sun = m.sun_dir.map(|d| Vec3::from(d).normalize_or(Vec3::Y));
        let (sd, on) = match sun {
            Some(d) => ([d.x, d.y, d.z], 1.0),
            None => ([0.0, 1.0, 0.0], 0.0),
        };
        let events = if s.renderer == RendererKind::Mcs { 1 } else { m.max_events.max(1) };
        let est = match m.transmittance {
            TransmittanceEstimator::Delta => 0,
            TransmittanceEstimator::Ratio => 1,
            TransmittanceEstimator::ResidualRatio => 2,
        };
        let [gmax, gmin] = self.global_majorant;
        let scale = m.density_scale;
        let (pos, point_on, intensity) = match m.point_light {
            Some((p, i)) => (p, 1.0, i),
            None => ([0.0; 3], 0.0, [0.0; 3]),
        };
        // Read only by the ENV_MAP / HYBRID variants (the plain shader's block is a prefix).
        let (sin, cos) = m.env_rotation_deg.to_radians().sin_cos();
        let env_on = self.env.as_ref().is_some_and(|e| e.sampleable) && m.env_intensity > 0.0;
        let inv_grad = if self.max_gradient > 0.0 { 1.0 / self.max_gradient } else { 0.0 };
        let [sr, sg, sb] = m.sun_radiance;
        let [er, eg, eb] = m.env_radiance;
        McParams {
            sun_dir: [sd[0], sd[1], sd[2], on],
            sun_radiance: [sr, sg, sb, 0.0],
            env_radiance: [er, eg, eb, m.density_scale],
            phase: m.phase,
            opts: [
                events,
                u32::from(m.debug_transmittance) | (u32::from(m.view_estimate) << 1) | (u32::from(m.env_flight) << 2),
                u32::from(m.majorant_grid),
                est,
            ],
            global_majorant: [gmax * scale, gmin * scale, m.roulette_start as f32, m.majorant_scale],
            point_pos: [pos[0], pos[1], pos[2], point_on],
            point_intensity: [intensity[0], intensity[1], intensity[2], 0.0],
            env_map: [m.env_intensity, cos, sin, f32::from(u8::from(env_on))],
            hybrid: [m.hybrid, inv_grad, 0.0, 0.0],
        }
    }

    /// The Monte Carlo shaders' `MC_FEATURES` constant (`tracking.glsl`): what these parameters
    /// switch on, read from them so the constant can never disagree with the run-time flags.
    /// Code for what is off is then removed when the pipeline is made, not run under a mask.
    fn mc_features(p: &McParams, env_map_variant: bool) -> u32 {
        let env = if env_map_variant { p.env_map[3] > 0.0 } else { p.env_radiance[..3].iter().any(|&c| c > 0.0) };
        let bits =
            [p.sun_dir[3] > 0.0, p.point_pos[3] > 0.0, env, p.opts[1] & 1 != 0, p.opts[1] & 2 != 0, p.opts[1] & 4 != 0];
        let flags = bits.iter().enumerate().fold(0, |acc, (i, &on)| acc | (u32::from(on) << i));
        // A field's all-ones value means "read it at run time", so a value that large stays so.
        let field = |v: u32, mask: u32| v.min(mask);
        flags | field(p.opts[2].min(1), 3) << 8 | field(p.opts[3], 3) << 10 | field(p.phase[0], 15) << 12
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

/// Push constants of `mc_bounded.comp`.
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct BoundedPush {
    budget: u32,
    reset: u32,
    /// Completed paths per pixel after which the pixel stops for this frame.
    cap: u32,
    /// Percentage of a row's lanes with an ended walk at which the row takes its events.
    regroup: u32,
    /// One in `interleave` tiles is advanced this frame: those of subset `subset`.
    interleave: u32,
    subset: u32,
}

/// llvmpipe ends all loops of a shader after 65,535 iterations per 8-lane row (silently: the
/// image would be wrong). `mc_bounded.comp`'s worst case per dispatch: at most `budget` events,
/// each lane's walk steps at most `budget` (8 lanes: 8 × budget for the row, plus one exit
/// iteration per event), and per event the environment map's two binary searches.
pub fn mc_loop_iterations(budget: u32, env_size: Option<[u32; 2]>) -> u64 {
    let search = |n: u32| u64::from(n.max(2).next_power_of_two().trailing_zeros()) + 2;
    let per_event = env_size.map_or(0, |[w, h]| search(w) + search(h));
    u64::from(budget) * (10 + per_event) + 1
}

/// The loop limit of llvmpipe's SIMD rows.
pub const LOOP_LIMIT: u64 = crate::graph::work::LLVMPIPE_LOOP_LIMIT;

/// The bounded pass's worst case (for the graph's `loop_bound`), or an error naming `mc_budget`
/// when it is over llvmpipe's limit: a clearer message than the graph's, and on every device.
fn check_loop_budget(budget: u32, env_size: Option<[u32; 2]>) -> Result<u64> {
    let worst = mc_loop_iterations(budget, env_size);
    if worst <= LOOP_LIMIT {
        return Ok(worst);
    }
    let per = mc_loop_iterations(1, env_size) - 1;
    Err(Error::Input(format!(
        "mc_budget={budget}: an 8-lane row could run {worst} loop iterations per frame{}, over llvmpipe's {LOOP_LIMIT} (it would silently cut the paths short); lower mc_budget to {} or less",
        env_size.map_or(String::new(), |[w, h]| format!(" with the {w}×{h} environment map")),
        (LOOP_LIMIT - 1) / per
    )))
}

pub use super::frame::{record_frame, render_frame, Targets};
use super::gpu_data::{block_ranges, gradient_magnitudes, histogram};
