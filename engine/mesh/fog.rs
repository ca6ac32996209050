//! Participating media in the mesh renderer: a homogeneous fog ray-marched from the camera to
//! the G-buffer depth after lighting (`shaders_glsl/mesh/fog.comp`), in-scattering the sun,
//! the spot lights, the ambient term and, with `lpv=1`, the light propagation volume.

use crate::graph::{BufferId, GraphBuilder, ImageId, Work};
use crate::shaders;
use crate::vk::Sampling;
use crate::Result;

pub use super::settings::{FogBounds, FogSettings};

/// What the fog pass reads and writes.
pub struct FogInputs {
    /// The frame's uniform buffer.
    pub ubo: BufferId,
    /// Camera depth.
    pub depth: ImageId,
    /// Shadow atlas.
    pub atlas: ImageId,
    /// Lit HDR radiance, attenuated and added to in place.
    pub hdr: ImageId,
    /// The LPV's light grids, when the LPV is on.
    pub lpv: Option<[ImageId; 3]>,
    /// The scene's bounding box (for [`FogBounds::Scene`]).
    pub scene_bounds: [glam::Vec3; 2],
    /// Image size.
    pub size: [u32; 2],
    /// Lights with a shadow tile (sun counts once), for the declared work.
    pub lights: u32,
}

/// Declares the fog pass (call only when `s.enabled`).
pub fn add_fog_pass(g: &mut GraphBuilder<'_>, s: &FogSettings, input: FogInputs) -> Result<()> {
    s.validate()?;
    let (bounded, [lo, hi]) = match s.bounds {
        FogBounds::Scene => (1.0, input.scene_bounds.map(|v| v.to_array())),
        FogBounds::Unbounded => (0.0, [[0.0; 3]; 2]),
        FogBounds::Box { min, max } => (1.0, [min, max]),
    };
    let push = [s.density, s.albedo, s.g, s.steps as f32, lo[0], lo[1], lo[2], bounded, hi[0], hi[1], hi[2], 0.0];
    let FogInputs { ubo, depth, atlas, hdr, lpv, size: [w, h], lights, .. } = input;
    // Per pixel: depth and the HDR texel in and out; per segment 4 shadow texels per light and
    // 8 cells × 3 RGBA32F texels of the LPV.
    let per_step = u64::from(lights) * 16 + if lpv.is_some() { 8 * 3 * 16 } else { 0 };
    let pixels = u64::from(w) * u64::from(h);
    let shader = if lpv.is_some() { &shaders::MESH_FOG_COMP__LPV } else { &shaders::MESH_FOG_COMP };
    g.compute("fog", shader)
        .work(Work { bytes: pixels * (4 + 32 + u64::from(s.steps) * per_step), ..Default::default() })
        .uniform(ubo)
        .sampled(depth, Sampling::Nearest)
        .sampled(atlas, Sampling::Nearest)
        .read_write(hdr)
        .each(lpv.into_iter().flatten(), |p, id| p.sampled(id, Sampling::Linear))
        .constants(&push)
        // Per segment the spot loop (at most MAX_SPOTS and its exit), and the segment loop's exit.
        .loop_bound(u64::from(s.steps) * (crate::mesh::frame::MAX_SPOTS as u64 + 2) + 1)
        .dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
    Ok(())
}
