//! GPU buffers with deferred destruction.

use super::context::{Context, Garbage};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

/// A buffer and its memory; destroyed once the GPU is done with it after the last owner drops it.
pub struct Buffer {
    ctx: Context,
    /// Raw handle.
    pub raw: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
    allocation: Option<Allocation>,
}

impl Buffer {
    /// Creates a buffer in `location` (GpuOnly, CpuToGpu for uploads, GpuToCpu for readback).
    pub fn new(
        ctx: &Context,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Self> {
        if size == 0 {
            return Err(Error::Input(format!("buffer `{name}`: size must be > 0")));
        }
        let info = vk::BufferCreateInfo::default().size(size).usage(usage).sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        // SAFETY: raw was just created from this device.
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let allocation = ctx
            .allocator()
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| {
                // SAFETY: buffer unused so far.
                unsafe { ctx.device.destroy_buffer(raw, None) };
                Error::Allocation { name: name.into(), source }
            })?;
        // SAFETY: allocation satisfies the buffer's requirements.
        if let Err(e) = unsafe { ctx.device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) } {
            ctx.defer_destroy(Garbage::Buffer(raw, allocation));
            return Err(Error::Vulkan { call: "vkBindBufferMemory", result: e });
        }
        ctx.set_name(raw, name);
        Ok(Self { ctx: ctx.clone(), raw, size, allocation: Some(allocation) })
    }

    /// A host-visible (CpuToGpu) buffer holding `data`: staging, per-frame vertices, small tables.
    pub fn with_data(ctx: &Context, name: &str, data: &[u8], usage: vk::BufferUsageFlags) -> Result<Self> {
        let mut b = Self::new(ctx, name, data.len() as u64, usage, MemoryLocation::CpuToGpu)?;
        b.write_bytes(data)?;
        Ok(b)
    }

    /// Host-visible bytes of the buffer, if it was allocated in mappable memory.
    pub fn mapped(&self) -> Option<&[u8]> {
        self.allocation.as_ref()?.mapped_slice()
    }

    /// The little-endian u32 at word `i` of a host-visible buffer (0 if unmapped or past its end).
    pub fn mapped_u32(&self, i: usize) -> u32 {
        self.mapped().and_then(|b| b.get(4 * i..4 * i + 4)).map_or(0, |w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
    }

    /// Mutable host-visible bytes, if mappable.
    pub fn mapped_mut(&mut self) -> Option<&mut [u8]> {
        self.allocation.as_mut()?.mapped_slice_mut()
    }

    /// Copies `data` into a mappable buffer (CpuToGpu/GpuToCpu).
    pub fn write_bytes(&mut self, data: &[u8]) -> Result<()> {
        let dst = self.mapped_mut().ok_or_else(|| Error::Input("buffer is not host-visible".into()))?;
        if data.len() > dst.len() {
            return Err(Error::Input(format!("write of {} bytes exceeds buffer of {}", data.len(), dst.len())));
        }
        dst[..data.len()].copy_from_slice(data);
        Ok(())
    }

    /// Full-range descriptor info for push descriptors.
    pub fn descriptor(&self) -> vk::DescriptorBufferInfo {
        vk::DescriptorBufferInfo::default().buffer(self.raw).offset(0).range(vk::WHOLE_SIZE)
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            self.ctx.defer_destroy(Garbage::Buffer(self.raw, a));
        }
    }
}
