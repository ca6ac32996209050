//! The ray marchers' passes: MIP, ISO (hit, then shade), EAM (front to back, back to front,
//! with precomputed gradients or depth), LAO and DOS.

use super::occlusion::{eam_pass, march_pass, MarchInputs};
use super::renderer::VolumeRenderer;
use super::settings::{RenderSettings, RendererKind};
use crate::error::{Error, Result};
use crate::graph::{GraphBuilder, ImageDesc, ImageId};
use crate::shaders;
use crate::vk::{vk, Sampling};
use crate::volume::camera::Camera;

impl VolumeRenderer {
    /// The marcher `s.renderer` into `march.hdr` (and `depth` where given); returns ISO's hit image.
    pub(super) fn add_march_passes(
        &self,
        g: &mut GraphBuilder<'_>,
        camera: &Camera,
        s: &RenderSettings,
        march: MarchInputs,
        depth: Option<ImageId>,
        groups: [u32; 3],
    ) -> Result<Option<ImageId>> {
        let (hdr, size, occ, grads) = (march.hdr, march.size, march.occupancy, march.gradients);
        let mut iso_hit = None;
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
                return Err(Error::Graph("the Monte Carlo renderers are not marchers (add_mc_pass)".into()))
            }
            RendererKind::Eam if s.precomputed_gradients => {
                eam_pass(g, "eam", &shaders::VOLUME_EAM_COMP__GRADIENT_TEXTURE, &march)
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
                eam_pass(g, s.renderer.name(), shader, &march)
                    .work(bounded_march(8))
                    .write(hdr)
                    .sampled(occ, Sampling::Nearest)
                    .dispatch(groups)?;
            }
        }
        Ok(iso_hit)
    }
}
