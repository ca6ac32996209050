//! Default demo until the renderers land: an analytic placeholder scene rendered by compute,
//! tone-mapped, and written as a PNG (headless) or shown in a window.

use clap::Parser;
use std::time::Instant;
use vkengine::demo::{output, DemoArgs};
use vkengine::shaders;
use vkengine::vk::{pipeline::push_words, vk, Binding, Context, Descriptor, Image, ImageInfo, Pipeline, TimestampPool};
use vkengine::window::{run_windowed, FrameOutput, WindowApp, WindowConfig};
use vkengine::Result;

struct Hello {
    scene: Pipeline,
    tonemap: Pipeline,
    hdr: Option<Image>,
    ldr: Option<Image>,
    timestamps: TimestampPool,
    fresh: bool,
}

const STORAGE: vk::DescriptorType = vk::DescriptorType::STORAGE_IMAGE;

impl Hello {
    fn new(ctx: &Context) -> Result<Self> {
        let c = vk::ShaderStageFlags::COMPUTE;
        Ok(Self {
            scene: Pipeline::compute(ctx, &shaders::DEMO_HELLO_COMP, &[Binding::new(0, STORAGE, c)], 20)?,
            tonemap: Pipeline::compute(
                ctx,
                &shaders::POST_TONEMAP_COMP,
                &[Binding::new(0, STORAGE, c), Binding::new(1, STORAGE, c)],
                16,
            )?,
            hdr: None,
            ldr: None,
            timestamps: TimestampPool::new(ctx, 3)?,
            fresh: true,
        })
    }

    fn ensure_size(&mut self, ctx: &Context, [w, h]: [u32; 2]) -> Result<()> {
        if self.ldr.as_ref().is_some_and(|i| i.info.extent[..2] == [w, h]) {
            return Ok(());
        }
        let s = vk::ImageUsageFlags::STORAGE;
        self.hdr = Some(Image::new(ctx, "hdr", ImageInfo::d2(vk::Format::R32G32B32A32_SFLOAT, w, h, s))?);
        self.ldr = Some(Image::new(
            ctx,
            "ldr",
            ImageInfo::d2(vk::Format::R8G8B8A8_UNORM, w, h, s | vk::ImageUsageFlags::TRANSFER_SRC),
        )?);
        self.fresh = true;
        Ok(())
    }

    /// Records scene + tone map; `ldr_layout` is where the previous frame left the output.
    fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        frame: u64,
        size: [u32; 2],
        ldr_layout: vk::ImageLayout,
    ) -> Result<FrameOutput> {
        self.ensure_size(ctx, size)?;
        let (hdr, ldr) = (self.hdr.as_ref().expect("sized"), self.ldr.as_ref().expect("sized"));
        let cs = vk::PipelineStageFlags2::COMPUTE_SHADER;
        let old_ldr = if self.fresh { vk::ImageLayout::UNDEFINED } else { ldr_layout };
        let old_hdr = if self.fresh { vk::ImageLayout::UNDEFINED } else { vk::ImageLayout::GENERAL };
        self.fresh = false;
        let barrier = |img: &Image, old, src: vk::PipelineStageFlags2, src_a, dst_a| {
            vk::ImageMemoryBarrier2::default()
                .image(img.raw)
                .subresource_range(img.info.full_range())
                .old_layout(old)
                .new_layout(vk::ImageLayout::GENERAL)
                .src_stage_mask(src)
                .src_access_mask(src_a)
                .dst_stage_mask(cs)
                .dst_access_mask(dst_a)
        };
        let w = vk::AccessFlags2::SHADER_STORAGE_WRITE;
        let r = vk::AccessFlags2::SHADER_STORAGE_READ;
        let t = vk::PipelineStageFlags2::TRANSFER | cs;
        let groups = [size[0].div_ceil(8), size[1].div_ceil(8)];
        let d = &ctx.device;
        self.timestamps.reset(cmd, 3);
        self.timestamps.write(cmd, vk::PipelineStageFlags2::TOP_OF_PIPE, 0);
        let pre = [barrier(hdr, old_hdr, cs, vk::AccessFlags2::NONE, w)];
        // SAFETY: recording; images transitioned by the barriers before use.
        unsafe { d.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&pre)) };
        let t_sec = frame as f32 * 0.05;
        let light = [t_sec.cos() * 0.6, 0.7, t_sec.sin() * 0.6 + 0.6, 0.0f32];
        let mut push: Vec<u32> = light.iter().map(|f| f.to_bits()).collect();
        push.push(t_sec.to_bits());
        self.scene.bind(cmd, &[Descriptor::StorageImage(hdr.view)], &push_words(&push))?;
        // SAFETY: pipeline and descriptors bound.
        unsafe { d.cmd_dispatch(cmd, groups[0], groups[1], 1) };
        self.timestamps.write(cmd, cs, 1);
        let mid =
            [barrier(hdr, vk::ImageLayout::GENERAL, cs, w, r), barrier(ldr, old_ldr, t, vk::AccessFlags2::NONE, w)];
        // SAFETY: recording.
        unsafe { d.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&mid)) };
        self.tonemap.bind(
            cmd,
            &[Descriptor::StorageImage(hdr.view), Descriptor::StorageImage(ldr.view)],
            &push_words(&[0, 1.0f32.to_bits(), 0, 1.0f32.to_bits()]),
        )?;
        // SAFETY: pipeline and descriptors bound.
        unsafe { d.cmd_dispatch(cmd, groups[0], groups[1], 1) };
        self.timestamps.write(cmd, cs, 2);
        Ok(FrameOutput { image: ldr.raw, extent: size, layout: vk::ImageLayout::GENERAL, stage: cs, access: w })
    }
}

impl WindowApp for Hello {
    fn render(&mut self, ctx: &Context, cmd: vk::CommandBuffer, frame: u64, extent: [u32; 2]) -> Result<FrameOutput> {
        self.record(ctx, cmd, frame, extent, FrameOutput::AFTER_BLIT_LAYOUT)
    }
}

#[derive(serde::Serialize)]
struct Report {
    demo: &'static str,
    device: output::DeviceReport,
    size: [u32; 2],
    frames: u64,
    passes: Vec<PassTime>,
    wall_ms: f64,
}

#[derive(serde::Serialize)]
struct PassTime {
    name: &'static str,
    gpu_ms: f64,
}

fn headless(args: &DemoArgs) -> Result<()> {
    let ctx = Context::new(&args.context_options())?;
    eprintln!("device: {} ({})", ctx.info.name, ctx.info.driver);
    let mut app = Hello::new(&ctx)?;
    let start = Instant::now();
    let mut last = FrameOutput {
        image: vk::Image::null(),
        extent: args.size,
        layout: vk::ImageLayout::GENERAL,
        stage: vk::PipelineStageFlags2::NONE,
        access: vk::AccessFlags2::NONE,
    };
    let mut passes = Vec::new();
    for frame in 0..args.frames.max(1) {
        last = ctx.one_shot(|cmd| app.record(&ctx, cmd, frame, args.size, vk::ImageLayout::GENERAL))?;
        let t = app.timestamps.read_ns(3)?;
        passes = vec![
            PassTime { name: "scene", gpu_ms: (t[1].saturating_sub(t[0])) as f64 * 1e-6 },
            PassTime { name: "tonemap", gpu_ms: (t[2].saturating_sub(t[1])) as f64 * 1e-6 },
        ];
    }
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let ldr = app.ldr.as_ref().expect("rendered");
    let pixels = ctx.read_image(ldr, last.layout, last.stage, last.access)?;
    let out = args.out.clone().unwrap_or_else(|| "out/hello.png".into());
    output::write_png(&out, args.size[0], args.size[1], &pixels)?;
    eprintln!("wrote {} ({} frames, {:.1} ms)", out.display(), args.frames, wall_ms);
    if let Some(path) = &args.report {
        let report =
            Report { demo: "hello", device: (&ctx.info).into(), size: args.size, frames: args.frames, passes, wall_ms };
        output::write_json(path, &report)?;
    }
    Ok(())
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
        run_windowed(config, &args.context_options(), Hello::new).map(|_| ())
    } else {
        headless(&args)
    };
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(vkengine::demo::exit_code(&e));
    }
}
