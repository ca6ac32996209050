//! The volume's feature buffers (`volume/features.comp`, `post/features.glsl`): per pixel, from
//! the camera ray through its centre, the depth where the transmittance first falls below ½ (or
//! the expected first collision), the gradient normal and the transfer function's albedo there,
//! and the transmittance to the background. Written once per view; they are what the denoiser
//! may not blur across and what temporal reuse checks a reprojected history against.

use super::occlusion::{march_pass, MarchInputs};
use super::renderer::VolumeRenderer;
use super::settings::RenderSettings;
use crate::graph::{GraphBuilder, ImageId};
use crate::shaders;
use crate::vk::Sampling;
use crate::Result;

/// Most march steps of one camera ray (the step grows past it): 2,048 covers the diagonal of a
/// 512³ volume at half-voxel steps, far under llvmpipe's loop limit.
pub const MAX_STEPS: u32 = 2048;

/// Push constants of `volume/features.comp`.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct FeaturesPush {
    density: f32,
    tf_gradient: u32,
    max_steps: u32,
    pad: u32,
}

impl VolumeRenderer {
    /// The feature pass into `out` (RG32UI).
    pub(super) fn add_features_pass(
        &self,
        g: &mut GraphBuilder<'_>,
        march: &MarchInputs,
        s: &RenderSettings,
        out: ImageId,
    ) -> Result<()> {
        let push = FeaturesPush {
            density: s.mc.density_scale,
            tf_gradient: u32::from(self.tf_gradient),
            max_steps: MAX_STEPS,
            pad: 0,
        };
        let [w, h] = march.size;
        march_pass(g, "features", &shaders::VOLUME_FEATURES_COMP, march)
            .write(out)
            .sampled(march.gradients, Sampling::Linear)
            .sampled(march.occupancy, Sampling::Nearest)
            .constants(&push)
            .loop_bound(u64::from(MAX_STEPS) + 1)
            .dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
        Ok(())
    }
}
