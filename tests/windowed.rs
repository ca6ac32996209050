//! Windowed path under a real X server (Xvfb in CI): open, present, resize, close — zero
//! validation messages.

mod common;

use vkengine::graph::execute::{record_graph, Imports, RecordedGraph};
use vkengine::graph::{add_present_pass, Access, GraphBuilder, ImageDesc};
use vkengine::vk::{vk, Context, ContextOptions};
use vkengine::window::{run_windowed, PresentTarget, WindowApp, WindowConfig};

/// Clears a transient image to a per-frame colour and presents it: two graph passes.
struct ClearApp {
    /// The previous frame's recording, kept until it was submitted.
    in_flight: Option<RecordedGraph>,
}

impl WindowApp for ClearApp {
    fn render(
        &mut self,
        ctx: &Context,
        _window: &winit::window::Window,
        cmd: vk::CommandBuffer,
        frame: u64,
        target: PresentTarget,
    ) -> vkengine::Result<()> {
        self.in_flight = None;
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let [w, h] = target.extent;
        let img = g.create_image("window-output", ImageDesc::d2(vk::Format::R8G8B8A8_UNORM, w, h));
        let c = (frame % 10) as f32 / 10.0;
        g.add_transfer_pass("clear").write_image(img, Access::TransferDst)?.record(move |pc| {
            let i = pc.image(img);
            // SAFETY: transfer pass; the graph put the image in TRANSFER_DST_OPTIMAL.
            unsafe {
                pc.device().cmd_clear_color_image(
                    pc.cmd,
                    i.raw,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &vk::ClearColorValue { float32: [c, 0.5, 1.0 - c, 1.0] },
                    &[i.info.full_range()],
                )
            };
            Ok(())
        });
        add_present_pass(&mut g, &mut imports, img, target)?;
        self.in_flight = Some(record_graph(ctx, cmd, g.compile()?, &imports, Default::default())?);
        Ok(())
    }
}

#[test]
fn window_presents_resizes_and_closes_cleanly() {
    if !common::have_display("the windowed test") {
        return;
    }
    common::pin_lavapipe();
    let opts = ContextOptions {
        validation: common::validation_policy(),
        device: None,
        display: None,
        gpu_timeout: vkengine::vk::DEFAULT_GPU_TIMEOUT,
        max_allocation: None,
        page_levels: None,
    };
    let config = WindowConfig {
        title: "vkengine windowed test".into(),
        size: [160, 120],
        max_frames: Some(12),
        resize_script: vec![(4, [96, 64])],
        any_thread: true,
    };
    let stats = run_windowed(config, &opts, |_| Ok(ClearApp { in_flight: None })).expect("windowed run");
    assert!(stats.validation_messages.is_empty(), "validation messages: {:#?}", stats.validation_messages);
    assert_eq!(stats.frames_presented, 12);
    assert_eq!(stats.extents.first(), Some(&[160, 120]));
    assert!(stats.extents.contains(&[96, 64]), "resize never reached the swapchain: {:?}", stats.extents);
    assert!(stats.swapchain_generations >= 2);
}
