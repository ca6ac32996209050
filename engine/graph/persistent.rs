//! Resources that outlive a frame and own the state their last use left them in. A graph
//! imports one with [`Imports::persistent_image`]/[`Imports::persistent_buffer`]; recording the
//! graph writes the state it ends in back, so no caller copies `final_state` around.

use super::builder::GraphBuilder;
use super::imports::{Imports, StateCell};
use super::resource::{BufferId, ImageId, ResourceState};
use crate::vk::{vk, Buffer, Context, Image};
use crate::Result;
use std::sync::{Arc, Mutex};

fn load(cell: &StateCell) -> ResourceState {
    *cell.lock().unwrap_or_else(|p| p.into_inner())
}

fn store(cell: &StateCell, state: ResourceState) {
    *cell.lock().unwrap_or_else(|p| p.into_inner()) = state;
}

/// After a host readback: the next graph's first use also waits for that transfer.
fn read_by_transfer(cell: &StateCell) {
    let mut s = load(cell);
    s.stage |= vk::PipelineStageFlags2::TRANSFER;
    store(cell, s);
}

/// A persistent image with its state.
pub struct PersistentImage {
    image: Image,
    state: StateCell,
}

impl PersistentImage {
    /// Wraps an image whose contents are undefined.
    pub fn new(image: Image) -> Self {
        Self::with_state(image, ResourceState::UNDEFINED)
    }

    /// Wraps an image that the caller left in `state` (e.g. after an upload).
    pub fn with_state(image: Image, state: ResourceState) -> Self {
        Self { image, state: Arc::new(Mutex::new(state)) }
    }

    /// The image.
    pub fn image(&self) -> &Image {
        &self.image
    }

    /// The state the last recorded graph (or upload) left it in.
    pub fn state(&self) -> ResourceState {
        load(&self.state)
    }

    /// Declares it in `g`; recording the graph updates its state.
    pub fn import(&self, g: &mut GraphBuilder<'_>, imports: &mut Imports, name: &str) -> ImageId {
        imports.persistent_image(g, name, &self.image, &self.state)
    }

    /// Reads it back as bytes (any format; rows tightly packed); it returns to its layout.
    pub fn read(&self, ctx: &Context) -> Result<Vec<u8>> {
        let s = self.state();
        let bytes = ctx.read_image(&self.image, s.layout, s.stage, s.access)?;
        read_by_transfer(&self.state);
        Ok(bytes)
    }

    /// Reads an RGBA32F image back as texels; it returns to its layout.
    pub fn read_rgba32f(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        let s = self.state();
        let texels = ctx.read_image_rgba32f(&self.image, s.layout, s.stage, s.access)?;
        read_by_transfer(&self.state);
        Ok(texels)
    }

    /// Records that work outside any graph (a blit, a presentation engine) left it in `state`.
    pub fn set_state(&self, state: ResourceState) {
        store(&self.state, state);
    }
}

impl std::ops::Deref for PersistentImage {
    type Target = Image;
    fn deref(&self) -> &Image {
        &self.image
    }
}

/// A persistent buffer with its state.
pub struct PersistentBuffer {
    buffer: Buffer,
    state: StateCell,
}

impl PersistentBuffer {
    /// Wraps a buffer whose contents are undefined.
    pub fn new(buffer: Buffer) -> Self {
        Self::with_state(buffer, ResourceState::UNDEFINED)
    }

    /// Wraps a buffer that the caller left in `state` (e.g. after an upload).
    pub fn with_state(buffer: Buffer, state: ResourceState) -> Self {
        Self { buffer, state: Arc::new(Mutex::new(state)) }
    }

    /// Reads it back through a staging copy.
    pub fn read(&self, ctx: &Context) -> Result<Vec<u8>> {
        let bytes = ctx.read_buffer(&self.buffer)?;
        read_by_transfer(&self.state);
        Ok(bytes)
    }

    /// The buffer.
    pub fn buffer(&self) -> &Buffer {
        &self.buffer
    }

    /// The state the last recorded graph left it in.
    pub fn state(&self) -> ResourceState {
        load(&self.state)
    }

    /// Declares it in `g`; recording the graph updates its state.
    pub fn import(&self, g: &mut GraphBuilder<'_>, imports: &mut Imports, name: &str) -> BufferId {
        imports.persistent_buffer(g, name, &self.buffer, &self.state)
    }
}

impl std::ops::Deref for PersistentBuffer {
    type Target = Buffer;
    fn deref(&self) -> &Buffer {
        &self.buffer
    }
}
