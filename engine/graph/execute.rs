//! Executor: turns a compiled graph into commands — allocates (and aliases) transient memory,
//! records each pass's barrier batch, debug label, dynamic-rendering scope and closure, and
//! brackets passes with GPU timestamps. Transient memory is in `transients`; what stays here is
//! the resolved-handle table, imports and the recording loop, which share private types.

use super::barriers::record_barriers;
use super::commands::Commands;
use super::persistent::StateCell;
use super::shader_pass::Slot;
use super::transients::{allocate_transients, Transients};
use super::{
    BufferId, CompiledGraph, GraphBuilder, ImageDesc, ImageId, LoadOp, PassKind, ResourceId, ResourceState, Work,
};
use crate::error::{Error, Result};
use crate::graph::trace::PassTiming;
use crate::vk::pipeline_cache::CachedPipeline;
use crate::vk::{Buffer, Context, Image, ImageInfo, TimestampPool};
use ash::vk;
use std::cell::Cell;
use std::ffi::CString;
use std::time::Instant;

/// An image as a pass sees it.
#[derive(Clone, Copy, Debug)]
pub struct GraphImage {
    /// Raw image.
    pub raw: vk::Image,
    /// View over all mips and layers (null for transfer-only images).
    pub view: vk::ImageView,
    /// Format, extent, kind, usage.
    pub info: ImageInfo,
}

/// A buffer as a pass sees it.
#[derive(Clone, Copy, Debug)]
pub struct GraphBuffer {
    /// Raw buffer.
    pub raw: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum Resolved {
    Image(GraphImage),
    Buffer(GraphBuffer),
}

/// What a pass's record closure receives: the device, the command buffer, and its resources.
pub struct PassContext<'r> {
    /// The engine context.
    pub ctx: &'r Context,
    /// Command buffer to record into (inside dynamic rendering for raster passes).
    pub cmd: vk::CommandBuffer,
    /// Render area of a raster pass (zero for other passes).
    pub extent: vk::Extent2D,
    resources: &'r [Option<Resolved>],
    views: &'r BufferViews,
    /// Dispatches recorded so far (the shader-pass dispatcher counts them).
    pub(crate) dispatches: Cell<u32>,
}

/// Texel-buffer views made while recording, destroyed once the graph's submission is done.
pub(crate) struct BufferViews {
    ctx: Context,
    views: std::cell::RefCell<Vec<vk::BufferView>>,
}

impl Drop for BufferViews {
    fn drop(&mut self) {
        // Dropped with the recorded graph, after its submission: the tag covers that submission.
        for v in self.views.take() {
            self.ctx.defer_destroy(crate::vk::garbage::Garbage::BufferView(v));
        }
    }
}

impl PassContext<'_> {
    /// The resolved image behind `id`; panics if the pass did not declare it (a graph bug).
    pub fn image(&self, id: ImageId) -> GraphImage {
        match self.resources.get(ResourceId::Image(id).index()) {
            Some(Some(Resolved::Image(i))) => *i,
            _ => panic!("image {id:?} is not a resolved image of this graph"),
        }
    }

    /// The resolved buffer behind `id`; panics if the pass did not declare it (a graph bug).
    pub fn buffer(&self, id: BufferId) -> GraphBuffer {
        match self.resources.get(ResourceId::Buffer(id).index()) {
            Some(Some(Resolved::Buffer(b))) => *b,
            _ => panic!("buffer {id:?} is not a resolved buffer of this graph"),
        }
    }

    /// The logical device.
    pub fn device(&self) -> &ash::Device {
        &self.ctx.device
    }

    /// Pushes one descriptor per declared slot, in binding order, with the layouts the graph
    /// put each image in.
    pub(crate) fn push_descriptors(&self, pipe: &CachedPipeline, slots: &[Slot]) -> Result<()> {
        if slots.is_empty() {
            return Ok(());
        }
        let mut buffers = Vec::with_capacity(slots.len());
        let mut images = Vec::with_capacity(slots.len());
        let mut texels = Vec::new();
        for s in slots {
            match *s {
                Slot::TexelBuffer(b, format) => {
                    let info = vk::BufferViewCreateInfo::default()
                        .buffer(self.buffer(b).raw)
                        .format(format)
                        .offset(0)
                        .range(vk::WHOLE_SIZE);
                    // SAFETY: the buffer is this graph's, created with storage-texel usage.
                    let view = unsafe { self.ctx.device.create_buffer_view(&info, None) }
                        .map_err(|e| Error::Graph(format!("vkCreateBufferView: {e}")))?;
                    self.views.views.borrow_mut().push(view);
                    texels.push(view);
                }
                Slot::Uniform(b) | Slot::StorageBuffer(b) => buffers.push(vk::DescriptorBufferInfo {
                    buffer: self.buffer(b).raw,
                    offset: 0,
                    range: vk::WHOLE_SIZE,
                }),
                Slot::StorageImage(i) => images.push(vk::DescriptorImageInfo {
                    sampler: vk::Sampler::null(),
                    image_view: self.image(i).view,
                    image_layout: vk::ImageLayout::GENERAL,
                }),
                Slot::Sampled(i, sampling, layout) => images.push(vk::DescriptorImageInfo {
                    sampler: self.ctx.pipelines().sampler(self.ctx, sampling)?,
                    image_view: self.image(i).view,
                    image_layout: layout,
                }),
                Slot::Unused => {}
            }
        }
        let (mut bi, mut ii, mut ti) = (0, 0, 0);
        let writes: Vec<_> = slots
            .iter()
            .enumerate()
            .filter(|(_, s)| !matches!(s, Slot::Unused))
            .map(|(binding, s)| {
                let w =
                    vk::WriteDescriptorSet::default().dst_binding(binding as u32).descriptor_type(pipe.types[binding]);
                match s {
                    Slot::Uniform(_) | Slot::StorageBuffer(_) => {
                        bi += 1;
                        w.buffer_info(std::slice::from_ref(&buffers[bi - 1]))
                    }
                    Slot::TexelBuffer(..) => {
                        ti += 1;
                        w.texel_buffer_view(std::slice::from_ref(&texels[ti - 1]))
                    }
                    _ => {
                        ii += 1;
                        w.image_info(std::slice::from_ref(&images[ii - 1]))
                    }
                }
            })
            .collect();
        // SAFETY: cmd is recording; every handle belongs to this graph's resources or the cache.
        unsafe {
            self.ctx.push_descriptor.cmd_push_descriptor_set(
                self.cmd,
                vk::PipelineBindPoint::COMPUTE,
                pipe.layout,
                0,
                &writes,
            )
        };
        Ok(())
    }
}

/// Vulkan handles of imported (persistent) resources, keyed by the ids the builder returned,
/// and the state cells recording writes back to.
#[derive(Default)]
pub struct Imports {
    entries: Vec<(ResourceId, Resolved)>,
    states: Vec<(ResourceId, StateCell)>,
}

fn desc_of(info: &ImageInfo) -> ImageDesc {
    ImageDesc {
        format: info.format,
        extent: info.extent,
        kind: info.kind,
        mip_levels: info.mip_levels,
        extra_usage: info.usage,
    }
}

pub(crate) fn info_of(desc: &ImageDesc, usage: vk::ImageUsageFlags) -> ImageInfo {
    ImageInfo { format: desc.format, extent: desc.extent, kind: desc.kind, mip_levels: desc.mip_levels, usage }
}

impl Imports {
    /// Imports a persistent image whose last use left it in `state`.
    pub fn image(&mut self, g: &mut GraphBuilder<'_>, name: &str, image: &Image, state: ResourceState) -> ImageId {
        self.raw_image(g, name, GraphImage { raw: image.raw, view: image.view, info: image.info }, state)
    }

    /// Imports a persistent image that passes may only read (uploaded data, lookup tables).
    pub fn image_readonly(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        image: &Image,
        state: ResourceState,
    ) -> ImageId {
        let id = g.import_image_readonly(name, desc_of(&image.info), state);
        self.bind_image(id, image);
        id
    }

    /// Imports an image by raw handles (e.g. a swapchain image).
    pub fn raw_image(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        image: GraphImage,
        state: ResourceState,
    ) -> ImageId {
        let id = g.import_image(name, desc_of(&image.info), state);
        self.entries.push((ResourceId::Image(id), Resolved::Image(image)));
        id
    }

    /// Supplies the handles for an image already declared with `GraphBuilder::import_image`.
    pub fn bind_image(&mut self, id: ImageId, image: &Image) {
        let r = Resolved::Image(GraphImage { raw: image.raw, view: image.view, info: image.info });
        self.entries.push((ResourceId::Image(id), r));
    }

    /// Imports a persistent buffer that passes may only read (vertices, indices, tables).
    pub fn buffer_readonly(&mut self, g: &mut GraphBuilder<'_>, name: &str, buffer: &Buffer) -> BufferId {
        let id = g.import_buffer_readonly(name, super::BufferDesc::new(buffer.size), ResourceState::UNDEFINED);
        self.entries
            .push((ResourceId::Buffer(id), Resolved::Buffer(GraphBuffer { raw: buffer.raw, size: buffer.size })));
        id
    }

    /// Imports a persistent image that owns its state (see [`super::persistent`]).
    pub(crate) fn persistent_image(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        image: &Image,
        state: &StateCell,
    ) -> ImageId {
        let now = *state.lock().unwrap_or_else(|p| p.into_inner());
        let id = self.image(g, name, image, now);
        self.states.push((ResourceId::Image(id), state.clone()));
        id
    }

    /// Imports a persistent buffer that owns its state.
    pub(crate) fn persistent_buffer(
        &mut self,
        g: &mut GraphBuilder<'_>,
        name: &str,
        buffer: &Buffer,
        state: &StateCell,
    ) -> BufferId {
        let now = *state.lock().unwrap_or_else(|p| p.into_inner());
        let id = self.buffer(g, name, buffer, now);
        self.states.push((ResourceId::Buffer(id), state.clone()));
        id
    }

    /// Imports a persistent buffer whose last use left it in `state`.
    pub fn buffer(&mut self, g: &mut GraphBuilder<'_>, name: &str, buffer: &Buffer, state: ResourceState) -> BufferId {
        let id = g.import_buffer(name, super::BufferDesc::new(buffer.size), state);
        self.entries
            .push((ResourceId::Buffer(id), Resolved::Buffer(GraphBuffer { raw: buffer.raw, size: buffer.size })));
        id
    }
}

/// How the executor runs a graph.
#[derive(Clone, Copy, Debug)]
pub struct ExecuteOptions {
    /// Share memory between transients whose lifetimes do not overlap.
    pub alias: bool,
}

impl Default for ExecuteOptions {
    fn default() -> Self {
        Self { alias: true }
    }
}

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

/// A recorded graph: keep it alive until its submission completes, then read its timings.
pub struct RecordedGraph {
    _transients: Transients,
    _views: BufferViews,
    timestamps: TimestampPool,
    pass_names: Vec<String>,
    work: Vec<Work>,
    counts: Vec<Commands>,
    cpu_ns: Vec<u64>,
    /// Names of passes the compiler culled (never recorded).
    pub culled: Vec<String>,
    /// Transient memory use.
    pub memory: MemoryReport,
    /// CPU time of the whole recording (transient setup, barriers, every pass's closure).
    pub record_ns: u64,
}

impl RecordedGraph {
    /// Per-pass GPU and CPU times; call after the submission completed.
    pub fn timings(&self) -> Result<Vec<PassTiming>> {
        let t = self.timestamps.read_ns(self.pass_names.len() as u32 + 1)?;
        Ok(self
            .pass_names
            .iter()
            .enumerate()
            .map(|(i, name)| PassTiming {
                name: name.clone(),
                gpu_begin_ns: t[i] - t[0],
                gpu_end_ns: t[i + 1].max(t[i]) - t[0],
                cpu_ns: self.cpu_ns[i],
                work: self.work[i],
                commands: self.counts[i],
            })
            .collect())
    }

    /// Names of the passes that were recorded, in order.
    pub fn pass_names(&self) -> &[String] {
        &self.pass_names
    }
}

fn load_op(op: LoadOp) -> vk::AttachmentLoadOp {
    match op {
        LoadOp::Load => vk::AttachmentLoadOp::LOAD,
        LoadOp::Clear => vk::AttachmentLoadOp::CLEAR,
        LoadOp::DontCare => vk::AttachmentLoadOp::DONT_CARE,
    }
}

/// Records a compiled graph into `cmd`. Keep the result alive until the submission completes.
pub fn record_graph(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    mut graph: CompiledGraph<'_>,
    imports: &Imports,
    options: ExecuteOptions,
) -> Result<RecordedGraph> {
    let record_start = Instant::now();
    let mut resolved: Vec<Option<Resolved>> = vec![None; graph.resources().len()];
    for (id, r) in &imports.entries {
        if let Some(slot) = resolved.get_mut(id.index()) {
            *slot = Some(*r);
        }
    }
    for info in graph.resources() {
        if info.imported && resolved[info.id.index()].is_none() {
            let used = graph.passes().iter().any(|p| p.uses.iter().any(|u| u.resource == info.id));
            if used {
                return Err(Error::Input(format!(
                    "frame graph: imported resource `{}` has no handle in Imports",
                    info.name
                )));
            }
        }
    }
    // llvmpipe silently stops every loop of a SIMD row past its limit: refuse, naming the pass.
    if ctx.info.name.contains("llvmpipe") {
        let limit = super::work::LLVMPIPE_LOOP_LIMIT;
        if let Some(p) = graph.passes().iter().find(|p| p.work.loop_iterations > limit) {
            return Err(Error::Input(format!(
                "pass `{}`: a SIMD row could run {} loop iterations per dispatch, over llvmpipe's {limit} (it would stop them silently and the image would be wrong); change the setting that sizes this pass (a longer step, fewer samples)",
                p.name, p.work.loop_iterations
            )));
        }
    }
    let (transients, memory) = allocate_transients(ctx, &mut graph, options.alias, &mut resolved)?;
    // Where each persistent import ends; written back once the recording succeeded.
    let ends: Vec<_> = imports.states.iter().map(|(id, cell)| (graph.final_state(*id), cell)).collect();
    let pass_count = graph.passes().len() as u32;
    let timestamps = TimestampPool::new(ctx, pass_count + 1)?;
    timestamps.reset(cmd, pass_count + 1);
    timestamps.write(cmd, vk::PipelineStageFlags2::NONE, 0);
    let mut pass_names = Vec::with_capacity(pass_count as usize);
    let mut work = Vec::with_capacity(pass_count as usize);
    let mut counts = Vec::with_capacity(pass_count as usize);
    let resources = graph.resources().to_vec();
    let mut cpu_ns = Vec::with_capacity(pass_count as usize);
    let culled = graph.culled_passes().iter().map(|p| p.name.clone()).collect();
    let views = BufferViews { ctx: ctx.clone(), views: Default::default() };
    for (i, pass) in graph.passes_mut().iter_mut().enumerate() {
        let start = Instant::now();
        let label = CString::new(pass.name.replace('\0', " ")).unwrap_or_default();
        if let Some(du) = &ctx.debug_utils {
            // SAFETY: cmd is recording; the label string lives for the call.
            unsafe { du.cmd_begin_debug_utils_label(cmd, &vk::DebugUtilsLabelEXT::default().label_name(&label)) };
        }
        let mut commands = Commands {
            barriers: record_barriers(ctx, cmd, &pass.barriers, &resolved),
            transfer_bytes: super::commands::transfer_bytes(pass, &resources),
            ..Default::default()
        };
        let mut extent = vk::Extent2D::default();
        let raster = pass.kind == PassKind::Raster;
        if raster {
            extent = begin_rendering(ctx, cmd, pass, &resolved)?;
        }
        if let Some(f) = pass.take_record() {
            let mut pc =
                PassContext { ctx, cmd, extent, resources: &resolved, views: &views, dispatches: Cell::new(0) };
            f(&mut pc).map_err(|e| Error::Graph(format!("pass `{}`: {e}", pass.name)))?;
            commands.dispatches = pc.dispatches.get();
        }
        if raster {
            // SAFETY: matches begin_rendering above.
            unsafe { ctx.device.cmd_end_rendering(cmd) };
        }
        timestamps.write(cmd, vk::PipelineStageFlags2::ALL_COMMANDS, i as u32 + 1);
        if let Some(du) = &ctx.debug_utils {
            // SAFETY: closes the label opened above.
            unsafe { du.cmd_end_debug_utils_label(cmd) };
        }
        pass_names.push(pass.name.clone());
        work.push(pass.work);
        counts.push(commands);
        cpu_ns.push(start.elapsed().as_nanos() as u64);
    }
    let last_batch = record_barriers(ctx, cmd, graph.final_barriers(), &resolved);
    if let Some(last) = counts.last_mut() {
        last.barriers += last_batch;
    }
    if let Some(last) = pass_names.last() {
        // A wait that times out on this command buffer names the pass it stopped behind.
        ctx.note_pass(last);
    }
    for (end, cell) in ends {
        if let Some(state) = end {
            *cell.lock().unwrap_or_else(|p| p.into_inner()) = state;
        }
    }
    let record_ns = record_start.elapsed().as_nanos() as u64;
    Ok(RecordedGraph {
        _transients: transients,
        _views: views,
        timestamps,
        pass_names,
        work,
        counts,
        cpu_ns,
        culled,
        memory,
        record_ns,
    })
}

fn begin_rendering(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    pass: &super::CompiledPass<'_>,
    resolved: &[Option<Resolved>],
) -> Result<vk::Extent2D> {
    let img = |id: ImageId| match resolved.get(ResourceId::Image(id).index()) {
        Some(Some(Resolved::Image(i))) => Ok(*i),
        _ => Err(Error::Input(format!("frame graph: pass `{}` attachment is not an image", pass.name))),
    };
    let mut colors = Vec::new();
    let mut extent = None;
    // Layered rendering (gl_Layer) covers the layers every attachment has.
    let mut layers = u32::MAX;
    for a in &pass.color_attachments {
        let i = img(a.image)?;
        layers = layers.min(i.info.layers());
        extent.get_or_insert(vk::Extent2D { width: i.info.extent[0], height: i.info.extent[1] });
        colors.push(
            vk::RenderingAttachmentInfo::default()
                .image_view(i.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(load_op(a.load_op))
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: a.clear } }),
        );
    }
    let depth = match &pass.depth_attachment {
        Some(d) => {
            let i = img(d.image)?;
            layers = layers.min(i.info.layers());
            extent.get_or_insert(vk::Extent2D { width: i.info.extent[0], height: i.info.extent[1] });
            let layout = if d.write {
                vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL
            } else {
                vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL
            };
            Some(
                vk::RenderingAttachmentInfo::default()
                    .image_view(i.view)
                    .image_layout(layout)
                    .load_op(load_op(d.load_op))
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue {
                        depth_stencil: vk::ClearDepthStencilValue { depth: d.clear_depth, stencil: 0 },
                    }),
            )
        }
        None => None,
    };
    let extent =
        extent.ok_or_else(|| Error::Input(format!("frame graph: raster pass `{}` has no attachments", pass.name)))?;
    let area = vk::Rect2D { offset: vk::Offset2D::default(), extent };
    let mut info = vk::RenderingInfo::default().render_area(area).layer_count(layers.max(1)).color_attachments(&colors);
    if let Some(d) = depth.as_ref() {
        info = info.depth_attachment(d);
    }
    let viewport = vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: extent.width as f32,
        height: extent.height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    };
    // SAFETY: cmd is recording; attachments are in the layouts the pass's barriers established.
    unsafe {
        ctx.device.cmd_begin_rendering(cmd, &info);
        ctx.device.cmd_set_viewport(cmd, 0, &[viewport]);
        ctx.device.cmd_set_scissor(cmd, 0, &[area]);
    }
    Ok(extent)
}

/// What one synchronous graph run produced.
pub struct GraphRun {
    /// Per-pass timings.
    pub timings: Vec<PassTiming>,
    /// Culled pass names.
    pub culled: Vec<String>,
    /// Transient memory use.
    pub memory: MemoryReport,
    /// CPU time of recording the graph.
    pub record_ns: u64,
}

impl GraphRun {
    /// GPU milliseconds of all passes together (gaps between passes not counted).
    pub fn gpu_ms(&self) -> f64 {
        self.timings.iter().map(PassTiming::gpu_ms).sum()
    }
}

/// Records, submits and waits for a compiled graph (headless rendering, tests, benchmarks).
pub fn run_graph(
    ctx: &Context,
    graph: CompiledGraph<'_>,
    imports: &Imports,
    options: ExecuteOptions,
) -> Result<GraphRun> {
    let recorded = ctx.one_shot(|cmd| record_graph(ctx, cmd, graph, imports, options))?;
    let timings = recorded.timings()?;
    Ok(GraphRun { timings, culled: recorded.culled.clone(), memory: recorded.memory, record_ns: recorded.record_ns })
}
