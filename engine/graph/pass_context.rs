//! What a pass's record closure sees: the context, its command buffer and the Vulkan handles
//! behind the resource ids it declared. Below the builder (whose record closures take a
//! [`PassContext`]) and the executor (which makes one per pass).

use super::resource::{BufferId, ImageId, ResourceId};
use crate::error::{Error, Result};
use crate::vk::{Context, ImageInfo};
use ash::vk;
use std::cell::Cell;

/// An image as a pass sees it.
#[derive(Clone, Copy, Debug)]
pub struct GraphImage {
    /// Raw image.
    pub raw: vk::Image,
    /// View over all mips and layers (null for transfer-only images).
    pub view: vk::ImageView,
    /// Format, extent, kind, usage.
    pub info: ImageInfo,
}

/// A buffer as a pass sees it.
#[derive(Clone, Copy, Debug)]
pub struct GraphBuffer {
    /// Raw buffer.
    pub raw: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum Resolved {
    Image(GraphImage),
    Buffer(GraphBuffer),
}

/// What a pass's record closure receives: the device, the command buffer, and its resources.
pub struct PassContext<'r> {
    /// The engine context.
    pub ctx: &'r Context,
    /// Command buffer to record into (inside dynamic rendering for raster passes).
    pub cmd: vk::CommandBuffer,
    /// Render area of a raster pass (zero for other passes).
    pub extent: vk::Extent2D,
    pub(super) resources: &'r [Option<Resolved>],
    pub(super) views: &'r BufferViews,
    /// Dispatches recorded so far (the shader-pass dispatcher counts them).
    pub(crate) dispatches: Cell<u32>,
}

/// Texel-buffer views made while recording, destroyed once the graph's submission is done.
pub(crate) struct BufferViews {
    ctx: Context,
    views: std::cell::RefCell<Vec<vk::BufferView>>,
}

impl BufferViews {
    /// An empty set, for one recording.
    pub(crate) fn new(ctx: &Context) -> Self {
        Self { ctx: ctx.clone(), views: Default::default() }
    }
}

impl Drop for BufferViews {
    fn drop(&mut self) {
        // Dropped with the recorded graph, after its submission: the tag covers that submission.
        for v in self.views.take() {
            self.ctx.defer_destroy(crate::vk::context::Garbage::BufferView(v));
        }
    }
}

impl PassContext<'_> {
    /// The resolved image behind `id`; panics if the pass did not declare it (a graph bug).
    pub fn image(&self, id: ImageId) -> GraphImage {
        match self.resources.get(ResourceId::Image(id).index()) {
            Some(Some(Resolved::Image(i))) => *i,
            _ => panic!("image {id:?} is not a resolved image of this graph"),
        }
    }

    /// The resolved buffer behind `id`; panics if the pass did not declare it (a graph bug).
    pub fn buffer(&self, id: BufferId) -> GraphBuffer {
        match self.resources.get(ResourceId::Buffer(id).index()) {
            Some(Some(Resolved::Buffer(b))) => *b,
            _ => panic!("buffer {id:?} is not a resolved buffer of this graph"),
        }
    }

    /// The logical device.
    pub fn device(&self) -> &ash::Device {
        &self.ctx.device
    }

    /// A texel-buffer view of `buffer`, destroyed once the graph's submission is done.
    pub(crate) fn texel_view(&self, buffer: BufferId, format: vk::Format) -> Result<vk::BufferView> {
        let info = vk::BufferViewCreateInfo::default()
            .buffer(self.buffer(buffer).raw)
            .format(format)
            .offset(0)
            .range(vk::WHOLE_SIZE);
        // SAFETY: the buffer is this graph's, created with storage-texel usage.
        let view = unsafe { self.ctx.device.create_buffer_view(&info, None) }
            .map_err(|e| Error::Graph(format!("vkCreateBufferView: {e}")))?;
        self.views.views.borrow_mut().push(view);
        Ok(view)
    }
}
