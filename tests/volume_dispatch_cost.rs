//! lavapipe (Mesa 22.3) inlines uniform values that steer a shader's branches and, where that
//! halves the shader, does it again at every dispatch: it clones and optimises the shader and
//! compiles it, which Mesa's disk cache answers in a few ms (1.5–9 ms a frame for the volume
//! shaders at any image size). The volume shaders read their uniform blocks at an opaque index
//! on llvmpipe (`volume/common.glsl`'s OPAQUE_BLOCKS) so that there is nothing to inline. With
//! the disk cache off, each such compile is a whole LLVM compile, so a frame after the first
//! would cost about what the first did (measured 162 ms a frame for EAM at 16², 828 ms for MCM,
//! against 1.4 and 3.3 ms): this test sees the difference without timing anything small. One
//! test in its own binary, since it turns Mesa's cache off for the process.

mod common;

use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::procedural;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};

#[test]
fn frames_after_the_first_do_not_compile_the_volume_shaders_again() {
    if common::skip_pinned_to_lavapipe("the recompile at every dispatch is lavapipe's") {
        return;
    }
    // Before the first Vulkan call of this process (its only test).
    std::env::set_var("MESA_SHADER_CACHE_DISABLE", "true");
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("volume");
        let tf = TransferFunction::ramp(0.0, 0.6, [0.8, 0.6, 0.9], 8.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let cam = Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height: 2.0 });
        // Bounded work with an explicit budget: no calibration in between.
        let mc = McSettings { budget: 64, paths_per_frame: 1, ..Default::default() };
        for renderer in [RendererKind::Eam, RendererKind::Mcm] {
            let s = RenderSettings { renderer, mc, ..Default::default() };
            let mut t = Targets::new(ctx, [16, 16]).expect("targets");
            let ms: Vec<f64> =
                (0..4).map(|f| render_frame(ctx, &r, &mut t, &cam, &s, f).expect("render").gpu_ms()).collect();
            eprintln!("{renderer:?}: GPU ms per frame {ms:.2?}");
            // The first frame compiles the shader; a recompile would make each later one as long.
            let later = ms[1..].iter().copied().fold(0.0, f64::max);
            assert!(
                later < ms[0] / 4.0,
                "{renderer:?}: frames after the first took up to {later:.1} ms against the first's {:.1} ms: the shader was compiled again",
                ms[0]
            );
        }
    });
}
