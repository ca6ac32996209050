//! Post-processing passes shared by every renderer.

use crate::graph::{Access, GraphBuilder, GraphError, ImageId, ShaderStage};
use crate::vk::{pipeline::push_words, Descriptor, Pipeline};

/// Declares the tone-map pass (`post/tonemap.comp`): linear `hdr` → display `ldr`.
/// `params` = [mode (0 Reinhard, 1 range, 2 ACES), exposure, lo, hi] as the shader's push constants.
pub fn add_tonemap_pass<'a>(
    g: &mut GraphBuilder<'a>,
    pipeline: &'a Pipeline,
    hdr: ImageId,
    ldr: ImageId,
    params: [u32; 4],
    groups: [u32; 2],
) -> Result<(), GraphError> {
    let cs = ShaderStage::Compute;
    let mut p = g.add_compute_pass("tonemap");
    p.read_image(hdr, Access::StorageRead(cs))?;
    p.write_image(ldr, Access::StorageWrite(cs))?;
    p.record(move |pc| {
        let ds = [Descriptor::StorageImage(pc.image(hdr).view), Descriptor::StorageImage(pc.image(ldr).view)];
        if pipeline.bind(pc.cmd, &ds, &push_words(&params)).is_ok() {
            // SAFETY: pipeline and descriptors bound just above.
            unsafe { pc.device().cmd_dispatch(pc.cmd, groups[0], groups[1], 1) };
        }
    });
    Ok(())
}
