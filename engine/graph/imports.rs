//! Persistent resources entering a graph: the Vulkan handles of imported images and buffers,
//! keyed by the ids the builder returned, and the state cells their recording writes back to.

use super::builder::GraphBuilder;
use super::pass_context::{GraphBuffer, GraphImage, Resolved};
use super::resource::{BufferDesc, BufferId, ImageDesc, ImageId, ResourceId, ResourceState};
use crate::vk::{Buffer, Image, ImageInfo};
use std::sync::{Arc, Mutex};

/// Shared state cell: the resource and the graphs that imported it see the same value.
pub(crate) type StateCell = Arc<Mutex<ResourceState>>;

/// Vulkan handles of imported (persistent) resources, keyed by the ids the builder returned,
/// and the state cells recording writes back to.
#[derive(Default)]
pub struct Imports {
    pub(super) entries: Vec<(ResourceId, Resolved)>,
    pub(super) states: Vec<(ResourceId, StateCell)>,
}

fn desc_of(info: &ImageInfo) -> ImageDesc {
    ImageDesc {
        format: info.format,
        extent: info.extent,
        kind: info.kind,
        mip_levels: info.mip_levels,
        extra_usage: info.usage,
    }
}

impl Imports {
    /// Imports a persistent image whose last use left it in `state`.
    pub fn image(&mut self, g: &mut GraphBuilder<'_>, name: &str, image: &Image, state: ResourceState) -> ImageId {
        self.raw_image(g, name, GraphImage { raw: image.raw, view: image.view, info: image.info }, state)
    }

    /// Imports a persistent image that passes may only read (uploaded data, lookup tables).
    pub fn image_readonly(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        image: &Image,
        state: ResourceState,
    ) -> ImageId {
        let id = g.import_image_readonly(name, desc_of(&image.info), state);
        self.bind_image(id, image);
        id
    }

    /// Imports an image by raw handles (e.g. a swapchain image).
    pub fn raw_image(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        image: GraphImage,
        state: ResourceState,
    ) -> ImageId {
        let id = g.import_image(name, desc_of(&image.info), state);
        self.entries.push((ResourceId::Image(id), Resolved::Image(image)));
        id
    }

    /// Supplies the handles for an image already declared with `GraphBuilder::import_image`.
    pub fn bind_image(&mut self, id: ImageId, image: &Image) {
        let r = Resolved::Image(GraphImage { raw: image.raw, view: image.view, info: image.info });
        self.entries.push((ResourceId::Image(id), r));
    }

    /// Imports a persistent buffer that passes may only read (vertices, indices, tables).
    pub fn buffer_readonly(&mut self, g: &mut GraphBuilder<'_>, name: &str, buffer: &Buffer) -> BufferId {
        let id = g.import_buffer_readonly(name, BufferDesc::new(buffer.size), ResourceState::UNDEFINED);
        self.entries
            .push((ResourceId::Buffer(id), Resolved::Buffer(GraphBuffer { raw: buffer.raw, size: buffer.size })));
        id
    }

    /// Imports a persistent image that owns its state (see [`super::persistent`]).
    pub(crate) fn persistent_image(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        image: &Image,
        state: &StateCell,
    ) -> ImageId {
        let now = *state.lock().unwrap_or_else(|p| p.into_inner());
        let id = self.image(g, name, image, now);
        self.states.push((ResourceId::Image(id), state.clone()));
        id
    }

    /// Imports a persistent buffer that owns its state.
    pub(crate) fn persistent_buffer(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        buffer: &Buffer,
        state: &StateCell,
    ) -> BufferId {
        let now = *state.lock().unwrap_or_else(|p| p.into_inner());
        let id = self.buffer(g, name, buffer, now);
        self.states.push((ResourceId::Buffer(id), state.clone()));
        id
    }

    /// Imports a persistent buffer whose last use left it in `state`.
    pub fn buffer(&mut self, g: &mut GraphBuilder<'_>, name: &str, buffer: &Buffer, state: ResourceState) -> BufferId {
        let id = g.import_buffer(name, BufferDesc::new(buffer.size), state);
        self.entries
            .push((ResourceId::Buffer(id), Resolved::Buffer(GraphBuffer { raw: buffer.raw, size: buffer.size })));
        id
    }
}
