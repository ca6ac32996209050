//! Command pools and one-shot command submission.

use super::context::{Context, Garbage};
use crate::error::{Result, VkContext};
use ash::vk;

/// A command pool owned by one recording thread, with recycled command buffers.
pub struct CommandPool {
    ctx: Context,
    /// Raw pool.
    pub raw: vk::CommandPool,
}

impl CommandPool {
    /// Creates a resettable pool on the context's queue family.
    pub fn new(ctx: &Context) -> Result<Self> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER | vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: valid device.
        let raw = unsafe { ctx.device.create_command_pool(&info, None) }.vk("vkCreateCommandPool")?;
        Ok(Self { ctx: ctx.clone(), raw })
    }

    /// Allocates one primary command buffer (freed with the pool).
    pub fn allocate(&self) -> Result<vk::CommandBuffer> {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.raw)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: pool belongs to this device and is used from one thread.
        Ok(unsafe { self.ctx.device.allocate_command_buffers(&info) }.vk("vkAllocateCommandBuffers")?[0])
    }
}

impl Drop for CommandPool {
    fn drop(&mut self) {
        self.ctx.defer_destroy(Garbage::CommandPool(self.raw));
    }
}

/// Begins a one-time-submit command buffer.
pub fn begin(ctx: &Context, cmd: vk::CommandBuffer) -> Result<()> {
    let info = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
    // SAFETY: cmd is in the initial state (fresh or reset).
    unsafe { ctx.device.begin_command_buffer(cmd, &info) }.vk("vkBeginCommandBuffer")
}

impl Context {
    /// Records `f` into a fresh command buffer, submits it and waits for completion.
    pub fn one_shot<R>(&self, f: impl FnOnce(vk::CommandBuffer) -> Result<R>) -> Result<R> {
        let pool = CommandPool::new(self)?;
        let cmd = pool.allocate()?;
        begin(self, cmd)?;
        let r = f(cmd)?;
        // SAFETY: cmd is recording.
        unsafe { self.device.end_command_buffer(cmd) }.vk("vkEndCommandBuffer")?;
        let value = self.submit(&[cmd], &[], &[])?;
        self.wait_for(value)?;
        drop(pool);
        self.collect_garbage()?;
        Ok(r)
    }
}
