//! The sparse volume layout (`volume_layout=sparse`: 8³ bricks in an atlas behind a page table)
//! against the dense one, on lavapipe under validation: every renderer on the same volume, a
//! volume longer than the device's 3D-image limit against dense renders of its parts, the memory
//! a mostly empty volume takes, and corrupt bricks. Consistency checks (dense is the reference:
//! its renderers are tested against analytic answers elsewhere).

mod common;

use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::bricks::{Bricks, BRICK, SLOT_TEXELS};
use vkengine::volume::data::Volume;
use vkengine::volume::device::layout::{upload_bricks, VolumeLayout};
use vkengine::volume::optics::envmap::EnvMap;
use vkengine::volume::optics::tf::{TfPoint, TransferFunction};
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};

const SIZE: [u32; 2] = [40, 32];

fn render(ctx: &Context, r: &VolumeRenderer, cam: &Camera, s: &RenderSettings, size: [u32; 2]) -> Vec<[f32; 4]> {
    let mut t = Targets::new(ctx, size).expect("targets");
    render_frame(ctx, r, &mut t, cam, s, 0).expect("render");
    t.read_hdr(ctx).expect("readback")
}

fn max_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    a.iter().zip(b).flat_map(|(p, q)| (0..3).map(move |i| (p[i] - q[i]).abs())).fold(0.0, f32::max)
}

/// Largest difference between neighbouring voxels (normalized): how much a filtered value can
/// change per texel of position.
fn largest_step(v: &Volume) -> f32 {
    let n = v.normalized_u16();
    let [nx, ny, nz] = v.dims.map(|d| d as usize);
    let at = |x: usize, y: usize, z: usize| f32::from(n[(z * ny + y) * nx + x]) / 65535.0;
    let mut m = 0.0f32;
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let c = at(x, y, z);
                for (dx, dy, dz) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    if x + dx < nx && y + dy < ny && z + dz < nz {
                        m = m.max((at(x + dx, y + dy, z + dz) - c).abs());
                    }
                }
            }
        }
    }
    m
}

/// Each renderer and variant the sparse layout must serve, with the settings that select it.
fn cases() -> Vec<(&'static str, RenderSettings)> {
    let base = RenderSettings { empty_space_skipping: true, ..Default::default() };
    let mc =
        |budget, hybrid, env_map| McSettings { budget, hybrid, env_map, seed: 7, max_events: 8, ..Default::default() };
    let at = |renderer, m: McSettings| RenderSettings { renderer, mc: m, ..base };
    vec![
        ("mip", at(RendererKind::Mip, mc(0, 0.0, false))),
        ("iso", RenderSettings { iso: 0.3, ..at(RendererKind::Iso, mc(0, 0.0, false)) }),
        ("eam", at(RendererKind::Eam, mc(0, 0.0, false))),
        (
            "eam on-the-fly gradients",
            RenderSettings { precomputed_gradients: false, ..at(RendererKind::Eam, mc(0, 0.0, false)) },
        ),
        ("eam back to front", at(RendererKind::EamBackToFront, mc(0, 0.0, false))),
        ("lao", at(RendererKind::Lao, mc(0, 0.0, false))),
        ("dos", at(RendererKind::Dos, mc(0, 0.0, false))),
        ("mcs", at(RendererKind::Mcs, mc(0, 0.0, false))),
        ("mcm", at(RendererKind::Mcm, mc(0, 0.0, false))),
        ("mcm bounded", at(RendererKind::Mcm, mc(64, 0.0, false))),
        ("mcm ibl", at(RendererKind::Mcm, mc(0, 0.0, true))),
        ("mcm hybrid", at(RendererKind::Mcm, mc(0, 0.5, false))),
        ("mcm bounded ibl hybrid", at(RendererKind::Mcm, mc(64, 0.5, true))),
    ]
}

/// Blobs in empty space, dims not multiples of the brick (partial bricks on every axis): bricks
/// that vary, uniform ones sharing a slot, and edges.
fn blobs() -> Volume {
    // Centre and radius (voxels).
    blobs_in([44, 36, 41], &[[13.0, 12.0, 12.0, 11.0], [31.0, 24.0, 28.0, 12.0], [33.0, 8.0, 8.0, 6.0]])
}

/// `blobs` (centre and radius in voxels) in a `dims` box, with a ripple so bricks inside vary too.
fn blobs_in(dims: [u32; 3], blobs: &[[f32; 4]]) -> Volume {
    let mut data = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = [x, y, z].map(|c| c as f32 + 0.5);
                let ripple = 0.8 + 0.2 * (p[0] * 0.9).sin() * (p[1] * 0.7 + p[2] * 0.5).sin();
                let v = blobs
                    .iter()
                    .map(|b| (1.0 - ((0..3).map(|i| (p[i] - b[i]).powi(2)).sum::<f32>().sqrt() / b[3])).max(0.0))
                    .fold(0.0, f32::max);
                data.push(v * ripple);
            }
        }
    }
    Volume::new(dims, [1.0; 3], data, "blobs").expect("volume")
}

/// With exact filtering (texel fetches, f32 weights) the sparse layout reads the very texels the
/// dense one reads with the very weights, so every renderer whose lookups all go through
/// `sample_volume` must match bit for bit. The gradient-magnitude lookup (`sample_gradient`) is
/// hardware-filtered in both layouts (as before), at atlas coordinates that round differently;
/// this transfer function has no gradient axis (every row alike), so a renderer that reads it
/// (EAM with precomputed gradients, LAO, DOS; hybrid scattering's BRDF weight) can differ only by
/// the rounding of interpolating between equal rows, 2⁻²³ relative per lookup: over a ray of N
/// samples at most N · 2⁻²³ on values ≤ 1.
#[test]
fn every_renderer_matches_dense_bit_for_bit_with_exact_filtering() {
    common::gpu_test(|ctx| {
        let vol = blobs();
        let tf = TransferFunction::preset("cloud").expect("tf");
        let sky = EnvMap::procedural_sky(32, 16, [0.4, 0.8, 0.45]).expect("sky");
        let mut dense = VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Dense).expect("dense");
        let mut sparse = VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Sparse).expect("sparse");
        dense.set_environment(ctx, Some(&sky)).expect("env");
        sparse.set_environment(ctx, Some(&sky)).expect("env");
        assert_eq!(sparse.layout.layout, VolumeLayout::Sparse);
        assert!(sparse.layout.skipped_fraction > 0.1, "{:?}", sparse.layout);
        eprintln!("{:?}", sparse.layout);
        assert!(sparse.layout.stored_bricks > 10, "{:?}", sparse.layout);
        assert_every_renderer_matches((ctx, &dense), (ctx, &sparse), cases());
    });
}

/// Every case of `cases` with exact filtering, sparse against dense (each on its context): bit
/// for bit, or within N · 2⁻²³ where a renderer reads the gradient (above).
fn assert_every_renderer_matches(
    dense: (&Context, &VolumeRenderer),
    sparse: (&Context, &VolumeRenderer),
    cases: Vec<(&'static str, RenderSettings)>,
) {
    let cam = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 1.3 });
    assert_every_renderer_matches_from(&cam, dense, sparse, cases)
}

/// [`assert_every_renderer_matches`] seen from `cam`.
fn assert_every_renderer_matches_from(
    cam: &Camera,
    (dctx, dense): (&Context, &VolumeRenderer),
    (sctx, sparse): (&Context, &VolumeRenderer),
    cases: Vec<(&'static str, RenderSettings)>,
) {
    // Samples along the box's diagonal (largest axis 1) at the default half-voxel step.
    let samples = (3f32.sqrt() / dense.default_step()).ceil();
    let bound = samples / (1u32 << 23) as f32;
    for (name, s) in cases {
        let s = RenderSettings { exact_filter: true, ..s };
        let (a, b) = (render(dctx, dense, cam, &s, SIZE), render(sctx, sparse, cam, &s, SIZE));
        let lit = a.iter().filter(|p| p[..3].iter().any(|&c| c > 1e-3)).count();
        let d = max_diff(&a, &b);
        eprintln!("{name}: max |dense − sparse ({} atlases)| = {d:e} ({lit} lit pixels)", sparse.layout.atlases);
        assert!(lit > 50, "{name}: too few lit pixels to compare ({lit})");
        let reads_gradients = s.mc.hybrid > 0.0
            || matches!(s.renderer, RendererKind::Lao | RendererKind::Dos)
            || (s.renderer == RendererKind::Eam && s.precomputed_gradients);
        if reads_gradients {
            assert!(d <= bound, "{name}: sparse differs from dense by {d}, over {bound}");
        } else {
            assert_eq!(d, 0.0, "{name}: sparse differs from dense by {d}");
        }
    }
    assert_eq!(sparse.majorant_violations(), 0);
}

/// A two-level page table (directory of 8³-brick pages into a pool of pages) reads the very
/// words the flat one holds: forced on a box of 4 × 2 × 2 pages (partial ones along each axis)
/// whose blobs straddle page borders and leave whole pages empty (their directory entries share
/// a pool page), every renderer matches dense bit for bit with exact filtering, EAM's skipping
/// included (it reads occupancy from the words).
#[test]
fn a_two_level_page_table_renders_as_dense() {
    common::gpu_test(|ctx| {
        let vol =
            blobs_in([200, 72, 70], &[[100.0, 36.0, 36.0, 30.0], [140.0, 50.0, 30.0, 16.0], [80.0, 20.0, 50.0, 12.0]]);
        let tf = TransferFunction::preset("cloud").expect("tf");
        let mut dense = VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Dense).expect("dense");
        common::gpu_test_with(
            |o| o.page_levels = Some(2),
            |two| {
                let mut sparse = VolumeRenderer::with_layout(two, &vol, &tf, VolumeLayout::Sparse).expect("sparse");
                let l = sparse.layout;
                eprintln!("{l:?}");
                assert_eq!(l.page_levels, 2, "{l:?}");
                let all = cases().into_iter().filter(|(_, s)| !s.mc.env_map).collect();
                // The box is 1 × 0.36 × 0.35: closer, so the blobs fill the frame.
                let cam = Camera::orbit(2.5, 0.3, 0.3, Projection::Orthographic { height: 0.6 });
                assert_every_renderer_matches_from(&cam, (ctx, &dense), (two, &sparse), all);
                // A haze where the volume is 0: the empty pages' shared pool page is now the one
                // with the occupancy bit set, and EAM must not skip them.
                let point = |value, color, extinction| TfPoint { value, color, extinction };
                let haze = TransferFunction::OneD {
                    points: vec![
                        point(0.0, [0.6, 0.7, 0.9], 0.8),
                        point(0.3, [1.0; 3], 4.0),
                        point(1.0, [1.0, 0.8, 0.6], 10.0),
                    ],
                };
                dense.set_transfer_function(ctx, &haze).expect("tf");
                sparse.set_transfer_function(two, &haze).expect("tf");
                let eam = cases().into_iter().filter(|(n, _)| n.starts_with("eam")).collect();
                assert_every_renderer_matches_from(&cam, (ctx, &dense), (two, &sparse), eam);
            },
        );
    });
}

/// Bricks past the largest allocation fill several atlases (slot layers numbered on from one
/// atlas into the next): on a context that plans allocations of at most 64 KiB, the blobs' 86
/// slots (125 KiB per quantity) take several atlases (three on lavapipe, whose rows are padded),
/// and every renderer reads through them as the one-atlas test above does, bit for bit against
/// dense renders on an uncapped context.
#[test]
fn bricks_past_the_largest_allocation_fill_several_atlases_and_render_as_dense() {
    common::gpu_test(|ctx| {
        let vol = blobs();
        let tf = TransferFunction::preset("cloud").expect("tf");
        let dense = VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Dense).expect("dense");
        common::gpu_test_with(
            |o| o.max_allocation = Some(64 << 10),
            |capped| {
                let sparse = VolumeRenderer::with_layout(capped, &vol, &tf, VolumeLayout::Sparse).expect("sparse");
                eprintln!("{:?}", sparse.layout);
                assert!(sparse.layout.atlases > 1, "{:?}", sparse.layout);
                // The environment map is the one-atlas test's; it adds nothing here.
                let cases = cases().into_iter().filter(|(_, s)| !s.mc.env_map).collect();
                assert_every_renderer_matches((ctx, &dense), (capped, &sparse), cases);
                // Hardware filtering reads the further atlases through their own lookup.
                assert_hardware_filtering_within_rounding(&vol, (ctx, &dense), (capped, &sparse));
            },
        );
    });
}

/// Hardware filtering: the sparse lookup hands the texture unit an atlas coordinate computed in
/// f32 (the point, plus its slot's origin, divided by the atlas size, which the unit multiplies
/// back), so the filter position moves by at most a few roundings at the atlas's (or volume's)
/// scale: |δx| ≤ 4 · 2⁻²³ · max(atlas, volume extent) texels (four half-ulps, doubled). A value
/// then moves by at most |δx| times the largest neighbour difference Δ. MIP's output is a
/// maximum of values: |δ| ≤ |δx| Δ. EAM's, with this ramp (constant colour, extinction slope
/// S = 8 / 0.65 per unit value): each sample's opacity moves by at most S · step · |δv| and the
/// colour sum by at most 2 S |δv| over the ray's length (≤ √3): |δ| ≤ 2√3 S |δx| Δ.
#[test]
fn hardware_filtering_stays_within_the_rounding_of_atlas_coordinates() {
    common::gpu_test(|ctx| {
        let vol = blobs();
        let tf = TransferFunction::preset("cloud").expect("tf");
        let dense = VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Dense).expect("dense");
        let sparse = VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Sparse).expect("sparse");
        let cam = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 1.3 });
        assert_hardware_filtering_within_rounding(&vol, (ctx, &dense), (ctx, &sparse));
        // The majorant grid (the bricks' dilated value ranges) bounds every extinction the
        // hardware-filtered sparse lookups return: the tracking shaders count any sample above it.
        let mc = McSettings { budget: 64, seed: 3, max_events: 8, ..Default::default() };
        for renderer in [RendererKind::Mcs, RendererKind::Mcm] {
            render(ctx, &sparse, &cam, &RenderSettings { renderer, mc, ..Default::default() }, SIZE);
        }
        assert_eq!(sparse.majorant_violations(), 0, "the sparse layout's majorant grid is exceeded");
    });
}

/// MIP and EAM of `vol` hardware-filtered, sparse against dense (each on its context), within the
/// bound above from the atlas-coordinate rounding. A texture unit with fixed-point weights (a
/// step q = 2^-subTexelPrecisionBits; 0 on llvmpipe, which filters in f32) may round the two
/// positions' weights to neighbouring steps along each axis, and either weight pair may sum to
/// 1 ± q: a value then moves by up to 3q(Δ + 2) more (values ≤ 1).
fn assert_hardware_filtering_within_rounding(
    vol: &Volume,
    (dctx, dense): (&Context, &VolumeRenderer),
    (sctx, sparse): (&Context, &VolumeRenderer),
) {
    let extent = sparse.layout.image_texels.into_iter().chain(vol.dims).max().unwrap_or(0) as f32;
    let dx = 4.0 * extent / (1u32 << 23) as f32;
    let delta = largest_step(vol);
    let dv = dx * delta + 3.0 * common::quantized_filter_step(sctx) * (delta + 2.0);
    let cam = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 1.3 });
    for (name, s, bound) in
        [("mip", RendererKind::Mip, dv), ("eam", RendererKind::Eam, 2.0 * 3f32.sqrt() * (8.0 / 0.65) * dv)]
    {
        let s = RenderSettings { renderer: s, ..Default::default() };
        let (a, b) = (render(dctx, dense, &cam, &s, SIZE), render(sctx, sparse, &cam, &s, SIZE));
        let d = max_diff(&a, &b);
        eprintln!("{name}: max |dense − sparse| = {d:e}, bound {bound:e} (|δx| ≤ {dx:e} texels, Δ = {delta})");
        assert!(d <= bound, "{name}: sparse differs from dense by {d}, over {bound}");
    }
}

/// 64 × 64 × 5000: past lavapipe's 3D-image limit (4096) along z, so `auto` stores it in bricks.
/// Orthographic MIP along x over windows of 64 slices in z, against dense renders of crops that
/// hold each window and 16 slices either side (so the crop's edges, clamped, are never sampled).
/// Every slice holds the values 0 and 1, so each crop normalizes exactly as the whole volume.
/// Same rays in voxel units: the camera's height and target scale by the volumes' longest axes;
/// positions then round at the whole volume's scale (0.5 world units = 2500 voxels): |δx| ≤
/// 4 · 2⁻²⁴ · 5000 texels, and with the atlas's rounding as above.
#[test]
fn a_volume_past_the_3d_image_limit_renders_and_matches_dense_crops() {
    // 16 × 16 × 33,000 also passes 8 × lavapipe's limit: its 4,125 bricks along z are more than
    // one flat page-table image holds, so its table takes two levels.
    common::gpu_test(|ctx| {
        for (n, len, step) in [(64u32, 5000u32, 0.5f32), (16, 33000, 4.0)] {
            past_the_limit_matches_dense_crops(ctx, n, len, step);
        }
    });
}

/// The test above for an `n` × `n` × `len` volume, MIP `step` voxels a sample.
fn past_the_limit_matches_dense_crops(ctx: &Context, n: u32, len: u32, step: f32) {
    {
        let max3d = ctx.info.limits.max_image_dimension3_d;
        if len <= max3d {
            eprintln!("skipped: this device's 3D-image limit {max3d} holds {len}");
            return;
        }
        // Smooth (period ≥ 11 voxels) so Δ is small and the bound tight; 0 and 1 in every slice.
        let value = |x: u32, y: u32, z: u32| -> f32 {
            if x == 0 && y == 0 {
                return 0.0;
            }
            if x == n - 1 && y == n - 1 {
                return 1.0;
            }
            let f = |v: u32, p: f32| (v as f32 * std::f32::consts::TAU / p).sin();
            (0.5 + 0.2 * f(x, 17.0) * f(y, 13.0) + 0.25 * f(z, 11.0) * f(x + y, 23.0)).clamp(0.0, 1.0)
        };
        let make = |z0: u32, depth: u32| {
            let mut data = Vec::with_capacity((n * n * depth) as usize);
            for z in z0..z0 + depth {
                for y in 0..n {
                    for x in 0..n {
                        data.push(value(x, y, z));
                    }
                }
            }
            Volume::new([n, n, depth], [1.0; 3], data, format!("test z {z0}..{}", z0 + depth)).expect("volume")
        };
        let whole = make(0, len);
        let tf = TransferFunction::preset("cloud").expect("tf");
        let big = VolumeRenderer::new(ctx, &whole, &tf).expect("renders past the 3D-image limit");
        assert_eq!(big.layout.layout, VolumeLayout::Sparse, "{:?}", big.layout);
        eprintln!("{:?}", big.layout);
        let size = [32, 32];
        // `step` voxels a sample in both volumes (world units: the longest axis is 1); 4 keeps a
        // ray along 33,000 voxels within llvmpipe's 65,535 iterations (and the setting's 1e-4).
        let mip = |longest: u32| RenderSettings {
            renderer: RendererKind::Mip,
            step: Some(step / longest as f32),
            ..Default::default()
        };
        // Yaw π/2 looks along −x: the image's x runs along −z, its y along +y.
        let cam = |target_z: f32, height: f32| Camera {
            rig: vkengine::volume::camera::Rig::Orbit {
                target: glam::Vec3::new(0.0, 0.0, target_z),
                distance: 2.0,
                yaw: std::f32::consts::FRAC_PI_2,
                pitch: 0.0,
            },
            ..Camera::orbit(2.0, 0.0, 0.0, Projection::Orthographic { height })
        };
        let dx = 4.0 * len as f32 / (1u32 << 24) as f32
            + 4.0 * big.layout.image_texels.into_iter().max().unwrap_or(0) as f32 / (1u32 << 23) as f32;
        let delta = largest_step(&whole);
        let bound = dx * delta;
        for z0 in [0u32, 2040, 4096 - 48, len - 96] {
            let crop = make(z0, 96);
            let dense = VolumeRenderer::with_layout(ctx, &crop, &tf, VolumeLayout::Dense).expect("dense crop");
            // The window's centre, z0 + 48, in each volume's world units (longest axis = 1).
            let a = render(ctx, &dense, &cam(0.0, n as f32 / 96.0), &mip(96), size);
            let centre = (z0 as f32 + 48.0 - len as f32 / 2.0) / len as f32;
            let b = render(ctx, &big, &cam(centre, n as f32 / len as f32), &mip(len), size);
            let d = max_diff(&a, &b);
            eprintln!("crop z {z0}..{}: max |dense crop − sparse whole| = {d:e}, bound {bound:e}", z0 + 96);
            assert!(a.iter().any(|p| p[0] > 0.6), "crop {z0}: nothing bright to compare");
            assert!(d <= bound, "crop z {z0}: sparse whole differs from the dense crop by {d}, over {bound}");
        }
        // Tracking through the whole length stays under the majorant grid.
        let mc = McSettings { budget: 64, seed: 3, max_events: 4, ..Default::default() };
        render(
            ctx,
            &big,
            &cam(0.0, 1.0),
            &RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() },
            size,
        );
        assert_eq!(big.majorant_violations(), 0, "the sparse layout's majorant grid is exceeded");
    }
}

/// A few blobs in a large, mostly empty box: the device holds little more than the bricks that
/// vary. Each stored brick takes a 9³ slot (its 8³ voxels and the apron) of value and of
/// gradient: 729/512 = 1.42 × its voxels' bytes, plus a 4-byte page-table entry per brick of
/// the box and the shared uniform slots; the report must show at most 1.5 × the stored bricks'
/// dense bytes.
#[test]
fn a_mostly_empty_volume_stores_little_more_than_its_occupied_bricks() {
    common::gpu_test(|ctx| {
        // 256³ with three blobs of radius 34 voxels: 3 % of the voxels vary.
        let n = 256u32;
        let centres = [[60.0f32, 70.0, 50.0], [190.0, 160.0, 140.0], [100.0, 200.0, 210.0]];
        let mut data = Vec::with_capacity((n * n * n) as usize);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = [x, y, z].map(|c| c as f32 + 0.5);
                    let v = centres
                        .iter()
                        .map(|c| {
                            let r = (0..3).map(|i| (p[i] - c[i]).powi(2)).sum::<f32>().sqrt();
                            (1.0 - r / 34.0).max(0.0)
                        })
                        .fold(0.0, f32::max);
                    data.push(v);
                }
            }
        }
        let vol = Volume::new([n; 3], [1.0; 3], data, "three blobs").expect("volume");
        let tf = TransferFunction::preset("cloud").expect("tf");
        let r = VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Sparse).expect("sparse");
        let l = r.layout;
        let brick_bytes = 2 * 2 * u64::from(BRICK).pow(3);
        let occupied = l.stored_bricks * brick_bytes;
        let ratio = l.gpu_bytes as f64 / occupied as f64;
        eprintln!(
            "{l:?}: {ratio:.3} × the stored bricks' {occupied} bytes; dense {} bytes ({:.1} %)",
            l.dense_bytes,
            100.0 * l.gpu_bytes as f64 / l.dense_bytes as f64
        );
        assert!(l.skipped_fraction > 0.9, "{l:?}");
        assert!(ratio <= 1.5, "GPU bytes {} are {ratio} × the stored bricks' {occupied}", l.gpu_bytes);
    });
}

/// A page table pointing past the stored slots, or brick data cut short, is refused with one
/// error naming the source and the problem, before anything is uploaded.
#[test]
fn corrupt_bricks_are_one_clear_error() {
    common::gpu_test(|ctx| {
        let vol = blobs();
        let values = vol.normalized_u16();
        let grads = vkengine::volume::data::stats::gradient_magnitudes(&values, vol.dims);
        let good = Bricks::build(&values, &grads, vol.dims).expect("bricks");
        assert!(upload_bricks(ctx, &good, "blobs").is_ok());
        let mut pointer = good.clone();
        let last = pointer.slot_of.brick(pointer.slot_of.len() - 1);
        pointer.slot_of.set(last, good.slots() + 5).expect("set");
        let mut truncated = good.clone();
        truncated.gradients.truncate(truncated.gradients.len() - SLOT_TEXELS / 2);
        for (what, b, expect) in [("pointer", pointer, "past the"), ("truncated", truncated, "truncated")] {
            match upload_bricks(ctx, &b, "corrupt.vdb") {
                Ok(_) => panic!("{what}: corrupt bricks accepted"),
                Err(e) => {
                    let msg = e.to_string();
                    eprintln!("{what}: {msg}");
                    assert!(
                        msg.contains("corrupt.vdb") && msg.contains(expect) && !msg.contains('\n'),
                        "{what}: {msg}"
                    );
                }
            }
        }
    });
}
