//! GPU timestamp queries.

use super::context::{Context, Garbage};
use crate::error::{Result, VkContext};
use ash::vk;

/// A pool of timestamp queries, reset and read back per frame.
pub struct TimestampPool {
    ctx: Context,
    /// Raw pool.
    pub raw: vk::QueryPool,
    /// Number of queries.
    pub capacity: u32,
}

impl TimestampPool {
    /// Creates a pool with `capacity` timestamps.
    pub fn new(ctx: &Context, capacity: u32) -> Result<Self> {
        let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(capacity.max(1));
        // SAFETY: valid device.
        let raw = unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        Ok(Self { ctx: ctx.clone(), raw, capacity: capacity.max(1) })
    }

    /// Records a reset of the first `count` queries (must precede their writes in the same submission).
    pub fn reset(&self, cmd: vk::CommandBuffer, count: u32) {
        // SAFETY: cmd is recording outside a render pass.
        unsafe { self.ctx.device.cmd_reset_query_pool(cmd, self.raw, 0, count.min(self.capacity)) };
    }

    /// Writes a timestamp after all prior work reaches `stage`.
    pub fn write(&self, cmd: vk::CommandBuffer, stage: vk::PipelineStageFlags2, index: u32) {
        if index < self.capacity {
            // SAFETY: index in range; the query was reset earlier in this command buffer.
            unsafe { self.ctx.device.cmd_write_timestamp2(cmd, stage, self.raw, index) };
        }
    }

    /// Reads `count` timestamps in nanoseconds (waits for availability).
    pub fn read_ns(&self, count: u32) -> Result<Vec<u64>> {
        let count = count.min(self.capacity);
        let mut raw = vec![0u64; count as usize];
        if count == 0 {
            return Ok(raw);
        }
        // SAFETY: queries 0..count were written by completed work.
        unsafe {
            self.ctx.device.get_query_pool_results(
                self.raw,
                0,
                &mut raw,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let period = self.ctx.info.timestamp_period_ns;
        Ok(raw.into_iter().map(|t| (t as f64 * period) as u64).collect())
    }
}

impl Drop for TimestampPool {
    fn drop(&mut self) {
        self.ctx.defer_destroy(Garbage::QueryPool(self.raw));
    }
}
