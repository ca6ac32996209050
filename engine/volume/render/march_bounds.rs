//! How far the ray marchers go: steps per ray, the loop bound each pass declares, and the
//! samples of a frame (for profiles).

use super::renderer::{RenderSettings, RendererKind, VolumeRenderer};
use crate::volume::camera::Camera;
use glam::Mat4;

/// What `VolumeRenderer::march_samples` depends on: view-projection bits, size, step bits.
pub(crate) type MarchKey = ([u32; 16], [u32; 2], u32);

impl VolumeRenderer {
    /// Most segments a camera ray can take through the box: its diagonal over the step.
    pub(crate) fn march_steps(&self, s: &RenderSettings) -> u64 {
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
}
