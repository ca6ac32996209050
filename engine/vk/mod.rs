//! Vulkan context and resources: instance/device, memory, buffers, images, pipelines, queries,
//! swapchain. Everything else in the engine goes through these.

pub mod buffer;
pub mod commands;
pub mod context;
pub mod debug;
pub(crate) mod garbage;
pub mod image;
pub mod pipeline;
pub mod pipeline_cache;
pub mod query;
pub mod sampler;
pub mod select;
pub mod transfer;

pub use ash::vk;
pub use buffer::Buffer;
pub use commands::CommandPool;
pub use context::{
    list_devices, parse_gpu_timeout, Context, ContextOptions, DeviceInfo, Validation, DEFAULT_GPU_TIMEOUT,
};
pub use debug::{MessageSink, ValidationMessage};
pub use gpu_allocator::MemoryLocation;
pub use image::{Image, ImageInfo, ImageKind};
pub use pipeline::{Binding, Blend, Descriptor, GraphicsDesc, Pipeline};
pub use pipeline_cache::Sampling;
pub use query::TimestampPool;
pub use sampler::Sampler;
