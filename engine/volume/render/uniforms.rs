//! The uniform blocks the volume renderers read, filled from a renderer's state and settings.

use super::renderer::{RenderSettings, RendererKind, TransmittanceEstimator, VolumeRenderer};
use crate::volume::camera::Camera;
use glam::Vec3;

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
    /// Occupancy grid dims (the page table's in the sparse layout).
    pub grid: [u32; 4],
    /// Voxel dims (xyz).
    pub dims: [u32; 4],
    /// 1 / the sparse layout's atlas extent in texels (xyz).
    pub atlas: [f32; 4],
    /// Clip planes `(n, d)`, kept where `n·x <= d` (world units): the crop box's, then `clip…`.
    pub clip: [[f32; 4]; super::clip_settings::MAX_GPU_PLANES],
    /// Planes of `clip` in use (x); 0 leaves every ray interval the box's. y: 1 when the clipped
    /// part still shadows Monte Carlo paths (`clip_shadows=on`).
    pub clip_count: [u32; 4],
    /// Emission scale S and the temperature grid's range in kelvin (0, 0: none): EAM's colour
    /// with a temperature grid.
    pub emission: [f32; 4],
}

/// The Monte Carlo renderers' `Mc` uniform block (`shaders_glsl/volume/tracking.glsl`).
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
    /// Emission scale, albedo multiplier (emissive media), temperature range in kelvin (0, 0:
    /// no temperature grid).
    pub emission: [f32; 4],
}

impl VolumeRenderer {
    pub(crate) fn params(&self, camera: &Camera, s: &RenderSettings, size: [u32; 2], frame: u64) -> VolumeParams {
        let inv = camera.inverse_view_projection(size[0] as f32 / size[1] as f32);
        let (lo, hi) = (-self.box_half, self.box_half);
        let l = Vec3::from(s.light_dir).normalize_or(Vec3::Y);
        let step = s.step.unwrap_or_else(|| self.default_step());
        let [vx, vy, vz] = self.dims.map(|d| 1.0 / d as f32);
        let [bg_r, bg_g, bg_b] = s.background;
        let (clip, clip_count) = s.clip.gpu_planes();
        VolumeParams {
            inv_view_proj: inv.to_cols_array(),
            box_min: [lo.x, lo.y, lo.z, step],
            box_max: [hi.x, hi.y, hi.z, s.iso],
            light_dir: [l.x, l.y, l.z, s.termination],
            background: [bg_r, bg_g, bg_b, s.light_intensity],
            voxel: [vx, vy, vz, 0.0],
            flags: [u32::from(s.empty_space_skipping) | (u32::from(s.jitter) << 1), frame as u32, self.cell, s.mc.seed],
            grid: [self.grid[0], self.grid[1], self.grid[2], 0],
            // w: slot layers per atlas, where slots continue from one atlas into the next.
            dims: [
                self.dims[0],
                self.dims[1],
                self.dims[2],
                self.layout.image_texels[2] / crate::volume::data::bricks::SLOT,
            ],
            atlas: {
                let [x, y, z] = self.layout.image_texels.map(|t| 1.0 / t.max(1) as f32);
                [x, y, z, 0.0]
            },
            clip,
            clip_count: [clip_count, u32::from(s.clip.shadows && clip_count > 0), 0, 0],
            emission: {
                let [lo, hi] = self.temperature.as_ref().map_or([0.0; 2], |t| t.range);
                [s.mc.emission, 0.0, lo, hi]
            },
        }
    }

    pub(crate) fn mc_params(&self, s: &RenderSettings) -> McParams {
        let m = &s.mc;
        let sun = m.sun_dir.map(|d| Vec3::from(d).normalize_or(Vec3::Y));
        let (sd, on) = match sun {
            Some(d) => ([d.x, d.y, d.z], 1.0),
            None => ([0.0, 1.0, 0.0], 0.0),
        };
        let events = if s.renderer == RendererKind::Mcs { 1 } else { m.max_events.max(1) };
        let est = match s.transmittance_estimator() {
            TransmittanceEstimator::Delta => 0,
            // `transmittance_estimator` resolves Auto; the arm only completes the match.
            TransmittanceEstimator::Auto | TransmittanceEstimator::Ratio => 1,
            TransmittanceEstimator::ResidualRatio => 2,
        };
        let [gmax, gmin] = self.global_majorant;
        let scale = m.density_scale;
        let (pos, point_on, intensity) = match m.point_light {
            Some((p, i)) => (p, 1.0, i),
            None => ([0.0; 3], 0.0, [0.0; 3]),
        };
        // Read only by the ENV_MAP / HYBRID variants.
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
            emission: {
                let [lo, hi] = self.temperature.as_ref().map_or([0.0; 2], |t| t.range);
                [m.emission, m.albedo, lo, hi]
            },
        }
    }

    /// The Monte Carlo shaders' `MC_FEATURES` constant (`tracking.glsl`): what these parameters
    /// switch on, read from them so the constant can never disagree with the run-time flags.
    /// Code for what is off is then removed when the pipeline is made, not run under a mask.
    pub(crate) fn mc_features(p: &McParams, env_map_variant: bool) -> u32 {
        let env = if env_map_variant { p.env_map[3] > 0.0 } else { p.env_radiance[..3].iter().any(|&c| c > 0.0) };
        // Bit 7: emission or an albedo multiplier (bit 6, adaptive sampling, is the caller's).
        let emissive = p.emission[0] > 0.0 || p.emission[1] != 1.0;
        let bits = [
            p.sun_dir[3] > 0.0,
            p.point_pos[3] > 0.0,
            env,
            p.opts[1] & 1 != 0,
            p.opts[1] & 2 != 0,
            p.opts[1] & 4 != 0,
            false,
            emissive,
        ];
        let flags = bits.iter().enumerate().fold(0, |acc, (i, &on)| acc | (u32::from(on) << i));
        // A field's all-ones value means "read it at run time", so a value that large stays so.
        let field = |v: u32, mask: u32| v.min(mask);
        flags | field(p.opts[2].min(1), 3) << 8 | field(p.opts[3], 3) << 10 | field(p.phase[0], 15) << 12
    }
}
