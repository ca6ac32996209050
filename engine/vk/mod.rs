//! Vulkan context and resources: instance/device choice and the submission timeline
//! (`context`, which owns the deferred-destruction queue and the pipeline cache), memory,
//! buffers, images, samplers, pipelines, queries, transfers, command recording. Every other file
//! here builds on `context`; `context` in turn uses `debug`, `select` and, for the cache it owns,
//! `pipeline` (the one listed mutual pair in `tools/modcycles.py`). Everything else in the engine
//! goes through these; this module uses no other engine module but `crate::error` and
//! `crate::shaders`.

pub mod buffer;
pub mod commands;
pub mod context;
pub mod debug;
pub mod image;
pub mod pipeline;
pub mod query;
pub mod sampler;
pub mod select;
pub mod transfer;

pub use ash::vk;
pub use buffer::Buffer;
pub use commands::CommandPool;
pub use context::{
    is_llvmpipe, list_devices, parse_gpu_timeout, Context, ContextOptions, DeviceInfo, Validation, DEFAULT_GPU_TIMEOUT,
};
pub use debug::{MessageSink, ValidationMessage};
pub use gpu_allocator::MemoryLocation;
pub use image::{Image, ImageInfo, ImageKind};
pub use pipeline::cache::Sampling;
pub use pipeline::{Binding, Blend, Descriptor, GraphicsDesc, Pipeline};
pub use query::TimestampPool;
pub use sampler::Sampler;
