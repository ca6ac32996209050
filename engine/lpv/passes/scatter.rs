//! Scatter propagation: each cell adds into its six neighbours with float atomics, one step at
//! a time, each step resolved into its images and added into the accumulation.

use super::copies::zero_fill;
use super::{Frame, GRID_FORMAT};
use crate::graph::{BufferDesc, BufferId, GraphBuilder, ImageId, Work};
use crate::shaders;
use crate::Result;

/// The scatter steps from the injected images; returns the accumulated flat buffer (`seed`,
/// added into).
pub(super) fn scatter_steps(
    g: &mut GraphBuilder<'_>,
    f: &Frame,
    steps: u32,
    injected: [ImageId; 3],
    seed: BufferId,
    gv: Option<ImageId>,
    gv_sources: u32,
) -> Result<BufferId> {
    let tag = f.tag;
    let work = Work {
        bytes: f.cells * (48 + 8 * 16 * u64::from(gv_sources)),
        atomics: f.cells * 6 * 12,
        ..Default::default()
    };
    let shader = match gv_sources {
        0 => &shaders::LPV_PROPAGATE_COMP__SCATTER,
        1 => &shaders::LPV_PROPAGATE_COMP__SCATTER_OCC1,
        _ => &shaders::LPV_PROPAGATE_COMP__SCATTER_OCC2,
    };
    let mut src = injected;
    for step in 1..=steps {
        let dst = f.grid(g, &format!("{tag} step {step}"));
        let flat = g.create_buffer(format!("{tag} step {step} (scatter)"), BufferDesc::new(12 * f.cells * 4));
        zero_fill(g, format!("{tag} clear step {step}"), [flat])?;
        g.compute(format!("{tag} propagate {step} (scatter)"), shader)
            .work(work)
            .uniform(f.ubo)
            .each(src, |p, id| p.read(id))
            .atomic(flat)
            .each(gv, |p, id| p.read(id))
            .dispatch(f.cell_groups)?;
        g.compute(format!("{tag} accumulate {step}"), &shaders::LPV_RESOLVE_COMP__ACCUMULATE)
            .uniform(f.ubo)
            .read_texels(flat, GRID_FORMAT)
            .each(dst, |p, id| p.write(id))
            .read_write(seed)
            .dispatch(f.cell_groups)?;
        src = dst;
    }
    Ok(seed)
}
