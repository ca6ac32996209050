//! Measured device limits: micro-benchmarks that each run as one or a few frame-graph passes,
//! timed by the graph's GPU timestamps (one sample per timed pass) and repeated until stable.
//!
//! Every benchmark is a [`Bench`]: it lists its [`Case`]s (one report row each) and declares a
//! case's timed passes into a [`BenchGraph`]; [`run_case`] compiles and runs that graph and
//! [`measure_bench`] repeats it under a [`StopRule`] into [`LimitRow`]s. [`run_all`] is the
//! suite `device_limits` runs, one constructor per benchmark in [`suite`].
//!
//! A measurement runs batches (one graph execution with a few timed passes each), discards the
//! first batch as a warm-up (pipeline first use, first touch of memory), and stops when the
//! relative spread `(p90 − p10) / median` of the most recent `window` samples falls under
//! `tolerance`, or at `max_samples`, or after `max_seconds`.
//!
//! Benchmarks keep their inputs and outputs in `PersistentBuffer`s and `PersistentImage`s that
//! each graph run imports, carrying their state from run to run, so tests can run a benchmark once at
//! a tiny size and check the work itself ([`benches`] has the readbacks, [`cpu`] the CPU mirrors
//! of the kernels in `shaders_glsl/profile/`).

pub mod benches;
pub mod cpu;
mod stats;

pub use stats::{measure, relative_spread, LimitRow, Measured, StopReason, StopRule, Summary};

use vkengine::graph::execute::{run_graph, ExecuteOptions, Imports};
use vkengine::graph::{BufferId, GraphBuilder, ImageId, PersistentBuffer, PersistentImage, ResourceId};
use vkengine::vk::Context;
use vkengine::{Error, Result};

/// How one sample's GPU milliseconds become the row's unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rate {
    /// Work per second, divided by `scale` (1e9 for GB/s, Gfetch/s, Gatomic/s).
    PerSecond(f64),
    /// Microseconds per unit of work (per dispatch, per draw).
    MicrosEach,
    /// The pass's milliseconds as they are.
    Millis,
}

impl Rate {
    fn convert(self, work: f64, ms: f64) -> f64 {
        match self {
            Rate::PerSecond(scale) => work / (ms * 1e-3) / scale,
            Rate::MicrosEach => ms * 1e3 / work,
            Rate::Millis => ms,
        }
    }
}

/// One measured row of a benchmark.
#[derive(Clone, Debug)]
pub struct Case {
    /// Row name, also the prefix of its timed passes' names (`NAME #i`).
    pub name: String,
    /// What runs, with sizes.
    pub detail: String,
    /// Unit of the row's values.
    pub unit: &'static str,
    /// Work one timed pass does, in `work_unit`.
    pub work: f64,
    /// bytes, fetches, atomics, dispatches, draws, cells.
    pub work_unit: &'static str,
    /// How a sample's ms become `unit`.
    pub rate: Rate,
    /// Why the device cannot run this case, if it cannot.
    pub skipped: Option<String>,
}

/// A micro-benchmark: named cases, each a graph of timed passes over the benchmark's own
/// persistent resources.
pub trait Bench {
    /// The cases, in report order.
    fn cases(&self) -> Vec<Case>;

    /// Declares `reps` timed passes of case `case` (index into [`Bench::cases`]) into `g`: each
    /// named [`BenchGraph::timed`] and marked side-effect (a later pass may overwrite what an
    /// earlier one wrote, which would otherwise let the graph cull it).
    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, case: usize, reps: u32) -> Result<()>;
}

/// The graph a [`Bench`] declares one run of a case into.
pub struct BenchGraph<'a> {
    /// The frame graph.
    pub g: GraphBuilder<'a>,
    imports: Imports,
    exported: Vec<ResourceId>,
    label: String,
    timed: Vec<String>,
}

impl<'a> BenchGraph<'a> {
    fn new(label: String) -> Self {
        Self { g: GraphBuilder::new(), imports: Imports::default(), exported: Vec::new(), label, timed: Vec::new() }
    }

    /// The name of timed pass `i` of this case (its time is one sample).
    pub fn timed(&mut self, i: u32) -> String {
        let name = format!("{} #{i}", self.label);
        self.timed.push(name.clone());
        name
    }

    /// Imports a buffer the passes only read; its state carries over to the next run.
    pub fn input_buffer(&mut self, name: &str, t: &'a PersistentBuffer) -> BufferId {
        t.import(&mut self.g, &mut self.imports, name)
    }

    /// Imports a buffer the passes write (kept alive by an export); its state carries over.
    pub fn output_buffer(&mut self, name: &str, t: &'a PersistentBuffer) -> BufferId {
        let id = self.input_buffer(name, t);
        self.exported.push(id.into());
        id
    }

    /// Imports a storage image the passes only read; its state carries over.
    pub fn input_image(&mut self, name: &str, t: &'a PersistentImage) -> ImageId {
        t.import(&mut self.g, &mut self.imports, name)
    }

    /// Imports a sampled, read-only image; its state is left as it is.
    pub fn texture(&mut self, name: &str, t: &'a PersistentImage) -> ImageId {
        self.imports.image_readonly(&mut self.g, name, t.image(), t.state())
    }

    /// Imports an image the passes write (kept alive by an export); its state carries over.
    pub fn output_image(&mut self, name: &str, t: &'a PersistentImage) -> ImageId {
        let id = self.input_image(name, t);
        self.exported.push(id.into());
        id
    }

    /// Compiles and runs the graph (recording it carries the final states into the benchmark's
    /// resources) and returns the GPU ms of the timed passes in declaration order.
    fn execute(mut self, ctx: &Context) -> Result<Vec<f64>> {
        for id in &self.exported {
            match *id {
                ResourceId::Buffer(b) => self.g.export_buffer(b, None)?,
                ResourceId::Image(i) => self.g.export_image(i, None)?,
            }
        }
        let compiled = self.g.compile()?;
        let run = run_graph(ctx, compiled, &self.imports, ExecuteOptions::default())?;
        let ms: Vec<f64> = self
            .timed
            .iter()
            .filter_map(|name| run.timings.iter().find(|t| &t.name == name))
            .map(|t| t.gpu_end_ns.saturating_sub(t.gpu_begin_ns) as f64 * 1e-6)
            .collect();
        if ms.len() != self.timed.len() {
            return Err(Error::Graph(format!("profile: a timed pass did not run (culled: {:?})", run.culled)));
        }
        Ok(ms)
    }
}

/// One graph with `reps` timed passes of case `case`; the GPU ms of each.
pub fn run_case(ctx: &Context, bench: &dyn Bench, case: usize, reps: u32) -> Result<Vec<f64>> {
    let name = bench
        .cases()
        .into_iter()
        .nth(case)
        .map(|c| c.name)
        .ok_or_else(|| Error::Graph(format!("profile: no benchmark case {case}")))?;
    let mut g = BenchGraph::new(name);
    bench.declare(&mut g, case, reps)?;
    g.execute(ctx)
}

/// Measures every case of `bench` under `rule` (`reps` timed passes per batch), one row each.
pub fn measure_bench(
    ctx: &Context,
    bench: &dyn Bench,
    rule: &StopRule,
    reps: u32,
    mut emit: impl FnMut(LimitRow),
) -> Result<()> {
    for (i, case) in bench.cases().into_iter().enumerate() {
        if let Some(reason) = case.skipped {
            emit(LimitRow::skipped(&case.name, case.detail, case.unit, reason));
            continue;
        }
        let m = measure(rule, || run_case(ctx, bench, i, reps))?;
        let (work, rate) = (case.work, case.rate);
        let row = LimitRow::from_ms(&case.name, case.detail, case.unit, (work, case.work_unit), &m, |ms| {
            rate.convert(work, ms)
        });
        emit(row);
    }
    Ok(())
}

/// Sizes, repetitions and the stop rule of a suite run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LimitsConfig {
    /// Bytes the copy benchmark copies.
    pub copy_bytes: u64,
    /// Bytes the storage-buffer kernels read or write (rounded up to whole workgroup blocks).
    pub buffer_bytes: u64,
    /// Edge of the RGBA32F 3D storage image (rounded up to a multiple of 16).
    pub image_edge: u32,
    /// Edge of the sampled RGBA32F 3D texture.
    pub texture_edge: u32,
    /// Edge of the fetch kernel's invocation lattice (edge³ invocations, multiple of 4).
    pub fetch_grid: u32,
    /// Invocations of the atomic kernels (multiple of 64).
    pub atomic_invocations: u32,
    /// atomicAdds per invocation.
    pub atomics_per_invocation: u32,
    /// Dispatches in the dispatch-overhead pass.
    pub dispatches: u32,
    /// Draws in the draw-overhead pass.
    pub draws: u32,
    /// Grid edges of the LPV layout comparison.
    pub lpv_sizes: Vec<u32>,
    /// Timed passes per graph run.
    pub reps: u32,
    /// When to stop repeating.
    pub rule: StopRule,
}

impl LimitsConfig {
    /// Default sizes: buffers and images larger than a 32 MiB last-level cache; under a minute
    /// on lavapipe with 2 cores (noisy benchmarks run to the 5 s limit).
    pub fn full() -> Self {
        Self {
            copy_bytes: 64 << 20,
            buffer_bytes: 64 << 20,
            image_edge: 160,
            texture_edge: 128,
            fetch_grid: 64,
            atomic_invocations: 1 << 18,
            atomics_per_invocation: 16,
            dispatches: 1000,
            draws: 4096,
            lpv_sizes: vec![32, 64],
            reps: 4,
            rule: StopRule { window: 8, tolerance: 0.05, max_samples: 200, max_seconds: 5.0 },
        }
    }

    /// Smaller sizes and a shorter time limit (cache effects show at these sizes).
    pub fn quick() -> Self {
        Self {
            copy_bytes: 16 << 20,
            buffer_bytes: 16 << 20,
            image_edge: 96,
            texture_edge: 64,
            fetch_grid: 32,
            atomic_invocations: 1 << 16,
            atomics_per_invocation: 16,
            dispatches: 256,
            draws: 1024,
            lpv_sizes: vec![32, 64],
            reps: 3,
            rule: StopRule { window: 6, tolerance: 0.05, max_samples: 24, max_seconds: 1.0 },
        }
    }

    /// Tiny sizes, one sample each: for tests under validation.
    pub fn tiny() -> Self {
        Self {
            copy_bytes: 256 << 10,
            buffer_bytes: 64 << 10,
            image_edge: 16,
            texture_edge: 16,
            fetch_grid: 8,
            atomic_invocations: 4096,
            atomics_per_invocation: 4,
            dispatches: 16,
            draws: 64,
            lpv_sizes: vec![6, 8],
            reps: 1,
            rule: StopRule { window: 1, tolerance: f64::INFINITY, max_samples: 1, max_seconds: 0.0 },
        }
    }
}

/// Builds one benchmark of the suite (they are built one at a time, so only one holds memory).
pub type MakeBench = Box<dyn Fn(&Context) -> Result<Box<dyn Bench>>>;

/// The suite at `cfg`'s sizes, in report order.
pub fn suite(cfg: &LimitsConfig) -> Vec<MakeBench> {
    use benches::*;
    let c = cfg.clone();
    let mut all: Vec<MakeBench> = vec![
        Box::new(move |ctx| Ok(Box::new(CopyBench::new(ctx, c.copy_bytes)?))),
        Box::new(move |ctx| Ok(Box::new(BufferReadBench::new(ctx, c.buffer_bytes)?))),
        Box::new(move |ctx| Ok(Box::new(BufferWriteBench::new(ctx, c.buffer_bytes)?))),
        Box::new(move |ctx| Ok(Box::new(ImageReadBench::new(ctx, c.image_edge)?))),
        Box::new(move |ctx| Ok(Box::new(ImageWriteBench::new(ctx, c.image_edge)?))),
        Box::new(move |ctx| match linear_rgba32f_unsupported(ctx) {
            Some(reason) => Ok(Box::new(TextureBench::unsupported(reason))),
            None => Ok(Box::new(TextureBench::new(ctx, c.texture_edge, c.fetch_grid)?)),
        }),
        Box::new(move |ctx| Ok(Box::new(AtomicBench::new(ctx, c.atomic_invocations, c.atomics_per_invocation)?))),
        Box::new(move |ctx| Ok(Box::new(DispatchBench::new(ctx, c.dispatches)?))),
        Box::new(move |ctx| Ok(Box::new(DrawBench::new(ctx, c.draws)?))),
    ];
    for &n in &cfg.lpv_sizes {
        all.push(Box::new(move |ctx| Ok(Box::new(LpvLayoutBench::new(ctx, n)?))));
    }
    all
}

/// Runs every benchmark of the suite at `cfg`'s sizes, calling `progress` after each row.
pub fn run_all(ctx: &Context, cfg: &LimitsConfig, mut progress: impl FnMut(&LimitRow)) -> Result<Vec<LimitRow>> {
    let mut rows = Vec::new();
    let (rule, reps) = (&cfg.rule, cfg.reps.max(1));
    for make in suite(cfg) {
        let bench = make(ctx)?;
        measure_bench(ctx, bench.as_ref(), rule, reps, |row| {
            progress(&row);
            rows.push(row);
        })?;
    }
    Ok(rows)
}
