//! Transient memory: the images and buffers a compiled graph owns for one execution, placed in
//! one (aliased) allocation. A finished graph's set retires to the context and the next graph
//! with the same transient signature takes it instead of creating its own (the transient pool).

use super::pass_context::{GraphBuffer, GraphImage, Resolved};
use super::resource::info_of;
use super::{place, AliasPlan, AliasRequest, CompiledGraph, ResourceDesc, ResourceId};
use crate::error::{Error, Result, VkContext};
use crate::vk::context::TransientSet;
use crate::vk::{image::create_view, Context};
use ash::vk;
use gpu_allocator::vulkan::{AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

/// Transient memory of one execution.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct MemoryReport {
    /// Transients allocated.
    pub transients: usize,
    /// Bytes they would need without aliasing.
    pub unaliased_bytes: u64,
    /// Bytes actually allocated.
    pub heap_bytes: u64,
    /// The transients came from the pool (a finished graph with the same signature).
    pub reused: bool,
}

/// Transient objects and their shared memory. Dropped (after the graph's submission, as
/// [`RecordedGraph`] requires), they retire to the context, where the next graph with the same
/// transient signature takes them instead of creating its own.
pub(crate) struct Transients {
    ctx: Context,
    key: u64,
    set: Option<TransientSet>,
}

impl Drop for Transients {
    fn drop(&mut self) {
        if let Some(set) = self.set.take() {
            self.ctx.retire(self.key, set);
        }
    }
}

/// What a reused set needs to be bound again.
struct Layout {
    handles: Vec<(ResourceId, Resolved)>,
    requests: Vec<AliasRequest>,
    plan: AliasPlan,
    report: MemoryReport,
}

/// Everything the created objects depend on: each transient's handle, name, descriptor, usage
/// and lifetime (lifetimes decide the aliasing plan), and whether aliasing is on.
fn signature(graph: &CompiledGraph<'_>, alias: bool) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    alias.hash(&mut h);
    for t in graph.transients() {
        (t.id, &t.name, t.image_usage, t.buffer_usage, t.first, t.last).hash(&mut h);
        match &t.desc {
            ResourceDesc::Image(d) => d.hash(&mut h),
            ResourceDesc::Buffer(d) => d.hash(&mut h),
        }
    }
    h.finish()
}

/// The transient objects: a retired set with the same signature if one is free, else new ones
/// placed in one (aliased) allocation; either way the graph gets the aliasing barriers.
pub(crate) fn allocate_transients(
    ctx: &Context,
    graph: &mut CompiledGraph<'_>,
    alias: bool,
    resolved: &mut [Option<Resolved>],
) -> Result<(Transients, MemoryReport)> {
    let key = signature(graph, alias);
    let (set, reused) = match ctx.reuse(key)? {
        // A hash can collide: take the set only if it holds exactly these transients.
        Some(set) if fits(&set, graph) => (set, true),
        Some(other) => {
            ctx.retire(key, other);
            (create_transients(ctx, graph, alias)?, false)
        }
        None => (create_transients(ctx, graph, alias)?, false),
    };
    let layout =
        set.payload.downcast_ref::<Layout>().ok_or_else(|| Error::Graph("transient set of another kind".into()))?;
    if alias && !layout.handles.is_empty() {
        graph.apply_aliasing(&layout.requests, &layout.plan)?;
    }
    for (id, r) in &layout.handles {
        resolved[id.index()] = Some(*r);
    }
    let report = MemoryReport { reused, ..layout.report };
    Ok((Transients { ctx: ctx.clone(), key, set: Some(set) }, report))
}

/// Whether a retired set was made for exactly `graph`'s transients (handles, formats, extents,
/// usage, sizes, lifetimes).
fn fits(set: &TransientSet, graph: &CompiledGraph<'_>) -> bool {
    let Some(layout) = set.payload.downcast_ref::<Layout>() else { return false };
    let ts = graph.transients();
    layout.handles.len() == ts.len()
        && layout.requests.iter().zip(ts).all(|(r, t)| (r.first, r.last) == (t.first, t.last))
        && layout.handles.iter().zip(ts).all(|((id, r), t)| {
            *id == t.id
                && match (r, &t.desc) {
                    (Resolved::Image(i), ResourceDesc::Image(d)) => i.info == info_of(d, t.image_usage),
                    (Resolved::Buffer(b), ResourceDesc::Buffer(d)) => b.size == d.size,
                    _ => false,
                }
        })
}

/// Creates the transient objects, places them in one (aliased) allocation and binds them.
fn create_transients(ctx: &Context, graph: &CompiledGraph<'_>, alias: bool) -> Result<TransientSet> {
    // Until the set is complete its objects are garbage if anything fails.
    struct Partial<'c>(&'c Context, Option<TransientSet>);
    impl Drop for Partial<'_> {
        fn drop(&mut self) {
            for g in self.1.take().into_iter().flat_map(TransientSet::into_garbage) {
                self.0.defer_destroy(g);
            }
        }
    }
    let empty = TransientSet { images: vec![], buffers: vec![], allocation: None, payload: Box::new(()) };
    let mut partial = Partial(ctx, Some(empty));
    let set = partial.1.as_mut().ok_or_else(|| Error::Graph("transient set taken".into()))?;
    let mut reqs = Vec::new();
    let mut handles = Vec::new();
    for t in graph.transients() {
        match &t.desc {
            ResourceDesc::Image(desc) => {
                let info = info_of(desc, t.image_usage);
                // SAFETY: valid device and create info.
                let raw = unsafe { ctx.device.create_image(&info.create_info(), None) }.vk("vkCreateImage")?;
                set.images.push((raw, vk::ImageView::null()));
                ctx.set_name(raw, &t.name);
                // SAFETY: raw was just created.
                reqs.push(unsafe { ctx.device.get_image_memory_requirements(raw) });
                handles.push((t.id, Resolved::Image(GraphImage { raw, view: vk::ImageView::null(), info })));
            }
            ResourceDesc::Buffer(desc) => {
                let info = vk::BufferCreateInfo::default().size(desc.size.max(1)).usage(t.buffer_usage);
                // SAFETY: valid device and create info.
                let raw = unsafe { ctx.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
                set.buffers.push(raw);
                ctx.set_name(raw, &t.name);
                // SAFETY: raw was just created.
                reqs.push(unsafe { ctx.device.get_buffer_memory_requirements(raw) });
                handles.push((t.id, Resolved::Buffer(GraphBuffer { raw, size: desc.size })));
            }
        }
    }
    if handles.is_empty() {
        let layout = Layout { handles, requests: vec![], plan: AliasPlan::default(), report: MemoryReport::default() };
        set.payload = Box::new(layout);
        return partial.1.take().ok_or_else(|| Error::Graph("transient set taken".into()));
    }
    let type_bits = reqs.iter().fold(u32::MAX, |a, r| a & r.memory_type_bits);
    if type_bits == 0 {
        return Err(Error::Graph("transients share no memory type; cannot place them in one heap".into()));
    }
    let mut i = 0;
    let requests = graph.alias_requests(|_| {
        let r = reqs[i];
        i += 1;
        (r.size, r.alignment)
    });
    let granularity = ctx.info.limits.buffer_image_granularity.max(1);
    let plan = if alias {
        place(&requests, granularity)
    } else {
        let mut offset = 0u64;
        let offsets = requests
            .iter()
            .map(|r| {
                let a = r.align.max(granularity);
                let o = offset.div_ceil(a) * a;
                offset = o + r.size;
                o
            })
            .collect();
        AliasPlan { offsets, heap_size: offset, unaliased_size: offset }
    };
    let max_align = reqs.iter().map(|r| r.alignment).max().unwrap_or(1).max(granularity);
    let allocation = ctx
        .allocator()
        .allocate(&AllocationCreateDesc {
            name: "frame graph transients",
            requirements: vk::MemoryRequirements {
                size: plan.heap_size.max(1),
                alignment: max_align,
                memory_type_bits: type_bits,
            },
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|source| Error::Allocation { name: "frame graph transients".into(), source })?;
    // SAFETY: the memory handle is only used to bind resources while the allocation is kept alive in `set`.
    let (memory, base) = (unsafe { allocation.memory() }, allocation.offset());
    set.allocation = Some(allocation);
    let mut image_slot = 0;
    for ((_, r), offset) in handles.iter_mut().zip(&plan.offsets) {
        match r {
            Resolved::Image(img) => {
                // SAFETY: the offset satisfies the image's alignment inside an allocation of a compatible type.
                unsafe { ctx.device.bind_image_memory(img.raw, memory, base + offset) }.vk("vkBindImageMemory")?;
                img.view = create_view(ctx, img.raw, &img.info)?;
                set.images[image_slot].1 = img.view;
                image_slot += 1;
            }
            Resolved::Buffer(b) => {
                // SAFETY: as above, for the buffer's requirements.
                unsafe { ctx.device.bind_buffer_memory(b.raw, memory, base + offset) }.vk("vkBindBufferMemory")?;
            }
        }
    }
    let report = MemoryReport {
        transients: plan.offsets.len(),
        unaliased_bytes: plan.unaliased_size,
        heap_bytes: plan.heap_size,
        reused: false,
    };
    set.payload = Box::new(Layout { handles, requests, plan, report });
    partial.1.take().ok_or_else(|| Error::Graph("transient set taken".into()))
}
