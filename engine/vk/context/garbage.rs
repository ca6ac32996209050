//! Deferred destruction and retired transient sets: a dropped resource becomes [`Garbage`]
//! tagged with the latest submitted timeline value and is freed once the GPU passed it; a
//! finished graph's transients wait here, under their signature, for the next identical graph.

use super::Shared;
use crate::error::Result;
use ash::vk;
use gpu_allocator::vulkan::Allocation;

/// A Vulkan object waiting for the GPU to finish with it.
pub(crate) enum Garbage {
    Buffer(vk::Buffer, Allocation),
    RawBuffer(vk::Buffer),
    Allocation(Allocation),
    Image(vk::Image, Vec<vk::ImageView>, Option<Allocation>),
    Pipeline(vk::Pipeline),
    PipelineLayout(vk::PipelineLayout),
    DescriptorSetLayout(vk::DescriptorSetLayout),
    QueryPool(vk::QueryPool),
    Sampler(vk::Sampler),
    BufferView(vk::BufferView),
    CommandPool(vk::CommandPool),
}

/// How many finished graphs' transient sets the context keeps for reuse (a frame loop needs
/// one per frame in flight; a few more cover alternating graphs such as a UI toggle).
pub const RETIRED_SETS: usize = 8;

/// One graph's transient objects: images with their views, buffers, their shared memory, and
/// what the graph executor needs to bind them again (opaque here).
pub(crate) struct TransientSet {
    pub(crate) images: Vec<(vk::Image, vk::ImageView)>,
    pub(crate) buffers: Vec<vk::Buffer>,
    pub(crate) allocation: Option<Allocation>,
    pub(crate) payload: Box<dyn std::any::Any + Send + Sync>,
}

impl TransientSet {
    /// The objects as garbage, for destruction.
    pub(crate) fn into_garbage(self) -> impl Iterator<Item = Garbage> {
        let images = self.images.into_iter().map(|(i, v)| Garbage::Image(i, vec![v], None));
        let buffers = self.buffers.into_iter().map(Garbage::RawBuffer);
        images.chain(buffers).chain(self.allocation.map(Garbage::Allocation))
    }
}

pub(crate) struct Retired {
    key: u64,
    retired_at: u64,
    set: TransientSet,
}

impl Retired {
    pub(crate) fn into_garbage(self) -> impl Iterator<Item = Garbage> {
        self.set.into_garbage()
    }
}

impl Shared {
    /// Keeps a finished graph's transient objects for a later graph with the same `key`. Beyond
    /// [`RETIRED_SETS`] sets the oldest is destroyed.
    pub(crate) fn retire(&self, key: u64, set: TransientSet) {
        let entry = Retired { key, retired_at: self.last_submitted(), set };
        let evicted = {
            let mut list = self.retired.lock().unwrap_or_else(|p| p.into_inner());
            list.push(entry);
            (list.len() > RETIRED_SETS).then(|| list.remove(0))
        };
        for g in evicted.into_iter().flat_map(Retired::into_garbage) {
            self.defer_destroy(g);
        }
    }

    /// A retired transient set with signature `key` whose last submission has completed.
    pub(crate) fn reuse(&self, key: u64) -> Result<Option<TransientSet>> {
        let done = self.completed()?;
        let mut list = self.retired.lock().unwrap_or_else(|p| p.into_inner());
        Ok(list.iter().position(|r| r.key == key && r.retired_at <= done).map(|i| list.remove(i).set))
    }

    /// Schedules `g` for destruction once the GPU has finished all work submitted so far.
    pub(crate) fn defer_destroy(&self, g: Garbage) {
        let tag = self.last_submitted();
        self.garbage.lock().unwrap_or_else(|p| p.into_inner()).push((tag, g));
    }

    /// Frees deferred garbage whose submissions have completed; call once per frame.
    pub fn collect_garbage(&self) -> Result<()> {
        let done = self.completed()?;
        let ready: Vec<Garbage> = {
            let mut list = self.garbage.lock().unwrap_or_else(|p| p.into_inner());
            let (ready, keep): (Vec<_>, Vec<_>) = list.drain(..).partition(|(t, _)| *t <= done);
            *list = keep;
            ready.into_iter().map(|(_, g)| g).collect()
        };
        for g in ready {
            self.destroy_now(g);
        }
        Ok(())
    }

    pub(super) fn destroy_now(&self, g: Garbage) {
        let d = &self.device;
        // SAFETY: each handle was created from this device and its last use has completed.
        unsafe {
            match g {
                Garbage::Buffer(b, a) => {
                    d.destroy_buffer(b, None);
                    let _ = self.allocator().free(a);
                }
                Garbage::RawBuffer(b) => d.destroy_buffer(b, None),
                Garbage::Allocation(a) => {
                    let _ = self.allocator().free(a);
                }
                Garbage::Image(i, views, a) => {
                    for v in views {
                        d.destroy_image_view(v, None);
                    }
                    d.destroy_image(i, None);
                    if let Some(a) = a {
                        let _ = self.allocator().free(a);
                    }
                }
                Garbage::Pipeline(p) => d.destroy_pipeline(p, None),
                Garbage::PipelineLayout(l) => d.destroy_pipeline_layout(l, None),
                Garbage::DescriptorSetLayout(l) => d.destroy_descriptor_set_layout(l, None),
                Garbage::QueryPool(q) => d.destroy_query_pool(q, None),
                Garbage::Sampler(s) => d.destroy_sampler(s, None),
                Garbage::BufferView(v) => d.destroy_buffer_view(v, None),
                Garbage::CommandPool(p) => d.destroy_command_pool(p, None),
            }
        }
    }
}
