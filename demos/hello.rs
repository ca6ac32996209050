//! Default demo until the renderers land: an analytic placeholder scene rendered by compute and
//! tone-mapped, as two frame-graph passes. Headless: PNG + JSON report (+ a profile folder with the
//! graph's DOT with `--profile DIR`); with a display: a window.

use clap::Parser;
use std::time::Instant;
use vkengine::graph::execute::{record_graph, ExecuteOptions, Imports, MemoryReport, RecordedGraph};
use vkengine::graph::{dot, trace, Access, CompiledGraph, GraphBuilder, ImageDesc, PersistentImage, PresentTarget};
use vkengine::shaders;
use vkengine::vk::{vk, Context, Image, ImageInfo};
use vkengine::window::{run_windowed, WindowApp, WindowConfig};
use vkengine::{Error, Result};
use vkengine_demos::{output, stats::PassStats, DemoArgs};

struct Hello {
    /// Persistent output (imported into each frame's graph; it owns its state).
    ldr: Option<PersistentImage>,
    /// The previous frame's recording: kept until its submission has been made.
    in_flight: Option<RecordedGraph>,
}

const HDR: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

impl Hello {
    fn new() -> Result<Self> {
        Ok(Self { ldr: None, in_flight: None })
    }

    fn output(&mut self, ctx: &Context, [w, h]: [u32; 2]) -> Result<()> {
        if self.ldr.as_ref().is_some_and(|i| i.info.extent[..2] == [w, h]) {
            return Ok(());
        }
        let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
        let img = Image::new(ctx, "ldr", ImageInfo::d2(vk::Format::R8G8B8A8_UNORM, w, h, usage))?;
        self.ldr = Some(PersistentImage::new(img));
        Ok(())
    }

    /// Declares the frame: scene → hdr (transient) → tone map → ldr (persistent, kept for
    /// readback) → with a window, the present pass.
    fn graph<'a>(
        &'a self,
        frame: u64,
        imports: &mut Imports,
        present: Option<PresentTarget>,
    ) -> Result<CompiledGraph<'a>> {
        let ldr = self.ldr.as_ref().ok_or_else(|| Error::Input("output not created".into()))?;
        let [w, h] = [ldr.info.extent[0], ldr.info.extent[1]];
        let groups = [w.div_ceil(8), h.div_ceil(8), 1];
        let mut g = GraphBuilder::new();
        let out = ldr.import(&mut g, imports, "ldr");
        let hdr = g.create_image("hdr", ImageDesc::d2(HDR, w, h));
        let t = frame as f32 * 0.05;
        let light = [t.cos() * 0.6, 0.7, t.sin() * 0.6 + 0.6, 0.0, t];
        g.compute("scene", &shaders::DEMO_HELLO_COMP).write(hdr).constants(&light).dispatch(groups)?;
        let params = [0, 1.0f32.to_bits(), 0, 1.0f32.to_bits()];
        vkengine::post::add_tonemap_pass(&mut g, hdr, out, params, groups)?;
        if let Some(target) = present {
            vkengine::graph::add_present_pass(&mut g, imports, out, target)?;
        }
        g.export_image(out, Some(Access::TransferSrc))?;
        Ok(g.compile()?)
    }

    /// Records one frame; returns the recording (keep until submitted) and the output's new state.
    fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: u64,
        present: Option<PresentTarget>,
    ) -> Result<RecordedGraph> {
        let mut imports = Imports::default();
        let compiled = self.graph(frame, &mut imports, present)?;
        record_graph(ctx, cmd, compiled, &imports, ExecuteOptions::default())
    }
}

impl WindowApp for Hello {
    fn render(
        &mut self,
        ctx: &Context,
        _window: &winit::window::Window,
        cmd: vk::CommandBuffer,
        frame: u64,
        target: PresentTarget,
    ) -> Result<()> {
        self.output(ctx, target.extent)?;
        // The previous frame was submitted before this call: its transients retire to the
        // context, which hands them out again only once that submission completed.
        self.in_flight = None;
        self.in_flight = Some(self.record(ctx, cmd, frame, Some(target))?);
        Ok(())
    }
}

#[derive(serde::Serialize)]
struct Report {
    demo: &'static str,
    device: output::DeviceReport,
    size: [u32; 2],
    frames: u64,
    passes: Vec<PassReport>,
    culled: Vec<String>,
    transient_memory: MemoryReport,
    wall_ms: f64,
}

#[derive(serde::Serialize)]
struct PassReport {
    name: String,
    gpu_ms: f64,
    cpu_ms: f64,
}

fn headless(args: &DemoArgs) -> Result<()> {
    let ctx = Context::new(&args.context_options())?;
    eprintln!("device: {} ({})", ctx.info.name, ctx.info.driver);
    let mut app = Hello::new()?;
    app.output(&ctx, args.size)?;
    if let Some(profile) = &args.profile {
        let mut imports = Imports::default();
        let compiled = app.graph(0, &mut imports, None)?;
        std::fs::create_dir_all(profile).map_err(|source| Error::Io { path: profile.display().to_string(), source })?;
        let path = profile.join("graph.dot");
        std::fs::write(&path, dot::to_dot(&compiled))
            .map_err(|source| Error::Io { path: path.display().to_string(), source })?;
    }
    let start = Instant::now();
    let mut stats = PassStats::default();
    let (mut culled, mut memory) = (Vec::new(), MemoryReport::default());
    for frame in 0..args.warmup + args.frames().max(1) {
        let recorded = ctx.one_shot(|cmd| app.record(&ctx, cmd, frame, None))?;
        if frame >= args.warmup {
            stats.add(&recorded.timings()?);
        }
        (culled, memory) = (recorded.culled.clone(), recorded.memory);
    }
    let frames = &stats.timings;
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let ldr = app.ldr.as_ref().ok_or_else(|| Error::Input("output not created".into()))?;
    let pixels = ldr.read(&ctx)?;
    let out = args.out.clone().unwrap_or_else(|| "out/hello.png".into());
    output::write_png(&out, args.size[0], args.size[1], &pixels)?;
    let last = frames.last().cloned().unwrap_or_default();
    eprint!("{}", trace::format_table(&last));
    eprintln!("wrote {} ({} frames, {:.1} ms)", out.display(), args.frames(), wall_ms);
    stats.write_profile(args, "hello", &ctx)?;
    if let Some(path) = &args.report {
        let passes = last
            .iter()
            .map(|t| PassReport { name: t.name.clone(), gpu_ms: t.gpu_ms(), cpu_ms: t.cpu_ns as f64 * 1e-6 })
            .collect();
        let report = Report {
            demo: "hello",
            device: (&ctx.info).into(),
            size: args.size,
            frames: args.frames(),
            passes,
            culled,
            transient_memory: memory,
            wall_ms,
        };
        output::write_json(path, &report)?;
    }
    vkengine_demos::check_validation(&ctx)
}

fn main() {
    let args = DemoArgs::parse();
    let result = if args.windowed() {
        let config = WindowConfig {
            title: "vkengine hello".into(),
            size: args.size,
            max_frames: None,
            resize_script: vec![],
            any_thread: false,
        };
        run_windowed(config, &args.context_options(), |_| Hello::new()).map(|_| ())
    } else {
        headless(&args)
    };
    vkengine_demos::runner::exit_on_error(result);
}
