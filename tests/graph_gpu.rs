//! Frame graph on the GPU (lavapipe, validation + synchronization validation): chains of compute
//! and raster passes produce exact values, aliased transients stay correct, culled passes never run,
//! raster passes reach every layer of array attachments.

mod common;

use std::cell::Cell;
use vkengine::graph::execute::{run_graph, ExecuteOptions, Imports};
use vkengine::graph::{
    Access, BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, ImageKind, LoadOp, ResourceState, ShaderStage,
};
use vkengine::shaders;
use vkengine::vk::{
    pipeline::push_words, vk, Binding, Context, Descriptor, GraphicsDesc, Image, ImageInfo, Pipeline, Sampler,
};

const W: u32 = 24;
const H: u32 = 16;
const FMT: vk::Format = vk::Format::R32_UINT;

/// Where `Context::upload_buffer` leaves a buffer.
const AFTER_UPLOAD: ResourceState = ResourceState {
    layout: vk::ImageLayout::UNDEFINED,
    stage: vk::PipelineStageFlags2::TRANSFER,
    access: vk::AccessFlags2::TRANSFER_WRITE,
};

struct Pipes {
    seed: Pipeline,
    step: Pipeline,
    raster: Pipeline,
    sampler: Sampler,
}

fn pipes(ctx: &Context) -> Pipes {
    let c = vk::ShaderStageFlags::COMPUTE;
    let si = vk::DescriptorType::STORAGE_IMAGE;
    Pipes {
        seed: Pipeline::compute(ctx, &shaders::TEST_GRAPH_SEED_COMP, &[Binding::new(0, si, c)], 4).expect("seed"),
        step: Pipeline::compute(
            ctx,
            &shaders::TEST_GRAPH_STEP_COMP,
            &[Binding::new(0, si, c), Binding::new(1, si, c)],
            4,
        )
        .expect("step"),
        raster: Pipeline::graphics(
            ctx,
            &[&shaders::TEST_FULLSCREEN_VERT, &shaders::TEST_GRAPH_RASTER_FRAG],
            &[Binding::new(0, vk::DescriptorType::COMBINED_IMAGE_SAMPLER, vk::ShaderStageFlags::FRAGMENT)],
            4,
            &GraphicsDesc { color_formats: vec![FMT], ..Default::default() },
        )
        .expect("raster"),
        sampler: Sampler::clamped(ctx, false).expect("sampler"),
    }
}

fn readback(ctx: &Context, img: &Image, state: ResourceState) -> Vec<u32> {
    let bytes = ctx.read_image(img, state.layout, state.stage, state.access).expect("readback");
    bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

fn add_step<'a>(
    g: &mut GraphBuilder<'a>,
    name: &str,
    src: ImageId,
    dst: ImageId,
    add: u32,
    pipe: &'a Pipeline,
    groups: [u32; 2],
) {
    let cs = ShaderStage::Compute;
    let mut pass = g.add_compute_pass(name);
    pass.read_image(src, Access::StorageRead(cs)).expect("decl");
    pass.write_image(dst, Access::StorageWrite(cs)).expect("decl");
    pass.record(move |pc| {
        let ds = [Descriptor::StorageImage(pc.image(src).view), Descriptor::StorageImage(pc.image(dst).view)];
        pipe.bind(pc.cmd, &ds, &push_words(&[add])).expect("bind");
        // SAFETY: pipeline and descriptors bound.
        unsafe { pc.device().cmd_dispatch(pc.cmd, groups[0], groups[1], 1) };
        Ok(())
    });
}

fn add_fill<'a>(
    g: &mut GraphBuilder<'a>,
    name: &str,
    target: BufferId,
    fill: &'a Pipeline,
    flag: Option<&'a Cell<bool>>,
) {
    let mut pass = g.add_compute_pass(name);
    pass.write_buffer(target, Access::StorageWrite(ShaderStage::Compute)).expect("decl");
    pass.record(move |pc| {
        if let Some(f) = flag {
            f.set(true);
        }
        fill.bind(pc.cmd, &[Descriptor::StorageBuffer(pc.buffer(target).raw)], &push_words(&[64, 0xABCD, 0]))
            .expect("bind");
        // SAFETY: pipeline bound.
        unsafe { pc.device().cmd_dispatch(pc.cmd, 1, 1, 1) };
        Ok(())
    });
}

fn seed(x: u32, y: u32, base: u32) -> u32 {
    x + 1000 * y + base
}

/// seed → step(+1) → raster(+7, sampled) → step(+2) → step(+3) into an imported output.
fn chain(ctx: &Context, alias: bool) -> (Vec<u32>, vkengine::graph::execute::GraphRun) {
    let p = pipes(ctx);
    let out = Image::new(
        ctx,
        "out",
        ImageInfo::d2(FMT, W, H, vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC),
    )
    .expect("out");
    let mut g = GraphBuilder::new();
    let mut imports = Imports::default();
    let out_id = imports.image(&mut g, "out", &out, ResourceState::UNDEFINED);
    let desc = ImageDesc::d2(FMT, W, H);
    let a = g.create_image("a", desc);
    let b = g.create_image("b", desc);
    let c = g.create_image("c", desc);
    let d = g.create_image("d", desc);
    let groups = [W.div_ceil(8), H.div_ceil(8)];
    let cs = ShaderStage::Compute;
    let dispatch = |pc: &mut vkengine::graph::PassContext<'_>| {
        // SAFETY: pipeline and descriptors were bound by the caller.
        unsafe { pc.device().cmd_dispatch(pc.cmd, groups[0], groups[1], 1) };
    };
    {
        let seed_pipe = &p.seed;
        let mut pass = g.add_compute_pass("seed");
        pass.write_image(a, Access::StorageWrite(cs)).expect("decl");
        pass.record(move |pc| {
            seed_pipe.bind(pc.cmd, &[Descriptor::StorageImage(pc.image(a).view)], &push_words(&[5])).expect("bind");
            dispatch(pc);
            Ok(())
        });
    }
    add_step(&mut g, "step1", a, b, 1, &p.step, groups);
    {
        let (raster, sampler) = (&p.raster, p.sampler.raw);
        let mut pass = g.add_raster_pass("raster");
        pass.read_image(b, Access::Sampled(ShaderStage::Fragment)).expect("decl");
        pass.color_attachment(c, LoadOp::DontCare, [0.0; 4]).expect("decl");
        pass.record(move |pc| {
            raster
                .bind(pc.cmd, &[Descriptor::CombinedImageSampler(pc.image(b).view, sampler)], &push_words(&[7]))
                .expect("bind");
            // SAFETY: inside the pass's dynamic rendering scope with the pipeline bound.
            unsafe { pc.device().cmd_draw(pc.cmd, 3, 1, 0, 0) };
            Ok(())
        });
    }
    add_step(&mut g, "step2", c, d, 2, &p.step, groups);
    add_step(&mut g, "step3", d, out_id, 3, &p.step, groups);
    g.export_image(out_id, Some(Access::TransferSrc)).expect("export");
    let compiled = g.compile().expect("compile");
    let final_state = compiled.final_state(out_id.into()).expect("imported state");
    let run = run_graph(ctx, compiled, &imports, ExecuteOptions { alias }).expect("run");
    (readback(ctx, &out, final_state), run)
}

fn expected() -> Vec<u32> {
    let mut v = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let s1 = seed(x, y, 5) * 3 + 1;
            let r = s1 + 7;
            v.push(((r * 3 + 2) * 3) + 3);
        }
    }
    v
}

#[test]
fn compute_raster_chain_is_exact() {
    common::gpu_test(|ctx| {
        let (got, run) = chain(ctx, false);
        assert_eq!(got, expected());
        let names: Vec<_> = run.timings.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["seed", "step1", "raster", "step2", "step3"]);
        assert!(run.timings.iter().all(|t| t.gpu_end_ns >= t.gpu_begin_ns));
        assert_eq!(run.memory.heap_bytes, run.memory.unaliased_bytes);
    });
}

#[test]
fn aliased_transients_stay_correct_and_save_memory() {
    common::gpu_test(|ctx| {
        let (got, run) = chain(ctx, true);
        assert_eq!(got, expected());
        assert_eq!(run.memory.transients, 4);
        // a..d live [0,1], [1,2], [2,3], [3,4]: at most two are alive at once.
        assert!(
            run.memory.heap_bytes * 2 <= run.memory.unaliased_bytes + 1024,
            "aliasing saved too little: {:?}",
            run.memory
        );
    });
}

#[test]
fn culled_pass_never_runs() {
    common::gpu_test(|ctx| {
        let bindings = [Binding::new(0, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::COMPUTE)];
        let fill = Pipeline::compute(ctx, &shaders::TEST_FILL_BUFFER_COMP, &bindings, 12).expect("fill");
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
        let kept = ctx.upload_buffer("kept", &[0u8; 256], usage).expect("kept");
        let sentinel = ctx.upload_buffer("sentinel", &[0u8; 256], usage).expect("sentinel");
        let culled_ran = Cell::new(false);
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let after_upload = AFTER_UPLOAD;
        let kept_id = imports.buffer(&mut g, "kept", &kept, after_upload);
        let sentinel_id = imports.buffer(&mut g, "sentinel", &sentinel, after_upload);
        let scratch = g.create_buffer("scratch", BufferDesc::new(256));
        add_fill(&mut g, "kept", kept_id, &fill, None);
        add_fill(&mut g, "writes-unexported-sentinel", sentinel_id, &fill, Some(&culled_ran));
        add_fill(&mut g, "writes-unread-scratch", scratch, &fill, Some(&culled_ran));
        g.export_buffer(kept_id, Some(Access::TransferSrc)).expect("export");
        let compiled = g.compile().expect("compile");
        let run = run_graph(ctx, compiled, &imports, ExecuteOptions::default()).expect("run");
        assert!(!culled_ran.get(), "a culled pass recorded commands");
        assert_eq!(run.culled, ["writes-unexported-sentinel", "writes-unread-scratch"]);
        assert_eq!(run.memory.transients, 0, "a culled pass's transient was allocated");
        let sentinel_bytes = ctx.read_buffer(&sentinel).expect("read");
        assert!(sentinel_bytes.iter().all(|&b| b == 0), "culled pass wrote its sentinel");
        let kept_bytes = ctx.read_buffer(&kept).expect("read");
        assert_eq!(u32::from_le_bytes([kept_bytes[4], kept_bytes[5], kept_bytes[6], kept_bytes[7]]), 7 + 0xABCD);
    });
}

#[test]
fn raster_pass_renders_every_layer_of_an_array_attachment() {
    common::gpu_test(|ctx| {
        let layers = 3;
        let info = ImageInfo {
            format: vk::Format::R32_SFLOAT,
            extent: [W, H, 1],
            kind: ImageKind::D2Array(layers),
            mip_levels: 1,
            usage: vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
        };
        let out = Image::new(ctx, "layered", info).expect("layered");
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let id = imports.image(&mut g, "layered", &out, ResourceState::UNDEFINED);
        // The clear covers the rendering's layer count, so a single-layer render would leave
        // layers 1.. untouched.
        g.add_raster_pass("clear layers")
            .color_attachment(id, LoadOp::Clear, [7.5; 4])
            .expect("decl")
            .record(|_| Ok(()));
        g.export_image(id, Some(Access::TransferSrc)).expect("export");
        let compiled = g.compile().expect("compile");
        let state = compiled.final_state(id.into()).expect("imported state");
        run_graph(ctx, compiled, &imports, ExecuteOptions::default()).expect("run");
        let got = readback(ctx, &out, state);
        assert_eq!(got.len(), (W * H * layers) as usize);
        assert!(got.iter().all(|&v| v == 7.5f32.to_bits()), "some layer was not rendered");
    });
}

#[test]
fn the_next_identical_graph_reuses_the_transients_and_a_different_one_does_not() {
    common::gpu_test(|ctx| {
        let run = |w: u32| {
            let mut g = GraphBuilder::new();
            let img = g.create_image("pooled", ImageDesc::d2(FMT, w, H));
            g.compute("seed", &shaders::TEST_GRAPH_SEED_COMP)
                .write(img)
                .constants(&7u32)
                .dispatch([w.div_ceil(8), H.div_ceil(8), 1])
                .expect("declare");
            g.export_image(img, None).expect("export");
            run_graph(ctx, g.compile().expect("compile"), &Imports::default(), ExecuteOptions::default())
                .expect("run")
                .memory
        };
        let first = run(W);
        assert!(!first.reused && first.transients == 1, "{first:?}");
        // Dropped after its submission completed: the same signature takes the set back.
        assert!(run(W).reused, "an identical graph should reuse the set");
        assert!(!run(W + 8).reused, "a different extent must not reuse it");
        assert!(run(W).reused, "the first set is still pooled");
    });
}

#[test]
fn a_pass_over_llvmpipes_loop_limit_is_refused_by_name() {
    common::gpu_test(|ctx| {
        if !ctx.info.name.contains("llvmpipe") {
            return; // the limit is llvmpipe's; other devices run the pass
        }
        let run = |bound: u64| {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
            let buf = ctx.upload_buffer("out", &[0u8; 256], usage).expect("buffer");
            let mut g = GraphBuilder::new();
            let mut imports = Imports::default();
            let after_upload = AFTER_UPLOAD;
            let id = imports.buffer(&mut g, "out", &buf, after_upload);
            g.compute("long loops", &shaders::TEST_FILL_BUFFER_COMP)
                .write(id)
                .constants(&[64u32, 0, 0])
                .loop_bound(bound)
                .dispatch([1, 1, 1])
                .expect("declare");
            g.export_buffer(id, Some(Access::TransferSrc)).expect("export");
            run_graph(ctx, g.compile().expect("compile"), &imports, ExecuteOptions::default()).map(|_| ())
        };
        assert!(run(65_535).is_ok(), "a pass at the limit runs");
        let err = run(65_536).expect_err("a pass over the limit must be refused").to_string();
        assert!(err.contains("long loops") && err.contains("65536"), "{err}");
    });
}
