//! Volume renderers against analytic answers, on lavapipe under validation + sync validation.

mod common;

use glam::Vec3;
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{procedural, Volume};
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{render_frame, RenderSettings, RendererKind, Targets, VolumeRenderer};

const SIZE: [u32; 2] = [32, 32];

/// Orthographic camera looking down -Z; the image spans `height` world units.
fn ortho(height: f32) -> Camera {
    Camera::orbit(3.0, 0.0, 0.0, Projection::Orthographic { height })
}

fn render(ctx: &Context, vol: &Volume, tf: &TransferFunction, cam: &Camera, s: RenderSettings) -> Vec<[f32; 4]> {
    let r = VolumeRenderer::new(ctx, vol, tf).expect("renderer");
    let mut t = Targets::new(ctx, SIZE).expect("targets");
    render_frame(ctx, &r, &mut t, cam, &s, 0).expect("render");
    t.read_hdr(ctx).expect("readback")
}

/// World position of pixel centre (x, y) on the z = 0 plane for `ortho(height)`.
fn pixel_world(x: u32, y: u32, height: f32) -> (f32, f32) {
    let u = ((x as f32 + 0.5) / SIZE[0] as f32 * 2.0 - 1.0) * height * 0.5;
    let v = -((y as f32 + 0.5) / SIZE[1] as f32 * 2.0 - 1.0) * height * 0.5;
    (u, v)
}

fn max_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    a.iter().zip(b).flat_map(|(p, q)| (0..3).map(move |i| (p[i] - q[i]).abs())).fold(0.0, f32::max)
}

#[test]
fn eam_homogeneous_box_matches_analytic() {
    common::gpu_test(|ctx| {
        let color = [0.8, 0.5, 0.2];
        let sigma = 3.0;
        let vol = procedural::homogeneous_box([16, 16, 16], 1.0).expect("procedural volume");
        let tf = TransferFunction::constant(color, sigma);
        let s = RenderSettings { renderer: RendererKind::Eam, empty_space_skipping: false, ..Default::default() };
        let img = render(ctx, &vol, &tf, &ortho(2.0), s);
        // The unit cube covers pixels 8..24; each ray crosses d = 1.
        let expect = color.map(|c| c * (1.0 - (-sigma).exp()));
        for (x, y) in [(16, 16), (9, 9), (22, 12), (12, 22)] {
            let p = img[(y * SIZE[0] + x) as usize];
            for i in 0..3 {
                assert!((p[i] - expect[i]).abs() < 1e-3, "pixel ({x},{y}) ch {i}: {} vs analytic {}", p[i], expect[i]);
            }
        }
        // Outside the box: background (black).
        assert_eq!(img[0][..3], [0.0; 3]);
    });
}

#[test]
fn eam_front_to_back_equals_back_to_front_and_step_halving_is_bounded() {
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([24, 24, 24], 0.45).expect("procedural volume");
        let tf = TransferFunction::ramp(0.1, 0.8, [1.0, 0.6, 0.3], 12.0);
        let cam = ortho(1.2);
        let base = RenderSettings { empty_space_skipping: false, precomputed_gradients: false, ..Default::default() };
        let f2b =
            render(ctx, &vol, &tf, &cam, RenderSettings { renderer: RendererKind::Eam, termination: 0.0, ..base });
        let b2f = render(ctx, &vol, &tf, &cam, RenderSettings { renderer: RendererKind::EamBackToFront, ..base });
        let d = max_diff(&f2b, &b2f);
        assert!(d < 1e-5, "front-to-back vs back-to-front differ by {d}");
        assert!(f2b.iter().any(|p| p[0] > 0.1), "image is empty");
        let step = 0.5 / 24.0;
        let coarse = render(ctx, &vol, &tf, &cam, RenderSettings { step: Some(step), ..base });
        let fine = render(ctx, &vol, &tf, &cam, RenderSettings { step: Some(step / 2.0), ..base });
        let d = max_diff(&coarse, &fine);
        // Stated bound: half-voxel → quarter-voxel steps change no channel by more than 5e-3.
        assert!(d < 5e-3, "halving the step changed the image by {d}");
        eprintln!("step halving: max |Δ| = {d:e}");
    });
}

#[test]
fn empty_space_skipping_changes_no_pixel() {
    common::gpu_test(|ctx| {
        // Also a size that is no multiple of the 8-voxel block: its last cells reach past the
        // volume, and a block-to-cell mapping by cell count would skip visible voxels.
        for dims in [[40, 40, 40], [37, 45, 29]] {
            let vol = procedural::smooth_sphere(dims, 0.3).expect("procedural volume");
            let tf = TransferFunction::ramp(0.2, 0.9, [0.4, 0.7, 1.0], 20.0);
            let cam = Camera::orbit(2.5, 0.6, 0.3, Projection::Perspective { fov_y: 0.7 });
            let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
            assert!(
                r.empty_fraction > 0.3,
                "{dims:?}: test volume should be sparse, empty fraction {}",
                r.empty_fraction
            );
            let mut images = Vec::new();
            for ess in [false, true] {
                let mut t = Targets::new(ctx, SIZE).expect("targets");
                let s = RenderSettings { empty_space_skipping: ess, ..Default::default() };
                render_frame(ctx, &r, &mut t, &cam, &s, 0).expect("render");
                images.push(t.read_hdr(ctx).expect("readback"));
            }
            let d = max_diff(&images[0], &images[1]);
            assert!(d <= 1e-6, "{dims:?}: empty-space skipping changed a pixel by {d}");
            assert!(images[1].iter().any(|p| p[2] > 0.05), "{dims:?}: image is empty");
        }
    });
}

#[test]
fn mip_of_radial_ramp_hits_known_maxima() {
    common::gpu_test(|ctx| {
        // Odd size puts a voxel centre exactly at the sphere centre, where the maximum 1 lives.
        let n = 33u32;
        let radius = 0.4;
        let vol = procedural::smooth_sphere([n, n, n], radius).expect("procedural volume");
        let tf = TransferFunction::constant([1.0; 3], 1.0);
        let height = 1.0;
        let img = render(
            ctx,
            &vol,
            &tf,
            &ortho(height),
            RenderSettings { renderer: RendererKind::Mip, ..Default::default() },
        );
        // Along a ray at distance b from the centre the maximum is 1 - b/R; half a voxel of
        // position error is (0.5/n)/R in value.
        let tol = 0.5 / n as f32 / radius;
        for (x, y) in [(16, 16), (15, 16), (18, 13), (20, 20), (24, 16)] {
            let (u, v) = pixel_world(x, y, height);
            let b = (u * u + v * v).sqrt();
            let expect = (1.0 - b / radius).max(0.0);
            let got = img[(y * SIZE[0] + x) as usize][0];
            assert!((got - expect).abs() <= tol, "MIP at ({x},{y}) b={b}: {got} vs {expect} (tol {tol})");
        }
    });
}

#[test]
fn iso_surface_hits_analytic_sphere() {
    common::gpu_test(|ctx| {
        use vkengine::graph::execute::{run_graph, Imports};
        use vkengine::graph::{Access, GraphBuilder, ResourceState};
        use vkengine::vk::{vk, Buffer, MemoryLocation};
        let n = 32u32;
        let radius = 0.45;
        let iso = 0.5;
        let vol = procedural::smooth_sphere([n, n, n], radius).expect("procedural volume");
        let tf = TransferFunction::constant([0.9, 0.9, 0.9], 1.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        let cam = Camera::orbit(3.0, 0.4, 0.25, Projection::Perspective { fov_y: 0.5 });
        let s = RenderSettings { renderer: RendererKind::Iso, iso, ..Default::default() };
        let bytes = (SIZE[0] * SIZE[1] * 16) as u64;
        let buf =
            Buffer::new(ctx, "hits", bytes, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu).expect("buf");
        let mut g = GraphBuilder::new();
        let mut imports = Imports::default();
        let out = r.add_passes(&mut g, &mut imports, &mut t, &cam, &s, 0).expect("passes");
        let hit = out.iso_hit.expect("iso exposes its hit buffer");
        let dst = imports.buffer(&mut g, "hits", &buf, ResourceState::UNDEFINED);
        let mut p = g.add_transfer_pass("read hits");
        p.read_image(hit, Access::TransferSrc).expect("decl");
        p.write_buffer(dst, Access::TransferDst).expect("decl");
        p.record(move |pc| {
            let region = vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                })
                .image_extent(vk::Extent3D { width: SIZE[0], height: SIZE[1], depth: 1 });
            // SAFETY: image in TRANSFER_SRC_OPTIMAL per the declared access; buffer sized for it.
            unsafe {
                pc.device().cmd_copy_image_to_buffer(
                    pc.cmd,
                    pc.image(hit).raw,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    pc.buffer(dst).raw,
                    &[region],
                )
            };
            Ok(())
        });
        g.export_buffer(dst, Some(Access::HostRead)).expect("export");
        g.export_image(out.ldr, Some(Access::TransferSrc)).expect("export");
        run_graph(ctx, g.compile().expect("compile"), &imports, Default::default()).expect("run");
        let data = buf.mapped().expect("host visible");
        let hits: Vec<[f32; 4]> = data
            .chunks_exact(16)
            .map(|c| std::array::from_fn(|i| f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]])))
            .collect();
        let want_r = radius * (1.0 - iso);
        let tol = 0.5 / n as f32;
        let mut count = 0;
        for h in hits.iter().filter(|h| h[3] >= 0.0) {
            let r = (Vec3::new(h[0], h[1], h[2]) - Vec3::splat(0.5)).length();
            assert!((r - want_r).abs() < tol, "hit at radius {r}, analytic {want_r} (tolerance {tol})");
            count += 1;
        }
        assert!(count > 50, "only {count} rays hit the surface");
        assert!(hits[0][3] < 0.0, "corner ray should miss");
    });
}

#[test]
fn precomputed_gradients_match_on_the_fly_for_1d_and_approximate_for_2d() {
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([24, 24, 24], 0.45).expect("procedural volume");
        let cam = ortho(1.2);
        for (tf, tol) in [
            (TransferFunction::ramp(0.1, 0.8, [1.0, 0.6, 0.3], 12.0), 1e-6f32),
            // A 2D function reads |∇v|: interpolated magnitudes differ slightly from the magnitude
            // of the interpolated gradient.
            (
                TransferFunction::TwoD {
                    boxes: vec![vkengine::volume::optics::tf::TfBox {
                        value: [0.05, 1.0],
                        gradient: [0.05, 1.0],
                        color: [0.9, 0.8, 1.0],
                        extinction: 30.0,
                    }],
                },
                0.1,
            ),
        ] {
            let fly =
                render(ctx, &vol, &tf, &cam, RenderSettings { precomputed_gradients: false, ..Default::default() });
            let pre =
                render(ctx, &vol, &tf, &cam, RenderSettings { precomputed_gradients: true, ..Default::default() });
            let d = max_diff(&fly, &pre);
            assert!(d <= tol, "precomputed vs on-the-fly gradients differ by {d} (tolerance {tol})");
            assert!(fly.iter().any(|p| p[0] > 0.05), "image is empty");
        }
    });
}

/// The marchers leave the gradient fetch out when the transfer function ignores it (the host's
/// `tf_gradient`, specialization constant 0): one that reads it must still get it. The box below
/// is empty at gradient magnitude 0, so a marcher that skipped the fetch (g = 0) draws nothing.
/// A consistency check, not an accuracy test; seen failing with the constant forced off.
#[test]
fn a_transfer_function_that_reads_the_gradient_gets_it_in_every_marcher() {
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([24, 24, 24], 0.45).expect("procedural volume");
        let tf = TransferFunction::TwoD {
            boxes: vec![vkengine::volume::optics::tf::TfBox {
                value: [0.05, 1.0],
                gradient: [0.05, 1.0],
                color: [0.9, 0.8, 1.0],
                extinction: 30.0,
            }],
        };
        for (renderer, precomputed_gradients) in [
            (RendererKind::Eam, true),
            (RendererKind::Eam, false),
            (RendererKind::EamBackToFront, false),
            (RendererKind::Lao, true),
            (RendererKind::Dos, true),
        ] {
            let s = RenderSettings { renderer, precomputed_gradients, ..Default::default() };
            let img = render(ctx, &vol, &tf, &ortho(1.2), s);
            let lit = img.iter().filter(|p| p[0] > 0.05).count();
            assert!(lit > 50, "{renderer:?} (precomputed {precomputed_gradients}): {lit} pixels lit");
        }
    });
}

#[test]
fn accumulation_is_the_mean_of_jittered_frames_and_resets_on_change() {
    common::gpu_test(|ctx| {
        let vol = procedural::smooth_sphere([16, 16, 16], 0.45).expect("procedural volume");
        let tf = TransferFunction::ramp(0.1, 0.8, [1.0, 0.6, 0.3], 12.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let cam = ortho(1.2);
        let s = RenderSettings { jitter: true, ..Default::default() };
        let frames = 4u64;
        // Each frame alone (fresh targets), averaged on the CPU.
        let mut mean = vec![[0.0f32; 4]; (SIZE[0] * SIZE[1]) as usize];
        for f in 0..frames {
            let mut t = Targets::new(ctx, SIZE).expect("targets");
            render_frame(ctx, &r, &mut t, &cam, &s, f).expect("render");
            for (m, x) in mean.iter_mut().zip(t.read_hdr(ctx).expect("readback")) {
                for i in 0..4 {
                    m[i] += x[i] / frames as f32;
                }
            }
        }
        let mut t = Targets::new(ctx, SIZE).expect("targets");
        for f in 0..frames {
            render_frame(ctx, &r, &mut t, &cam, &s, f).expect("render");
        }
        assert_eq!(t.samples, frames as u32);
        let acc = t.read_hdr(ctx).expect("readback");
        let d = max_diff(&acc, &mean);
        assert!(d < 1e-5, "progressive mean differs from the average by {d}");
        // Jitter made the frames differ, so the test compared something.
        let single = {
            let mut t1 = Targets::new(ctx, SIZE).expect("targets");
            render_frame(ctx, &r, &mut t1, &cam, &s, 0).expect("render");
            t1.read_hdr(ctx).expect("readback")
        };
        assert!(max_diff(&single, &acc) > 1e-4, "jitter had no effect");
        // A camera change restarts the mean.
        render_frame(ctx, &r, &mut t, &ortho(1.3), &s, frames).expect("render");
        assert_eq!(t.samples, 1);
    });
}

#[test]
fn the_marchers_declare_a_loop_bound_that_their_smallest_step_keeps_under_llvmpipes_limit() {
    common::gpu_test(|ctx| {
        // The step's range (≥ 1e-4 world units, the largest axis 1) bounds every camera ray at
        // ⌈√3 / 1e-4⌉ segments: the declared bound proves MIP, ISO and EAM cannot be truncated.
        let vol = procedural::smooth_sphere([16, 16, 16], 0.4).expect("volume");
        let tf = TransferFunction::ramp(0.2, 0.9, [1.0; 3], 5.0);
        let r = VolumeRenderer::new(ctx, &vol, &tf).expect("renderer");
        let cam = Camera::orbit(2.5, 0.6, 0.3, Projection::Perspective { fov_y: 0.7 });
        for renderer in [RendererKind::Mip, RendererKind::Iso, RendererKind::Eam, RendererKind::EamBackToFront] {
            let s = RenderSettings { renderer, step: Some(1e-4), ..Default::default() };
            let n = r.march_loop_iterations(&s);
            assert!((17_321..=17_340).contains(&n), "{renderer:?}: bound {n}");
            assert!(n < vkengine::graph::work::LLVMPIPE_LOOP_LIMIT);
            let mut t = Targets::new(ctx, [8, 8]).expect("targets");
            render_frame(ctx, &r, &mut t, &cam, &s, 0).expect("the executor accepts the declared bound");
        }
    });
}
