//! Per-resource hazard tracking along the execution order, producing barriers.

use ash::vk;

use super::access::write_bits;
use super::builder::Use;
use super::pass_context::{GraphBuffer, GraphImage, Resolved};
use super::resource::{BufferId, ImageId, ResourceId, ResourceState};
use crate::vk::Context;

/// An image memory barrier (whole image: all mips and layers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageBarrier {
    /// Image.
    pub image: ImageId,
    /// Stages that must complete first.
    pub src_stage: vk::PipelineStageFlags2,
    /// Writes to make available.
    pub src_access: vk::AccessFlags2,
    /// Stages that wait.
    pub dst_stage: vk::PipelineStageFlags2,
    /// Accesses the writes become visible to.
    pub dst_access: vk::AccessFlags2,
    /// Layout before (`UNDEFINED` discards contents).
    pub old_layout: vk::ImageLayout,
    /// Layout after.
    pub new_layout: vk::ImageLayout,
}

/// A buffer memory barrier (whole buffer).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferBarrier {
    /// Buffer.
    pub buffer: BufferId,
    /// Stages that must complete first.
    pub src_stage: vk::PipelineStageFlags2,
    /// Writes to make available.
    pub src_access: vk::AccessFlags2,
    /// Stages that wait.
    pub dst_stage: vk::PipelineStageFlags2,
    /// Accesses the writes become visible to.
    pub dst_access: vk::AccessFlags2,
}

/// All barriers recorded before one pass, meant for a single `vkCmdPipelineBarrier2`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PassBarriers {
    /// Image barriers.
    pub images: Vec<ImageBarrier>,
    /// Buffer barriers.
    pub buffers: Vec<BufferBarrier>,
}

impl PassBarriers {
    /// No barrier at all.
    pub fn is_empty(&self) -> bool {
        self.images.is_empty() && self.buffers.is_empty()
    }

    /// Number of barriers.
    pub fn len(&self) -> usize {
        self.images.len() + self.buffers.len()
    }
}

/// A dependency computed for one use, before it is attached to a concrete resource.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dep {
    pub(crate) src_stage: vk::PipelineStageFlags2,
    pub(crate) src_access: vk::AccessFlags2,
    pub(crate) dst_stage: vk::PipelineStageFlags2,
    pub(crate) dst_access: vk::AccessFlags2,
    pub(crate) old_layout: vk::ImageLayout,
    pub(crate) new_layout: vk::ImageLayout,
}

/// Synchronization state of one resource at a point in the order.
#[derive(Clone, Debug)]
pub(crate) struct Track {
    layout: vk::ImageLayout,
    write_stage: vk::PipelineStageFlags2,
    write_access: vk::AccessFlags2,
    /// Destination stages of a layout transition since the last write: later readers must
    /// chain through them to be ordered after the transition.
    chain_stage: vk::PipelineStageFlags2,
    /// Stages that read since the last write (what a write-after-read must wait for).
    readers: vk::PipelineStageFlags2,
    /// (stage, access) pairs the last write is already visible to, in the current layout.
    visible: Vec<(vk::PipelineStageFlags2, vk::AccessFlags2)>,
}

impl Track {
    pub(crate) fn new(state: ResourceState) -> Self {
        let write_access = write_bits(state.access);
        // A state with pending writes is treated as that write; otherwise as a read.
        let (write_stage, readers) = if write_access.is_empty() {
            (vk::PipelineStageFlags2::NONE, state.stage)
        } else {
            (state.stage, vk::PipelineStageFlags2::NONE)
        };
        Self {
            layout: state.layout,
            write_stage,
            write_access,
            chain_stage: vk::PipelineStageFlags2::NONE,
            readers,
            visible: Vec::new(),
        }
    }

    /// Stages that may still touch the resource and writes not yet made available to all.
    pub(crate) fn pending(&self) -> ResourceState {
        ResourceState {
            layout: self.layout,
            stage: self.write_stage | self.readers | self.chain_stage,
            access: self.write_access,
        }
    }

    /// Source scope for an operation that must follow every earlier use (a write or a layout
    /// transition). Readers only exist after a barrier made the last write available and
    /// chained to them, so waiting on the readers suffices (write-after-read); without
    /// readers the last write itself is the source (write-after-write).
    fn exclusive_src(&self) -> (vk::PipelineStageFlags2, vk::AccessFlags2) {
        if self.readers.is_empty() {
            (self.write_stage | self.chain_stage, self.write_access)
        } else {
            (self.readers | self.chain_stage, vk::AccessFlags2::NONE)
        }
    }

    /// Advances the state past `u` and returns the barrier needed before it, if any.
    pub(crate) fn apply(&mut self, u: &Use) -> Option<Dep> {
        let new_layout = u.layout.unwrap_or(vk::ImageLayout::UNDEFINED);
        let layout_change = u.layout.is_some() && self.layout != new_layout;
        let dep = |src_stage, src_access, old_layout| Dep {
            src_stage,
            src_access,
            dst_stage: u.stage,
            dst_access: u.access,
            old_layout,
            new_layout,
        };
        let result = if u.writes {
            let (src_stage, src_access) = self.exclusive_src();
            let old = if u.discards { vk::ImageLayout::UNDEFINED } else { self.layout };
            let needed = layout_change || !src_stage.is_empty() || !src_access.is_empty();
            let d = needed.then(|| dep(src_stage, src_access, old));
            self.write_stage = u.stage;
            self.write_access = write_bits(u.access);
            self.readers = vk::PipelineStageFlags2::NONE;
            self.chain_stage = vk::PipelineStageFlags2::NONE;
            self.visible.clear();
            d
        } else if layout_change {
            let (src_stage, src_access) = self.exclusive_src();
            let d = dep(src_stage, src_access, self.layout);
            self.chain_stage = u.stage;
            self.readers = u.stage;
            self.visible.clear();
            self.visible.push((u.stage, u.access));
            Some(d)
        } else {
            let src_stage = self.write_stage | self.chain_stage;
            let pending = !src_stage.is_empty() || !self.write_access.is_empty();
            let covered = self.visible.iter().any(|&(s, a)| s.contains(u.stage) && a.contains(u.access));
            self.readers |= u.stage;
            if pending && !covered {
                self.visible.push((u.stage, u.access));
                Some(dep(src_stage, self.write_access, self.layout))
            } else {
                None
            }
        };
        if u.layout.is_some() {
            self.layout = new_layout;
        }
        result
    }
}

// Recording: one batch becomes one vkCmdPipelineBarrier2.

fn image_barrier(b: &ImageBarrier, img: &GraphImage) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .image(img.raw)
        .subresource_range(img.info.full_range())
        .old_layout(b.old_layout)
        .new_layout(b.new_layout)
        .src_stage_mask(b.src_stage)
        .src_access_mask(b.src_access)
        .dst_stage_mask(b.dst_stage)
        .dst_access_mask(b.dst_access)
}

fn buffer_barrier(b: &BufferBarrier, buf: &GraphBuffer) -> vk::BufferMemoryBarrier2<'static> {
    vk::BufferMemoryBarrier2::default()
        .buffer(buf.raw)
        .offset(0)
        .size(vk::WHOLE_SIZE)
        .src_stage_mask(b.src_stage)
        .src_access_mask(b.src_access)
        .dst_stage_mask(b.dst_stage)
        .dst_access_mask(b.dst_access)
}

/// Records one batch as a single pipeline barrier; returns the barriers it held.
pub(crate) fn record_barriers(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    batch: &PassBarriers,
    res: &[Option<Resolved>],
) -> u32 {
    if batch.is_empty() {
        return 0;
    }
    let images: Vec<_> = batch
        .images
        .iter()
        .filter_map(|b| match res.get(ResourceId::Image(b.image).index()) {
            Some(Some(Resolved::Image(i))) => Some(image_barrier(b, i)),
            _ => None,
        })
        .collect();
    let buffers: Vec<_> = batch
        .buffers
        .iter()
        .filter_map(|b| match res.get(ResourceId::Buffer(b.buffer).index()) {
            Some(Some(Resolved::Buffer(x))) => Some(buffer_barrier(b, x)),
            _ => None,
        })
        .collect();
    let dep = vk::DependencyInfo::default().image_memory_barriers(&images).buffer_memory_barriers(&buffers);
    // SAFETY: cmd is recording outside a render pass; every handle is live for this graph.
    unsafe { ctx.device.cmd_pipeline_barrier2(cmd, &dep) };
    (images.len() + buffers.len()) as u32
}
