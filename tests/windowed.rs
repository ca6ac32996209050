//! Windowed path under a real X server (Xvfb in CI): open, present, resize, close — zero
//! validation messages.

mod common;

use vkengine::vk::{vk, Context, ContextOptions, Image, ImageInfo, Validation};
use vkengine::window::{run_windowed, FrameOutput, WindowApp, WindowConfig};

/// Clears an offscreen image to a per-frame colour; recreated when the swapchain size changes.
struct ClearApp {
    image: Option<Image>,
    first_use: bool,
}

impl WindowApp for ClearApp {
    fn render(
        &mut self,
        ctx: &Context,
        _window: &winit::window::Window,
        cmd: vk::CommandBuffer,
        frame: u64,
        extent: [u32; 2],
    ) -> vkengine::Result<FrameOutput> {
        if self.image.as_ref().is_none_or(|i| i.info.extent[..2] != extent) {
            let usage = vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC;
            self.image = Some(Image::new(
                ctx,
                "window-output",
                ImageInfo::d2(vk::Format::R8G8B8A8_UNORM, extent[0], extent[1], usage),
            )?);
            self.first_use = true;
        }
        let img = self.image.as_ref().expect("created above");
        let old = if self.first_use { vk::ImageLayout::UNDEFINED } else { FrameOutput::AFTER_BLIT_LAYOUT };
        self.first_use = false;
        let b = [vk::ImageMemoryBarrier2::default()
            .image(img.raw)
            .subresource_range(img.info.full_range())
            .old_layout(old)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_stage_mask(vk::PipelineStageFlags2::TRANSFER)
            .dst_stage_mask(vk::PipelineStageFlags2::TRANSFER)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)];
        let c = (frame % 10) as f32 / 10.0;
        // SAFETY: recording; image transitioned to TRANSFER_DST_OPTIMAL first.
        unsafe {
            ctx.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&b));
            ctx.device.cmd_clear_color_image(
                cmd,
                img.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &vk::ClearColorValue { float32: [c, 0.5, 1.0 - c, 1.0] },
                &[img.info.full_range()],
            );
        }
        Ok(FrameOutput {
            image: img.raw,
            extent,
            layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            stage: vk::PipelineStageFlags2::TRANSFER,
            access: vk::AccessFlags2::TRANSFER_WRITE,
        })
    }
}

#[test]
fn window_presents_resizes_and_closes_cleanly() {
    if std::env::var_os("DISPLAY").is_none() {
        assert!(!common::in_ci(), "CI must run the windowed test under Xvfb (DISPLAY unset)");
        eprintln!("skipping: no DISPLAY (run under xvfb-run)");
        return;
    }
    common::pin_lavapipe();
    let opts = ContextOptions {
        validation: if common::in_ci() { Validation::Required } else { Validation::IfAvailable },
        device: None,
        display: None,
    };
    let config = WindowConfig {
        title: "vkengine windowed test".into(),
        size: [160, 120],
        max_frames: Some(12),
        resize_script: vec![(4, [96, 64])],
        any_thread: true,
    };
    let stats = run_windowed(config, &opts, |_| Ok(ClearApp { image: None, first_use: true })).expect("windowed run");
    assert!(stats.validation_messages.is_empty(), "validation messages: {:#?}", stats.validation_messages);
    assert_eq!(stats.frames_presented, 12);
    assert_eq!(stats.extents.first(), Some(&[160, 120]));
    assert!(stats.extents.contains(&[96, 64]), "resize never reached the swapchain: {:?}", stats.extents);
    assert!(stats.swapchain_generations >= 2);
}
