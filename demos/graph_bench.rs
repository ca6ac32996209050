//! Measures frame graph build + compile + aliasing placement cost on synthetic graphs of
//! 10/100/1000 passes and writes `compile_cost.csv` (median and p95 microseconds per size).

use std::fs;
use std::path::PathBuf;
use std::time::Instant;

use ash::vk;
use clap::Parser;
use vkengine::graph::{
    place, Access, BufferDesc, CompiledGraph, GraphBuilder, GraphError, ImageDesc, ImageId, LoadOp, ResourceDesc,
    ResourceState, ShaderStage,
};

#[derive(Parser)]
#[command(about = "Frame graph compile-cost benchmark")]
struct Args {
    /// Output directory for compile_cost.csv.
    #[arg(long, default_value = "results/graph_bench")]
    out: PathBuf,
    /// Measured iterations per graph size.
    #[arg(long, default_value_t = 200)]
    iters: usize,
    /// Also measure recording on the Vulkan device (creating + aliasing transients, barriers,
    /// labels, timestamps; the passes record no work of their own).
    #[arg(long)]
    record: bool,
}

/// Deterministic xorshift, so every iteration builds the identical graph.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n as u64) as usize
    }
}

/// A frame-like graph: compute chains with fan-in over recent results, raster passes,
/// transfer uploads, a dead debug branch every 10 passes, and a final composite to present.
fn build(passes: usize) -> Result<(CompiledGraph<'static>, [ImageId; 2]), GraphError> {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut gb = GraphBuilder::new();
    let desc = ImageDesc::d2(vk::Format::R16G16B16A16_SFLOAT, 1920, 1080);
    let backbuffer = gb.import_image("backbuffer", desc, ResourceState::UNDEFINED);
    let history = gb.import_image("history", desc, ResourceState::from_access(Access::Sampled(ShaderStage::Fragment)));
    let mut live: Vec<ImageId> = Vec::new();
    let cs_read = Access::Sampled(ShaderStage::Compute);
    let cs_write = Access::StorageWrite(ShaderStage::Compute);
    // Upload steps declare two passes, so count declarations rather than steps.
    let mut declared = 0;
    let mut i = 0;
    while declared + 1 < passes {
        i += 1;
        declared += if i % 10 != 9 && i % 4 == 0 { 2 } else { 1 };
        let target = gb.create_image(format!("t{i}"), desc);
        if i % 10 == 9 {
            // Dead debug branch: reads something, writes an unexported transient → culled.
            let mut p = gb.add_compute_pass(format!("debug{i}"));
            if let Some(&src) = live.last() {
                p.read_image(src, cs_read)?;
            }
            p.write_image(target, cs_write)?;
            continue;
        }
        match i % 4 {
            0 => {
                let buf = gb.create_buffer(format!("upload{i}"), BufferDesc::new(1 << 16));
                gb.add_transfer_pass(format!("upload{i}")).write_buffer(buf, Access::TransferDst)?;
                let mut p = gb.add_compute_pass(format!("cs{i}"));
                p.read_buffer(buf, Access::StorageRead(ShaderStage::Compute))?.write_image(target, cs_write)?;
                if i == 4 {
                    p.read_image(history, cs_read)?;
                }
            }
            1 => {
                let mut p = gb.add_raster_pass(format!("raster{i}"));
                p.color_attachment(target, LoadOp::Clear, [0.0; 4])?;
                for _ in 0..live.len().min(2) {
                    let src = live[live.len() - 1 - rng.below(live.len().min(4))];
                    p.read_image(src, Access::Sampled(ShaderStage::Fragment))?;
                }
            }
            _ => {
                let mut p = gb.add_compute_pass(format!("cs{i}"));
                p.write_image(target, cs_write)?;
                for _ in 0..live.len().min(3) {
                    let src = live[live.len() - 1 - rng.below(live.len().min(8))];
                    p.read_image(src, cs_read)?;
                }
            }
        }
        live.push(target);
    }
    let mut composite = gb.add_raster_pass("composite");
    composite.color_attachment(backbuffer, LoadOp::DontCare, [0.0; 4])?;
    for &src in live.iter().rev().take(4) {
        composite.read_image(src, Access::Sampled(ShaderStage::Fragment))?;
    }
    gb.export_image(backbuffer, Some(Access::Present))?;
    Ok((gb.compile()?, [backbuffer, history]))
}

/// Stand-in for device memory requirements: texel bytes, 64 KiB alignment.
fn requirements(desc: &ResourceDesc) -> (u64, u64) {
    match desc {
        ResourceDesc::Image(d) => {
            (u64::from(d.extent[0]) * u64::from(d.extent[1]) * u64::from(d.extent[2]) * 8, 1 << 16)
        }
        ResourceDesc::Buffer(d) => (d.size, 256),
    }
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let idx = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[idx]
}

fn main() {
    vkengine_demos::runner::exit_on_bench_error(run());
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let iters = args.iters.max(1);
    let mut csv =
        String::from("passes,iters,median_us,p95_us,kept,culled,barriers,transients,heap_bytes,unaliased_bytes\n");
    println!(
        "{:>6} {:>6} {:>11} {:>11} {:>6} {:>6} {:>9} {:>10} {:>10} {:>10}",
        "passes", "iters", "median_us", "p95_us", "kept", "culled", "barriers", "transients", "heap_MiB", "unalias_MiB"
    );
    for &size in &[10usize, 100, 1000] {
        let mut samples = Vec::with_capacity(iters);
        let mut last = None;
        // One warm-up run keeps first-touch allocation out of the statistics.
        for i in 0..=iters {
            let start = Instant::now();
            let (mut g, _) = build(size)?;
            let reqs = g.alias_requests(|t| requirements(&t.desc));
            let plan = place(&reqs, 1024);
            g.apply_aliasing(&reqs, &plan)?;
            let us = start.elapsed().as_secs_f64() * 1e6;
            if i > 0 {
                samples.push(us);
            }
            last = Some((g.stats(), plan));
        }
        samples.sort_by(f64::total_cmp);
        let (median, p95) = (percentile(&samples, 0.5), percentile(&samples, 0.95));
        let Some((stats, plan)) = last else {
            continue;
        };
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        println!(
            "{:>6} {:>6} {:>11.1} {:>11.1} {:>6} {:>6} {:>9} {:>10} {:>10.1} {:>10.1}",
            stats.passes_declared,
            iters,
            median,
            p95,
            stats.passes_kept,
            stats.passes_culled,
            stats.barriers,
            stats.transients,
            mib(plan.heap_size),
            mib(plan.unaliased_size)
        );
        csv.push_str(&format!(
            "{},{iters},{median:.2},{p95:.2},{},{},{},{},{},{}\n",
            stats.passes_declared,
            stats.passes_kept,
            stats.passes_culled,
            stats.barriers,
            stats.transients,
            plan.heap_size,
            plan.unaliased_size
        ));
    }
    fs::create_dir_all(&args.out)?;
    if args.record {
        record_cost(&args, iters)?;
    }
    let path = args.out.join("compile_cost.csv");
    fs::write(&path, csv)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// CPU cost of `record_graph` per graph size, on the selected device; writes `record_cost.csv`.
fn record_cost(args: &Args, iters: usize) -> Result<(), Box<dyn std::error::Error>> {
    use vkengine::graph::execute::{record_graph, ExecuteOptions, Imports};
    use vkengine::vk::{Context, ContextOptions, Image, ImageInfo};
    let ctx = Context::new(&ContextOptions::from_env())?;
    let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::STORAGE;
    let info = ImageInfo::d2(vk::Format::R16G16B16A16_SFLOAT, 1920, 1080, usage);
    let (backbuffer, history) = (Image::new(&ctx, "backbuffer", info)?, Image::new(&ctx, "history", info)?);
    let mut csv =
        format!("# device: {} ({})\npasses,iters,record_median_us,record_p95_us\n", ctx.info.name, ctx.info.driver);
    let iters = (iters / 10).max(5);
    for &size in &[10usize, 100, 1000] {
        let mut samples = Vec::new();
        for i in 0..=iters {
            let (g, ids) = build(size)?;
            let mut imports = Imports::default();
            imports.bind_image(ids[0], &backbuffer);
            imports.bind_image(ids[1], &history);
            let us = ctx.one_shot(|cmd| {
                let start = Instant::now();
                let recorded = record_graph(&ctx, cmd, g, &imports, ExecuteOptions::default())?;
                let us = start.elapsed().as_secs_f64() * 1e6;
                Ok((us, recorded))
            })?;
            if i > 0 {
                samples.push(us.0);
            }
        }
        samples.sort_by(f64::total_cmp);
        let (median, p95) = (percentile(&samples, 0.5), percentile(&samples, 0.95));
        println!("record {size:>5} passes: median {median:.1} us, p95 {p95:.1} us ({} on {})", iters, ctx.info.name);
        csv.push_str(&format!("{size},{iters},{median:.2},{p95:.2}\n"));
    }
    fs::write(args.out.join("record_cost.csv"), csv)?;
    Ok(())
}
