//! Presentation as a graph pass: the swapchain image a window acquired is imported, the frame's
//! output is blitted onto it by a transfer pass, and its export in [`Access::Present`] is the
//! graph's final barrier. No barrier for the window is written by hand.

use super::access::Access;
use super::builder::GraphBuilder;
use super::imports::Imports;
use super::pass_context::GraphImage;
use super::resource::{ImageId, ResourceState};
use crate::vk::{ImageInfo, ImageKind};
use crate::Result;
use ash::vk;

/// Passes a window draws over a frame's tone-mapped output before presenting it (the UI).
pub trait FrameOverlay {
    /// Declares them; they load `target` and draw over it.
    fn add_passes<'a>(&'a self, g: &mut GraphBuilder<'a>, imports: &mut Imports, target: ImageId) -> Result<()>;
}

/// The swapchain image a frame presents to.
#[derive(Clone, Copy, Debug)]
pub struct PresentTarget {
    /// The acquired image.
    pub image: vk::Image,
    /// Its format.
    pub format: vk::Format,
    /// Its size.
    pub extent: [u32; 2],
}

/// The acquire semaphore is waited at the transfer stage, so the import's first barrier must
/// start there to be ordered after it; the previous contents are discarded.
const ACQUIRED: ResourceState = ResourceState {
    layout: vk::ImageLayout::UNDEFINED,
    stage: vk::PipelineStageFlags2::TRANSFER,
    access: vk::AccessFlags2::NONE,
};

/// Declares the blit of `src` (any colour image, scaled with linear filtering) onto `target`
/// and exports the target for presentation.
pub fn add_present_pass(
    g: &mut GraphBuilder<'_>,
    imports: &mut Imports,
    src: ImageId,
    target: PresentTarget,
) -> Result<()> {
    let [w, h] = target.extent;
    let info = ImageInfo {
        format: target.format,
        extent: [w, h, 1],
        kind: ImageKind::D2,
        mip_levels: 1,
        usage: vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::COLOR_ATTACHMENT,
    };
    let image = GraphImage { raw: target.image, view: vk::ImageView::null(), info };
    let dst = imports.raw_image(g, "swapchain", image, ACQUIRED);
    g.add_transfer_pass("present blit")
        .read_image(src, Access::TransferSrc)?
        .write_image(dst, Access::TransferDst)?
        .record(move |pc| {
            let (s, d) = (pc.image(src), pc.image(dst));
            let layers = vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            };
            let corner = |e: [u32; 3]| vk::Offset3D { x: e[0] as i32, y: e[1] as i32, z: 1 };
            let blit = vk::ImageBlit {
                src_subresource: layers,
                src_offsets: [vk::Offset3D::default(), corner(s.info.extent)],
                dst_subresource: layers,
                dst_offsets: [vk::Offset3D::default(), corner(d.info.extent)],
            };
            // SAFETY: transfer pass; the graph put `src` in TRANSFER_SRC and `dst` in TRANSFER_DST.
            unsafe {
                pc.device().cmd_blit_image(
                    pc.cmd,
                    s.raw,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    d.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[blit],
                    vk::Filter::LINEAR,
                )
            };
            Ok(())
        });
    g.export_image(dst, Some(Access::Present))?;
    Ok(())
}

/// A window frame's last passes: `overlay` drawn over `output`, then `output` presented to
/// `target`. Both optional, so headless and windowed frames share one driver.
pub fn add_window_passes<'a>(
    g: &mut GraphBuilder<'a>,
    imports: &mut Imports,
    output: ImageId,
    overlay: Option<&'a dyn FrameOverlay>,
    target: Option<PresentTarget>,
) -> Result<()> {
    if let Some(o) = overlay {
        o.add_passes(g, imports, output)?;
    }
    if let Some(t) = target {
        add_present_pass(g, imports, output, t)?;
    }
    Ok(())
}
