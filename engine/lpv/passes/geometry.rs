//! The geometry volume (blocking potentials from RSM texels and camera pixels) and directional
//! propagation's normal grid.

use super::inject::{rsm_pass, AtomicTargets};
use super::Frame;
use crate::graph::{GraphBuilder, ImageDesc, ImageId};
use crate::shaders;
use crate::vk::Sampling;
use crate::Result;

/// Accumulates the geometry volume with integer atomics and resolves it into the padded image
/// propagation samples; None with occlusion off (its variants declare no GV binding).
pub(super) fn geometry_volume(
    g: &mut GraphBuilder<'_>,
    f: &Frame,
    t: &AtomicTargets,
    gv_sources: u32,
) -> Result<Option<ImageId>> {
    let Some(gv) = t.gv else { return Ok(None) };
    let [pos, nrm, _] = f.rsm;
    rsm_pass(g, f, format!("{} geometry volume", f.tag), &shaders::LPV_GV_INJECT_COMP, &[pos, nrm], &[gv])
        .dispatch(f.rsm_groups)?;
    if let Some(cam) = f.camera {
        let groups = cam.size.map(|v| v.div_ceil(super::CAMERA_SURFEL_STRIDE).div_ceil(8));
        g.compute(format!("{} geometry volume (camera)", f.tag), &shaders::LPV_GV_CAMERA_COMP)
            .uniform(f.ubo)
            .sampled(cam.depth, Sampling::Nearest)
            .sampled(cam.normal, Sampling::Nearest)
            .atomic(gv)
            .dispatch([groups[0], groups[1], 1])?;
    }
    // One (N+1)³ block of lattice points per source and cascade (lpv/common.glsl).
    let m = f.n + 1;
    let desc = ImageDesc { extent: [m, m, m * f.count * gv_sources], ..f.grid_desc };
    let image = g.create_image(format!("{} geometry volume (filtered)", f.tag), desc);
    g.compute(format!("{} geometry volume resolve", f.tag), &shaders::LPV_GV_RESOLVE_COMP)
        .uniform(f.ubo)
        .read(gv)
        .write(image)
        .dispatch([m.div_ceil(8), m.div_ceil(4), (m * f.count * gv_sources).div_ceil(2)])?;
    Ok(Some(image))
}

/// Directional propagation's normal grid, before any dilation.
pub(super) fn normals(g: &mut GraphBuilder<'_>, f: &Frame, t: &AtomicTargets) -> Result<Option<ImageId>> {
    let Some(sums) = t.normals else { return Ok(None) };
    rsm_pass(g, f, format!("{} normals", f.tag), &shaders::LPV_NORMALS_COMP, &f.rsm, &[sums]).dispatch(f.rsm_groups)?;
    let image = g.create_image(format!("{} normals", f.tag), f.grid_desc);
    g.compute(format!("{} normals resolve", f.tag), &shaders::LPV_DILATE_COMP__RESOLVE)
        .uniform(f.ubo)
        .read(sums)
        .write(image)
        .dispatch(f.cell_groups)?;
    Ok(Some(image))
}
