//! Staging uploads and readbacks for buffers and images (one-shot, outside the frame graph:
//! used for loading data and for tests).

use super::buffer::Buffer;
use super::context::Context;
use super::image::{texel_size, Image};
use crate::error::{Error, Result};
use ash::vk;
use gpu_allocator::MemoryLocation;

fn barrier2(
    cmd: vk::CommandBuffer,
    ctx: &Context,
    image: &Image,
    (old, src_stage, src_access): (vk::ImageLayout, vk::PipelineStageFlags2, vk::AccessFlags2),
    (new, dst_stage, dst_access): (vk::ImageLayout, vk::PipelineStageFlags2, vk::AccessFlags2),
) {
    let b = [vk::ImageMemoryBarrier2::default()
        .image(image.raw)
        .subresource_range(image.info.full_range())
        .old_layout(old)
        .new_layout(new)
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)];
    // SAFETY: cmd is recording; image is live.
    unsafe { ctx.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&b)) };
}

/// Extent of mip `level` (each axis halves, never below 1).
fn mip_extent(image: &Image, level: u32) -> [u32; 3] {
    image.info.extent.map(|e| (e >> level).max(1))
}

/// Bytes of mip levels `0..levels`, every layer, tightly packed.
fn image_bytes(image: &Image, levels: u32) -> Result<u64> {
    let ts = texel_size(image.info.format)
        .ok_or_else(|| Error::Input(format!("format {:?} has no staging support", image.info.format)))?;
    let layers = image.info.layers() as u64;
    Ok((0..levels).map(|l| mip_extent(image, l).iter().map(|&e| e as u64).product::<u64>() * ts * layers).sum())
}

/// One copy region per mip in `0..levels`, consecutive in the buffer.
fn copy_regions(image: &Image, levels: u32) -> Result<Vec<vk::BufferImageCopy>> {
    let mut offset = 0;
    let mut out = Vec::new();
    for level in 0..levels {
        let [w, h, d] = mip_extent(image, level);
        out.push(
            vk::BufferImageCopy::default()
                .buffer_offset(offset)
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: image.info.aspect(),
                    mip_level: level,
                    base_array_layer: 0,
                    layer_count: image.info.layers(),
                })
                .image_extent(vk::Extent3D { width: w, height: h, depth: d }),
        );
        offset = image_bytes(image, level + 1)?;
    }
    Ok(out)
}

impl Context {
    /// Uploads `data` into a new GPU-only buffer via a staging buffer.
    pub fn upload_buffer(&self, name: &str, data: &[u8], usage: vk::BufferUsageFlags) -> Result<Buffer> {
        let dst = Buffer::new(
            self,
            name,
            data.len() as u64,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let staging = Buffer::with_data(self, "staging", data, vk::BufferUsageFlags::TRANSFER_SRC)?;
        self.one_shot(|cmd| {
            let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size: data.len() as u64 }];
            // SAFETY: both buffers are live and large enough.
            unsafe { self.device.cmd_copy_buffer(cmd, staging.raw, dst.raw, &region) };
            Ok(())
        })?;
        Ok(dst)
    }

    /// Copies a whole buffer back to the host (the caller must have finished GPU writes to it).
    pub fn read_buffer(&self, src: &Buffer) -> Result<Vec<u8>> {
        let staging =
            Buffer::new(self, "readback", src.size, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)?;
        self.one_shot(|cmd| {
            // Whatever wrote `src` earlier must be visible to this copy.
            let b = [vk::BufferMemoryBarrier2::default()
                .buffer(src.raw)
                .size(vk::WHOLE_SIZE)
                .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::TRANSFER)
                .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)];
            // SAFETY: cmd is recording; src is live.
            unsafe {
                self.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().buffer_memory_barriers(&b))
            };
            let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size: src.size }];
            // SAFETY: both buffers are live; the prior submission completed (one_shot waits).
            unsafe { self.device.cmd_copy_buffer(cmd, src.raw, staging.raw, &region) };
            Ok(())
        })?;
        Ok(staging.mapped().map(|m| m[..src.size as usize].to_vec()).unwrap_or_default())
    }

    /// Uploads tightly packed texels (every mip level, largest first, each with all layers) and
    /// leaves the image in `final_layout` (visible to `dst_stage`/`dst_access`).
    pub fn upload_image(
        &self,
        image: &Image,
        data: &[u8],
        final_layout: vk::ImageLayout,
        dst_stage: vk::PipelineStageFlags2,
        dst_access: vk::AccessFlags2,
    ) -> Result<()> {
        let bytes = image_bytes(image, image.info.mip_levels)?;
        let regions = copy_regions(image, image.info.mip_levels)?;
        if data.len() as u64 != bytes {
            return Err(Error::Input(format!("image upload: {} bytes given, image needs {bytes}", data.len())));
        }
        let before = (vk::ImageLayout::UNDEFINED, vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE);
        self.copy_into_image(image, data, &regions, before, (final_layout, dst_stage, dst_access))
    }

    /// Copies `data` into `image` by `regions` (which `data` holds), from state `before` to
    /// state `after`, and waits.
    fn copy_into_image(
        &self,
        image: &Image,
        data: &[u8],
        regions: &[vk::BufferImageCopy],
        before: (vk::ImageLayout, vk::PipelineStageFlags2, vk::AccessFlags2),
        after: (vk::ImageLayout, vk::PipelineStageFlags2, vk::AccessFlags2),
    ) -> Result<()> {
        let staging = Buffer::with_data(self, "staging", data, vk::BufferUsageFlags::TRANSFER_SRC)?;
        self.one_shot(|cmd| {
            let dst = (vk::ImageLayout::TRANSFER_DST_OPTIMAL, vk::PipelineStageFlags2::TRANSFER);
            barrier2(cmd, self, image, before, (dst.0, dst.1, vk::AccessFlags2::TRANSFER_WRITE));
            // SAFETY: image is in TRANSFER_DST_OPTIMAL; staging holds every region's texels.
            unsafe { self.device.cmd_copy_buffer_to_image(cmd, staging.raw, image.raw, dst.0, regions) };
            barrier2(cmd, self, image, (dst.0, dst.1, vk::AccessFlags2::TRANSFER_WRITE), after);
            Ok(())
        })
    }

    /// Writes boxes of mip 0 (`(offset, extent)` in texels, their texels tightly packed one box
    /// after another in `data`) and keeps the rest of the image: it stays in `layout`, read by
    /// `stage` before and after (`access` after). Nothing is submitted for no boxes.
    pub fn update_image(
        &self,
        image: &Image,
        boxes: &[([u32; 3], [u32; 3])],
        data: &[u8],
        layout: vk::ImageLayout,
        stage: vk::PipelineStageFlags2,
        access: vk::AccessFlags2,
    ) -> Result<()> {
        if boxes.is_empty() {
            return Ok(());
        }
        let texel = texel_size(image.info.format)
            .ok_or_else(|| Error::Input(format!("image update: format {:?} has no texel size", image.info.format)))?;
        let mut regions = Vec::with_capacity(boxes.len());
        let mut at = 0u64;
        for &(o, e) in boxes {
            if (0..3).any(|a| u64::from(o[a]) + u64::from(e[a]) > u64::from(image.info.extent[a])) {
                return Err(Error::Input(format!("image update: box at {o:?} of {e:?} texels past the image")));
            }
            regions.push(
                vk::BufferImageCopy::default()
                    .buffer_offset(at)
                    .image_subresource(vk::ImageSubresourceLayers {
                        aspect_mask: vk::ImageAspectFlags::COLOR,
                        mip_level: 0,
                        base_array_layer: 0,
                        layer_count: 1,
                    })
                    .image_offset(vk::Offset3D { x: o[0] as i32, y: o[1] as i32, z: o[2] as i32 })
                    .image_extent(vk::Extent3D { width: e[0], height: e[1], depth: e[2] }),
            );
            at += e.iter().map(|&c| u64::from(c)).product::<u64>() * texel;
        }
        if data.len() as u64 != at {
            return Err(Error::Input(format!("image update: {} bytes given, the boxes need {at}", data.len())));
        }
        // The earlier reads finish before the copy overwrites (old layout kept: contents stay).
        self.copy_into_image(image, data, &regions, (layout, stage, vk::AccessFlags2::NONE), (layout, stage, access))
    }

    /// Reads mip 0 of every layer back as tightly packed texels. `layout`/`stage`/`access` describe
    /// the image's current state; it is returned to that layout afterwards.
    pub fn read_image(
        &self,
        image: &Image,
        layout: vk::ImageLayout,
        stage: vk::PipelineStageFlags2,
        access: vk::AccessFlags2,
    ) -> Result<Vec<u8>> {
        let bytes = image_bytes(image, 1)?;
        let regions = copy_regions(image, 1)?;
        let staging =
            Buffer::new(self, "readback", bytes, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)?;
        self.one_shot(|cmd| {
            let t = vk::PipelineStageFlags2::TRANSFER;
            barrier2(
                cmd,
                self,
                image,
                (layout, stage, access),
                (vk::ImageLayout::TRANSFER_SRC_OPTIMAL, t, vk::AccessFlags2::TRANSFER_READ),
            );
            // SAFETY: image in TRANSFER_SRC_OPTIMAL; staging sized for it.
            unsafe {
                self.device.cmd_copy_image_to_buffer(
                    cmd,
                    image.raw,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    staging.raw,
                    &regions,
                )
            };
            if layout != vk::ImageLayout::UNDEFINED {
                barrier2(
                    cmd,
                    self,
                    image,
                    (vk::ImageLayout::TRANSFER_SRC_OPTIMAL, t, vk::AccessFlags2::NONE),
                    (layout, stage, access),
                );
            }
            Ok(())
        })?;
        Ok(staging.mapped().map(|m| m[..bytes as usize].to_vec()).unwrap_or_default())
    }

    /// [`Context::read_image`] for RGBA32F images, decoded to texels.
    pub fn read_image_rgba32f(
        &self,
        image: &Image,
        layout: vk::ImageLayout,
        stage: vk::PipelineStageFlags2,
        access: vk::AccessFlags2,
    ) -> Result<Vec<[f32; 4]>> {
        let bytes = self.read_image(image, layout, stage, access)?;
        Ok(bytes
            .chunks_exact(16)
            .map(|c| std::array::from_fn(|i| f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]])))
            .collect())
    }
}
