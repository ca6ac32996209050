//! Executor: turns a compiled graph into commands — allocates (and aliases) transient memory,
//! records each pass's barrier batch, debug label, dynamic-rendering scope and closure, and
//! brackets passes with GPU timestamps. The top of the graph module: transient memory is in
//! `transients`, imported handles in `imports`, what a pass sees in `pass_context`; what stays
//! here is the recording loop and running a graph.

use super::barriers::record_barriers;
use super::commands::Commands;
use super::pass_context::{BufferViews, Resolved};
use super::resource::ImageId;
use super::transients::{allocate_transients, Transients};
use super::{CompiledGraph, LoadOp, PassKind, ResourceId, Work};

pub use super::imports::Imports;
pub use super::pass_context::{GraphBuffer, GraphImage, PassContext};
pub use super::transients::MemoryReport;
use crate::error::{Error, Result};
use crate::graph::trace::PassTiming;
use crate::vk::{Context, TimestampPool};
use ash::vk;
use std::cell::Cell;
use std::ffi::CString;
use std::time::Instant;

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
    if ctx.info.llvmpipe() {
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
    let views = BufferViews::new(ctx);
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
