//! The accumulation's start and the sky light (the thesis' §5.3), which adds into it and into
//! the injected light differently.

use super::copies::flat_bytes;
use super::{Frame, SkyPush};
use crate::graph::{Access, BufferDesc, BufferId, GraphBuilder, ImageDesc};
use crate::shaders;
use crate::vk::{vk, Sampling};
use crate::Result;

/// The accumulation's start: the injected light itself, or its own copy where the sky pass adds
/// to the two differently or a variant adds into it (`own`).
pub(super) fn seed(g: &mut GraphBuilder<'_>, f: &Frame, inj_flat: BufferId, own: bool) -> Result<BufferId> {
    if !own {
        return Ok(inj_flat);
    }
    let bytes = flat_bytes(f.cells);
    let seed = g.create_buffer(format!("{} accumulated (flat)", f.tag), BufferDesc::new(bytes));
    let mut p = g.add_transfer_pass(format!("{} seed", f.tag));
    p.read_buffer(inj_flat, Access::TransferSrc)?;
    p.write_buffer(seed, Access::TransferDst)?;
    p.record(move |pc| {
        let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size: bytes }];
        // SAFETY: transfer pass; the source is declared TransferSrc, the target TransferDst.
        unsafe { pc.device().cmd_copy_buffer(pc.cmd, pc.buffer(inj_flat).raw, pc.buffer(seed).raw, &region) };
        Ok(())
    });
    Ok(seed)
}

/// Sky light into the cells open to the sky: the injected light and the accumulation's start.
pub(super) fn sky(g: &mut GraphBuilder<'_>, f: &Frame, inj_flat: BufferId, seed: BufferId) -> Result<()> {
    let Some(sky) = f.sky else { return Ok(()) };
    let n = f.n;
    // One map texel per coarsest cell, keeping each block's highest surface.
    let reduced =
        g.create_image(format!("{} sky height (per cell)", f.tag), ImageDesc::d2(vk::Format::R32_SFLOAT, n, n));
    g.compute(format!("{} sky reduce", f.tag), &shaders::LPV_SKY_REDUCE_COMP)
        .sampled(sky.height, Sampling::Nearest)
        .write(reduced)
        // A cell's k × k texels, k ≤ 16, with the loops' exits.
        .loop_bound(16 * 17 + 1)
        .dispatch([n.div_ceil(8), n.div_ceil(8), 1])?;
    let [r, gr, b] = sky.radiance;
    let push = SkyPush { view_proj: sky.view_proj.to_cols_array(), radiance: [r, gr, b, sky.cell] };
    g.compute(format!("{} inject sky", f.tag), &shaders::LPV_SKY_COMP)
        .uniform(f.ubo)
        .sampled(reduced, Sampling::Nearest)
        .read_write(inj_flat)
        .read_write(seed)
        .constants(&push)
        // 4 elevation bands × 8 azimuths, each ray marched ≤ 511 steps, then 6 faces: every
        // loop with its exit.
        .loop_bound(4 * (8 * 513 + 1) + 1 + 7)
        .dispatch(f.cell_groups)?;
    Ok(())
}
