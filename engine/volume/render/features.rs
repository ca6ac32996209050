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

/// Most full-length march steps of one camera ray (the shortest step grows past it): 2,048
/// covers the diagonal of a 512³ volume at half-voxel steps, far under llvmpipe's loop limit.
pub const MAX_STEPS: u32 = 2048;

/// Cells one feature ray crosses in a majorant grid of `grid` cells (at most the sum of the axes'
/// counts), twice over for a face met at a rounding error: the bound of one step's cell walk.
pub fn max_cells(grid: [u32; 3]) -> u32 {
    2 * (grid[0] + grid[1] + grid[2]) + 4
}

/// Steps of one feature ray: [`MAX_STEPS`] of at least the shortest length, and one cut short
/// before each empty cell.
pub fn max_iterations(grid: [u32; 3]) -> u32 {
    MAX_STEPS + max_cells(grid)
}

/// Push constants of `volume/features.comp`.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct FeaturesPush {
    density: f32,
    max_steps: u32,
    max_iterations: u32,
    max_cells: u32,
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
            max_steps: MAX_STEPS,
            max_iterations: max_iterations(self.grid),
            max_cells: max_cells(self.grid),
        };
        let [w, h] = march.size;
        march_pass(g, "features", &shaders::VOLUME_FEATURES_COMP, march)
            .write(out)
            .sampled(march.gradients, Sampling::Linear)
            .sampled(march.majorants, Sampling::Nearest)
            .constants(&push)
            // Each step's cell walk visits the cells it crosses plus the one it starts in.
            .loop_bound(2 * u64::from(push.max_iterations) + u64::from(push.max_cells) + 2)
            .dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
        Ok(())
    }
}
