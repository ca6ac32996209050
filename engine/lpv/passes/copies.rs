//! Whole-grid transfers between the LPV's flat buffers and its images, the flat layout's sizes,
//! and zero fills.

use crate::graph::{Access, BufferId, GraphBuilder, ImageId};
use crate::vk::vk;
use crate::Result;

/// Copies three channel images whole, in transfer layouts: with `src_layers` > 1 a 2D array's
/// layers land on a 3D image's slices (Vulkan 1.1).
pub(super) fn copy_channels(
    pc: &crate::graph::PassContext<'_>,
    src: [ImageId; 3],
    dst: [ImageId; 3],
    src_layers: u32,
    [width, height, depth]: [u32; 3],
) -> Result<()> {
    let sub = |layer_count| vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: 0,
        base_array_layer: 0,
        layer_count,
    };
    let region = [vk::ImageCopy {
        src_subresource: sub(src_layers),
        dst_subresource: sub(1),
        extent: vk::Extent3D { width, height, depth },
        ..Default::default()
    }];
    for (s, d) in src.into_iter().zip(dst) {
        // SAFETY: called from a transfer pass that declared `src` TransferSrc and `dst` TransferDst.
        unsafe {
            pc.device().cmd_copy_image(
                pc.cmd,
                pc.image(s).raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                pc.image(d).raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &region,
            )
        };
    }
    Ok(())
}

/// The buffer ↔ image copy of a whole 3D image of `extent` at byte `offset` of a flat buffer.
pub(crate) fn channel_region(offset: u64, [width, height, depth]: [u32; 3]) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        buffer_offset: offset,
        image_subresource: vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        image_extent: vk::Extent3D { width, height, depth },
        ..Default::default()
    }
}

/// Which way [`copy_flat`] copies.
#[derive(Clone, Copy)]
pub(super) enum Flat {
    /// Flat buffer → the three images.
    ToImages,
    /// The three images → flat buffer.
    FromImages,
}

/// Copies between a flat buffer of three channel blocks (texel order, vec4 each) holding
/// `extent[2] / extent[0]` cascades of `extent[0]`³ cells and three 3D images whose cascade
/// slots `slots` name (cascade k of the buffer ↔ slot `slots[k]` of the images).
pub(super) fn copy_flat(
    pc: &crate::graph::PassContext<'_>,
    dir: Flat,
    buffer: BufferId,
    images: [ImageId; 3],
    extent: [u32; 3],
    slots: &[u32],
) -> Result<()> {
    let channel_bytes = 16 * flat_channel(extent.iter().map(|&e| u64::from(e)).product::<u64>());
    let n = extent[0];
    let cascade_bytes = 16 * u64::from(n).pow(3);
    for (ch, img) in images.into_iter().enumerate() {
        let regions: Vec<vk::BufferImageCopy> = slots
            .iter()
            .enumerate()
            .map(|(k, &slot)| vk::BufferImageCopy {
                image_offset: vk::Offset3D { x: 0, y: 0, z: (slot * n) as i32 },
                ..channel_region(ch as u64 * channel_bytes + k as u64 * cascade_bytes, [n, n, n])
            })
            .collect();
        let (buf, image) = (pc.buffer(buffer).raw, pc.image(img).raw);
        // SAFETY: called from a transfer pass that declared the source TransferSrc and the
        // destination TransferDst; every slot lies inside the images.
        unsafe {
            match dir {
                Flat::ToImages => pc.device().cmd_copy_buffer_to_image(
                    pc.cmd,
                    buf,
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &regions,
                ),
                Flat::FromImages => pc.device().cmd_copy_image_to_buffer(
                    pc.cmd,
                    image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    buf,
                    &regions,
                ),
            }
        };
    }
    Ok(())
}

/// Texels between a flat grid's channel blocks beyond the grid's size (`FLAT_PAD` in
/// lpv/common.glsl: a power-of-two stride put a cell's channels into the same cache sets).
pub const FLAT_PAD: u64 = 68;

/// Texels from one channel block of a flat grid of `texels` cells to the next.
pub fn flat_channel(texels: u64) -> u64 {
    texels + FLAT_PAD
}

/// Bytes of a flat grid of `texels` cells: three channel blocks of vec4.
pub fn flat_bytes(texels: u64) -> u64 {
    3 * 16 * flat_channel(texels)
}

/// A transfer pass that fills `buffers` with zeros.
pub(super) fn zero_fill<const N: usize>(g: &mut GraphBuilder<'_>, name: String, buffers: [BufferId; N]) -> Result<()> {
    let mut p = g.add_transfer_pass(name);
    for b in buffers {
        p.write_buffer(b, Access::TransferDst)?;
    }
    p.record(move |pc| {
        for b in buffers {
            // SAFETY: transfer pass writing the declared buffers.
            unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(b).raw, 0, vk::WHOLE_SIZE, 0) };
        }
        Ok(())
    });
    Ok(())
}

/// A transfer pass `name` that copies a flat buffer of the stacked grids (`extent`) into three
/// images, cascade k of the buffer at slot `slots[k]`.
pub(crate) fn copy_to_images(
    g: &mut GraphBuilder<'_>,
    name: String,
    flat: BufferId,
    images: [ImageId; 3],
    extent: [u32; 3],
    slots: &[u32],
) -> Result<()> {
    let mut p = g.add_transfer_pass(name);
    p.read_buffer(flat, Access::TransferSrc)?;
    for img in images {
        p.write_image(img, Access::TransferDst)?;
    }
    let slots = slots.to_vec();
    p.record(move |pc| copy_flat(pc, Flat::ToImages, flat, images, extent, &slots));
    Ok(())
}
