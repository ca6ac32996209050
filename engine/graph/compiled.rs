//! The result of compilation: what the executor walks, plus the aliasing patch step.

use ash::vk;

use super::access::Access;
use super::alias::{AliasPlan, AliasRequest};
use super::barriers::{BufferBarrier, ImageBarrier, PassBarriers};
use super::builder::{ColorAttachment, DepthAttachment, PassKind, RecordFn};
use super::error::GraphError;
use super::resource::{ResourceDesc, ResourceId, ResourceState};
use super::work::Work;

/// One pass's merged use of one resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResourceUse {
    /// Resource.
    pub resource: ResourceId,
    /// Union of the stages of its accesses.
    pub stage: vk::PipelineStageFlags2,
    /// Union of its access masks.
    pub access: vk::AccessFlags2,
    /// Layout for images, `None` for buffers.
    pub layout: Option<vk::ImageLayout>,
    /// Observes the previous version.
    pub reads: bool,
    /// Produces a new version.
    pub writes: bool,
}

/// A kept pass, in execution order.
pub struct CompiledPass<'a> {
    /// Declared name.
    pub name: String,
    /// Kind.
    pub kind: PassKind,
    /// Index among all declared passes.
    pub declared_index: usize,
    /// Barriers to record before the pass.
    pub barriers: PassBarriers,
    /// Color attachments (raster passes).
    pub color_attachments: Vec<ColorAttachment>,
    /// Depth attachment (raster passes).
    pub depth_attachment: Option<DepthAttachment>,
    /// Every resource the pass touches.
    pub uses: Vec<ResourceUse>,
    /// Declared or derived work, for efficiency reports.
    pub work: Work,
    pub(crate) record: Option<RecordFn<'a>>,
}

impl<'a> CompiledPass<'a> {
    /// Moves the recording closure out (once); `None` if absent or already taken.
    pub fn take_record(&mut self) -> Option<RecordFn<'a>> {
        self.record.take()
    }
}

/// A pass removed because nothing exported depends on it.
#[derive(Clone, Debug)]
pub struct CulledPass {
    /// Declared name.
    pub name: String,
    /// Kind.
    pub kind: PassKind,
    /// Declared uses.
    pub uses: Vec<ResourceUse>,
}

/// A declared resource, as the executor and tools see it.
#[derive(Clone, Debug)]
pub struct ResourceInfo {
    /// Handle.
    pub id: ResourceId,
    /// Declared name.
    pub name: String,
    /// Descriptor.
    pub desc: ResourceDesc,
    /// Imported (persistent) rather than graph-owned.
    pub imported: bool,
    /// Imported read-only.
    pub read_only: bool,
    /// `Some(final access)` if exported.
    pub export: Option<Option<Access>>,
}

/// A graph-owned resource the executor must allocate.
#[derive(Clone, Debug)]
pub struct Transient {
    /// Handle.
    pub id: ResourceId,
    /// Declared name.
    pub name: String,
    /// Descriptor (its `extra_usage` is already folded into the usage fields).
    pub desc: ResourceDesc,
    /// Creation usage for images (empty for buffers).
    pub image_usage: vk::ImageUsageFlags,
    /// Creation usage for buffers (empty for images).
    pub buffer_usage: vk::BufferUsageFlags,
    /// First position in the compiled order that uses it.
    pub first: usize,
    /// Last position that uses it (the end of the graph if exported).
    pub last: usize,
    /// State after its last use: what a later occupant of its memory must wait for.
    pub(crate) end_state: ResourceState,
    /// Stage/access/layout of its first use, for inserting aliasing barriers.
    pub(crate) first_use: ResourceUse,
}

/// Counts describing one compilation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GraphStats {
    /// Passes declared.
    pub passes_declared: usize,
    /// Passes in the order.
    pub passes_kept: usize,
    /// Passes culled.
    pub passes_culled: usize,
    /// Image + buffer barriers, including the final batch.
    pub barriers: usize,
    /// Image barriers whose old and new layout differ.
    pub layout_transitions: usize,
    /// Transients to allocate.
    pub transients: usize,
}

/// A culled, ordered and synchronized graph, ready for memory placement and execution.
pub struct CompiledGraph<'a> {
    pub(crate) passes: Vec<CompiledPass<'a>>,
    pub(crate) culled: Vec<CulledPass>,
    pub(crate) resources: Vec<ResourceInfo>,
    pub(crate) transients: Vec<Transient>,
    pub(crate) final_barriers: PassBarriers,
    pub(crate) final_states: Vec<(ResourceId, ResourceState)>,
    pub(crate) stats: GraphStats,
    pub(crate) aliased: bool,
}

impl<'a> CompiledGraph<'a> {
    /// Kept passes in execution order.
    pub fn passes(&self) -> &[CompiledPass<'a>] {
        &self.passes
    }

    /// Kept passes, mutable so the executor can take their closures.
    pub fn passes_mut(&mut self) -> &mut [CompiledPass<'a>] {
        &mut self.passes
    }

    /// Culled passes in declaration order.
    pub fn culled_passes(&self) -> &[CulledPass] {
        &self.culled
    }

    /// Every declared resource, indexed by `ResourceId::index`.
    pub fn resources(&self) -> &[ResourceInfo] {
        &self.resources
    }

    /// Transients to allocate, in resource declaration order.
    pub fn transients(&self) -> &[Transient] {
        &self.transients
    }

    /// Barriers to record after the last pass (export transitions).
    pub fn final_barriers(&self) -> &PassBarriers {
        &self.final_barriers
    }

    /// State of every imported resource after the graph; feed it to next frame's import.
    pub fn final_states(&self) -> &[(ResourceId, ResourceState)] {
        &self.final_states
    }

    /// Final state of one imported resource.
    pub fn final_state(&self, id: ResourceId) -> Option<ResourceState> {
        self.final_states.iter().find(|(r, _)| *r == id).map(|&(_, s)| s)
    }

    /// Compilation statistics.
    pub fn stats(&self) -> GraphStats {
        self.stats
    }

    /// Builds placement requests from device memory requirements `(size, align)` per transient.
    pub fn alias_requests(&self, mut requirements: impl FnMut(&Transient) -> (u64, u64)) -> Vec<AliasRequest> {
        self.transients
            .iter()
            .map(|t| {
                let (size, align) = requirements(t);
                AliasRequest { size, align, first: t.first, last: t.last }
            })
            .collect()
    }

    /// Adds the barriers memory sharing needs, given the requests (from `alias_requests`) and
    /// the plan `place` made from them; both are indexed like `transients()`.
    ///
    /// A transient's first use then waits for every earlier-ending transient whose address
    /// range it overlaps (their last-use stages, and their writes made available). Call it at
    /// most once per compiled graph; skip it to execute without aliasing.
    pub fn apply_aliasing(&mut self, requests: &[AliasRequest], plan: &AliasPlan) -> Result<(), GraphError> {
        if self.aliased {
            return Err(GraphError::AlreadyAliased);
        }
        let expected = self.transients.len();
        for got in [requests.len(), plan.offsets.len()] {
            if got != expected {
                return Err(GraphError::AliasPlanMismatch { expected, got });
            }
        }
        let range = |i: usize| (plan.offsets[i], plan.offsets[i] + requests[i].size);
        for (i, t) in self.transients.iter().enumerate() {
            let (start, end) = range(i);
            let mut src_stage = vk::PipelineStageFlags2::NONE;
            let mut src_access = vk::AccessFlags2::NONE;
            for (j, prev) in self.transients.iter().enumerate() {
                let (ps, pe) = range(j);
                if prev.last < t.first && ps < end && start < pe {
                    src_stage |= prev.end_state.stage;
                    src_access |= prev.end_state.access;
                }
            }
            if src_stage.is_empty() && src_access.is_empty() {
                continue;
            }
            let barriers = &mut self.passes[t.first].barriers;
            let u = t.first_use;
            match t.id {
                ResourceId::Image(image) => match barriers.images.iter_mut().find(|b| b.image == image) {
                    Some(b) => {
                        b.src_stage |= src_stage;
                        b.src_access |= src_access;
                        b.old_layout = vk::ImageLayout::UNDEFINED;
                    }
                    None => {
                        barriers.images.push(ImageBarrier {
                            image,
                            src_stage,
                            src_access,
                            dst_stage: u.stage,
                            dst_access: u.access,
                            old_layout: vk::ImageLayout::UNDEFINED,
                            new_layout: u.layout.unwrap_or_default(),
                        });
                        self.stats.barriers += 1;
                        self.stats.layout_transitions += 1;
                    }
                },
                ResourceId::Buffer(buffer) => match barriers.buffers.iter_mut().find(|b| b.buffer == buffer) {
                    Some(b) => {
                        b.src_stage |= src_stage;
                        b.src_access |= src_access;
                    }
                    None => {
                        barriers.buffers.push(BufferBarrier {
                            buffer,
                            src_stage,
                            src_access,
                            dst_stage: u.stage,
                            dst_access: u.access,
                        });
                        self.stats.barriers += 1;
                    }
                },
            }
        }
        self.aliased = true;
        Ok(())
    }
}
