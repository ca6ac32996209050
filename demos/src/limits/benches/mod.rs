//! The suite's benchmarks, each a [`Bench`](super::Bench): memory bandwidth ([`memory`]: buffer
//! copy, storage buffers, storage images), fetch and atomic rates ([`rates`]), dispatch and draw
//! overhead ([`overhead`]) and the LPV SH layout comparison ([`lpv_layout`]). Their readbacks and
//! `expected` values are what the tests check. Below: what they share to create resources.

mod lpv_layout;
mod memory;
mod overhead;
mod rates;

pub use lpv_layout::{LpvLayoutBench, ShLayout};
pub use memory::{BufferReadBench, BufferWriteBench, CopyBench, ImageReadBench, ImageWriteBench};
pub use overhead::{DispatchBench, DrawBench};
pub use rates::{linear_rgba32f_unsupported, AtomicBench, TextureBench, Unsupported};

use super::{Case, Rate};
use vkengine::graph::PersistentBuffer;
use vkengine::graph::{Access, ResourceState};
use vkengine::vk::{vk, Buffer, Context, Image, ImageInfo, MemoryLocation};
use vkengine::Result;

const MIB: f64 = 1024.0 * 1024.0;

fn mib(bytes: u64) -> f64 {
    bytes as f64 / MIB
}

/// A case measured in GB/s of `bytes` per pass.
fn bandwidth(name: &str, detail: String, bytes: u64) -> Case {
    Case {
        name: name.into(),
        detail,
        unit: "GB/s",
        work: bytes as f64,
        work_unit: "bytes",
        rate: Rate::PerSecond(1e9),
        skipped: None,
    }
}

/// The state `Context::upload_buffer` leaves a buffer in (its copy still to be made visible).
fn after_buffer_upload() -> ResourceState {
    ResourceState::from_access(Access::TransferDst)
}

/// Uploads texels into `image`, leaving it in `layout` visible to compute `access`, and returns
/// that state (the upload's barrier already made the copy visible, so no write is pending).
fn upload_image(
    ctx: &Context,
    image: &Image,
    bytes: &[u8],
    layout: vk::ImageLayout,
    access: vk::AccessFlags2,
) -> Result<ResourceState> {
    let stage = vk::PipelineStageFlags2::COMPUTE_SHADER;
    ctx.upload_image(image, bytes, layout, stage, access)?;
    Ok(ResourceState { layout, stage, access: vk::AccessFlags2::NONE })
}

fn storage_buffer(ctx: &Context, name: &str, bytes: u64) -> Result<PersistentBuffer> {
    let usage =
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC;
    Ok(PersistentBuffer::new(Buffer::new(ctx, name, bytes, usage, MemoryLocation::GpuOnly)?))
}

fn uploaded(ctx: &Context, name: &str, data: &[u8], usage: vk::BufferUsageFlags) -> Result<PersistentBuffer> {
    Ok(PersistentBuffer::with_state(ctx.upload_buffer(name, data, usage)?, after_buffer_upload()))
}

fn rgba32f_3d(ctx: &Context, name: &str, n: u32, usage: vk::ImageUsageFlags) -> Result<Image> {
    Image::new(ctx, name, ImageInfo::d3(vk::Format::R32G32B32A32_SFLOAT, [n, n, n], usage))
}
