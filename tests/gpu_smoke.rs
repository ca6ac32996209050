//! Foundation smoke tests on lavapipe under validation + synchronization validation.

mod common;

use vkengine::shaders;
use vkengine::vk::{
    pipeline::push_words, vk, Binding, Buffer, Descriptor, GraphicsDesc, Image, ImageInfo, MemoryLocation, Pipeline,
    TimestampPool,
};

/// CPU twin of `shaders_glsl/common/hash.glsl`.
fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

fn run_fill(ctx: &vkengine::vk::Context, shader: &shaders::Shader, count: u32, offset: u32, hash: bool) -> Vec<u32> {
    let bindings = [Binding::new(0, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::COMPUTE)];
    let pipe = Pipeline::compute(ctx, shader, &bindings, 12).expect("pipeline");
    let buf = Buffer::new(
        ctx,
        "out",
        count as u64 * 4,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
    )
    .expect("buffer");
    ctx.one_shot(|cmd| {
        pipe.bind(cmd, &[Descriptor::StorageBuffer(buf.raw)], &push_words(&[count, offset, hash as u32]))?;
        // SAFETY: pipeline bound with all descriptors pushed.
        unsafe { ctx.device.cmd_dispatch(cmd, count.div_ceil(64), 1, 1) };
        Ok(())
    })
    .expect("dispatch");
    let bytes = ctx.read_buffer(&buf).expect("readback");
    bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

#[test]
fn compute_writes_buffer_exactly() {
    common::gpu_test(|ctx| {
        let n = 1000;
        let got = run_fill(ctx, &shaders::TEST_FILL_BUFFER_COMP, n, 5, false);
        let want: Vec<u32> = (0..n).map(|i| i * 7 + 5).collect();
        assert_eq!(got, want);
    });
}

#[test]
fn shader_variant_uses_its_defines() {
    common::gpu_test(|ctx| {
        assert_eq!(shaders::TEST_FILL_BUFFER_COMP__SCALED.defines, &[("SCALE", "3")]);
        let got = run_fill(ctx, &shaders::TEST_FILL_BUFFER_COMP__SCALED, 100, 1, false);
        let want: Vec<u32> = (0..100).map(|i| (i * 7 + 1) * 3).collect();
        assert_eq!(got, want);
    });
}

#[test]
fn shared_include_matches_cpu_hash() {
    common::gpu_test(|ctx| {
        let got = run_fill(ctx, &shaders::TEST_FILL_BUFFER_COMP, 4096, 0, true);
        let want: Vec<u32> = (0..4096).map(pcg_hash).collect();
        assert_eq!(got, want);
    });
}

#[test]
fn triangle_pixels_are_exact() {
    common::gpu_test(|ctx| {
        let (w, h) = (32u32, 32u32);
        let fmt = vk::Format::R8G8B8A8_UNORM;
        let img = Image::new(
            ctx,
            "target",
            ImageInfo::d2(fmt, w, h, vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC),
        )
        .expect("image");
        let pipe = Pipeline::graphics(
            ctx,
            &[&shaders::TEST_TRIANGLE_VERT, &shaders::TEST_TRIANGLE_FRAG],
            &[],
            0,
            &GraphicsDesc { color_formats: vec![fmt], ..Default::default() },
        )
        .expect("pipeline");
        ctx.one_shot(|cmd| {
            let to_color = [vk::ImageMemoryBarrier2::default()
                .image(img.raw)
                .subresource_range(img.info.full_range())
                .old_layout(vk::ImageLayout::UNDEFINED)
                .new_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .dst_stage_mask(vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT)
                .dst_access_mask(vk::AccessFlags2::COLOR_ATTACHMENT_WRITE)];
            let att = [vk::RenderingAttachmentInfo::default()
                .image_view(img.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: [0.0, 0.0, 0.0, 1.0] } })];
            let area = vk::Rect2D { offset: vk::Offset2D::default(), extent: vk::Extent2D { width: w, height: h } };
            // SAFETY: recording; image in the declared layouts.
            unsafe {
                ctx.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&to_color));
                ctx.device.cmd_begin_rendering(
                    cmd,
                    &vk::RenderingInfo::default().render_area(area).layer_count(1).color_attachments(&att),
                );
                pipe.bind(cmd, &[], &[])?;
                ctx.device.cmd_set_viewport(
                    cmd,
                    0,
                    &[vk::Viewport {
                        x: 0.0,
                        y: 0.0,
                        width: w as f32,
                        height: h as f32,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    }],
                );
                ctx.device.cmd_set_scissor(cmd, 0, &[area]);
                ctx.device.cmd_draw(cmd, 3, 1, 0, 0);
                ctx.device.cmd_end_rendering(cmd);
            }
            Ok(())
        })
        .expect("draw");
        let px = ctx
            .read_image(
                &img,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            )
            .expect("readback");
        let at = |x: u32, y: u32| {
            let i = ((y * w + x) * 4) as usize;
            [px[i], px[i + 1], px[i + 2], px[i + 3]]
        };
        // Triangle covers y > x (Vulkan NDC y points down); the diagonal itself is not checked.
        for (x, y) in [(0, 31), (2, 20), (10, 12), (30, 31)] {
            assert_eq!(at(x, y), [255, 102, 51, 255], "inside pixel ({x},{y})");
        }
        for (x, y) in [(31, 0), (20, 2), (12, 10), (31, 30)] {
            assert_eq!(at(x, y), [0, 0, 0, 255], "outside pixel ({x},{y})");
        }
        let inside = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).filter(|&(x, y)| at(x, y)[0] == 255).count();
        // Half the pixels minus/plus the diagonal: top-left rule puts it on one side.
        assert!((496..=528).contains(&inside), "covered pixels {inside}");
    });
}

#[test]
fn volume_upload_readback_round_trip() {
    common::gpu_test(|ctx| {
        let extent = [13u32, 7, 5];
        let n = (extent[0] * extent[1] * extent[2]) as usize;
        let values: Vec<f32> = (0..n as u32).map(|i| (pcg_hash(i) as f32) / u32::MAX as f32 - 0.25).collect();
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let img = Image::new(
            ctx,
            "volume",
            ImageInfo::d3(
                vk::Format::R32_SFLOAT,
                extent,
                vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC,
            ),
        )
        .expect("image");
        let ro = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let (st, acc) = (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_SAMPLED_READ);
        ctx.upload_image(&img, &bytes, ro, st, acc).expect("upload");
        let back = ctx.read_image(&img, ro, st, acc).expect("readback");
        assert_eq!(back, bytes);
        // Wrong-sized input is an error, not a panic.
        assert!(ctx.upload_image(&img, &bytes[4..], ro, st, acc).is_err());
    });
}

#[test]
fn timestamps_are_ordered() {
    common::gpu_test(|ctx| {
        let pool = TimestampPool::new(ctx, 2).expect("pool");
        let bindings = [Binding::new(0, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::COMPUTE)];
        let pipe = Pipeline::compute(ctx, &shaders::TEST_FILL_BUFFER_COMP, &bindings, 12).expect("pipeline");
        let n = 1 << 16;
        let buf = Buffer::new(ctx, "out", n as u64 * 4, vk::BufferUsageFlags::STORAGE_BUFFER, MemoryLocation::GpuOnly)
            .expect("buffer");
        ctx.one_shot(|cmd| {
            pool.reset(cmd, 2);
            pool.write(cmd, vk::PipelineStageFlags2::TOP_OF_PIPE, 0);
            pipe.bind(cmd, &[Descriptor::StorageBuffer(buf.raw)], &push_words(&[n, 0, 1]))?;
            // SAFETY: pipeline and descriptors bound.
            unsafe { ctx.device.cmd_dispatch(cmd, n / 64, 1, 1) };
            pool.write(cmd, vk::PipelineStageFlags2::BOTTOM_OF_PIPE, 1);
            Ok(())
        })
        .expect("submit");
        let t = pool.read_ns(2).expect("timestamps");
        assert!(t[1] > t[0], "timestamps not increasing: {t:?}");
        assert!(t[1] - t[0] < 10_000_000_000, "implausible duration {t:?}");
    });
}

#[test]
fn selects_lavapipe_and_reports_it() {
    if common::skip_pinned_to_lavapipe("it checks that the suite selected lavapipe") {
        return;
    }
    common::gpu_test(|ctx| {
        assert!(ctx.info.name.contains("llvmpipe"), "pinned device is {}", ctx.info.name);
        assert_eq!(ctx.info.kind, vk::PhysicalDeviceType::CPU);
        assert!(ctx.info.timestamp_period_ns > 0.0);
        if common::validation_required() {
            assert!(ctx.info.validation, "CI / VKENGINE_VALIDATION=required must run with the validation layer");
        }
    });
}
