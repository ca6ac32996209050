//! The Monte Carlo pass (single and multiple scattering, classic or bounded work): its shader
//! variant, environment light, path state and push constants.

use super::frame::Targets;
use super::mc_loops::{check_loop_budget, largest_budget, BoundedPush};
use super::occlusion::{march_pass, MarchInputs};
use super::renderer::{VolumeRenderer, READ_ONLY};
use super::settings::RenderSettings;
use crate::error::{Error, Result};
use crate::graph::execute::Imports;
use crate::graph::{Access, BufferId, GraphBuilder, ResourceState};
use crate::shaders;
use crate::vk::Sampling;

/// `mc_bounded.comp`'s moments image (past `volume/common.glsl`'s fixed bindings).
const MOMENTS_BINDING: u32 = 23;
/// `mc_common.glsl`'s per-tile buffer (`mc_tiles.glsl`).
const TILES_BINDING: u32 = 24;

impl VolumeRenderer {
    /// The MCS/MCM pass into `march.hdr` for the `n`-th frame of the mean.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn add_mc_pass<'a>(
        &'a self,
        g: &mut GraphBuilder<'a>,
        imports: &mut Imports,
        targets: &Targets,
        s: &RenderSettings,
        march: &MarchInputs,
        (mc, mc_params): (&super::uniforms::McParams, BufferId),
        moments: super::variance::MomentImages,
        n: u32,
        groups: [u32; 3],
    ) -> Result<()> {
        let (hdr, grads) = (march.hdr, march.gradients);
        let maj = march.majorants;
        let stats = imports.buffer(g, "volume stats", &self.stats, ResourceState::UNDEFINED);
        let env = match (&self.env, s.mc.env_map) {
            (Some(e), true) => Some((
                imports.image_readonly(g, "environment map", &e.texture, READ_ONLY),
                imports.buffer_readonly(g, "environment cdf", &e.cdf),
            )),
            (None, true) => return Err(Error::Input("env_map is on but no environment map was loaded".into())),
            _ => None,
        };
        let [temp, planck] = march.temperature;
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
        // Adaptive sampling, from a mean's second frame on: stopped tiles trace nothing, and
        // bounded work hands their budget to the others, up to 16 times a tile's own.
        let adaptive = s.mc.convergence.adaptive && n > 1;
        let max_budget = match adaptive {
            true => s.mc.budget.saturating_mul(16).min(largest_budget(env_size)).max(s.mc.budget),
            false => s.mc.budget,
        };
        let loops = if bounded { check_loop_budget(max_budget, env_size)? } else { 0 };
        let paths = match (bounded, &targets.paths) {
            (false, _) => None,
            (true, Some(b)) => Some(imports.buffer(g, "mc paths", b, ResourceState::UNDEFINED)),
            (true, None) => {
                return Err(Error::Input("mc_budget: the targets have no path buffer (Targets::enable_paths)".into()))
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
            max_budget,
        };
        let mc_groups = [groups[0].div_ceil(interleave), groups[1], 1];
        // Bounded work reads nothing of the image, but keeps the pixels it does not
        // advance this frame (interleaving): read-write, not write-only.
        let pass = march_pass(g, s.renderer.name(), shader, march);
        let pass = if bounded { pass.read_write(hdr) } else { pass.write(hdr) };
        pass.sampled(maj, Sampling::Nearest)
            .sampled(grads, Sampling::Linear)
            .uniform(mc_params)
            .atomic(stats)
            .each(env, |p, (tex, cdf)| p.sampled(tex, Sampling::Nearest).read(cdf))
            .each(paths, |p, b| p.read_write(b))
            .each(paths.map(|_| push), |p, push| p.constants(&push))
            .each(bounded.then_some(moments.moments), |p, m| p.read_write_at(MOMENTS_BINDING, m))
            .read_at(TILES_BINDING, moments.tiles)
            .sampled_at(super::temperature::TEMPERATURE_BINDING, temp, Sampling::Linear)
            .sampled_at(super::temperature::PLANCK_BINDING, planck, Sampling::Linear)
            .specialize(&march.specialization(
                u32::from(march.tf_gradient),
                Self::mc_features(mc, env.is_some()) | u32::from(adaptive) << 6,
            ))
            .loop_bound(loops)
            .dispatch(if bounded { mc_groups } else { groups })?;
        // The host reads the violation counter after the frame.
        g.export_buffer(stats, Some(Access::HostRead))?;
        Ok(())
    }
}
