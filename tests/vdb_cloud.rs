//! A sparse cloud written by OpenVDB's own Python module (tools/make_vdb_sparse_cloud.py, run
//! at test time with /usr/bin/python3 and Debian's python3-openvdb, which tools/setup.sh
//! installs): a box past 1,024 voxels on every axis with under 1 % of them active, loaded leaf
//! by leaf (never densified), stored in bricks and rendered; against the dense load of a crop
//! of the same puffs that OpenVDB writes alongside.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection, Rig};
use vkengine::volume::data::bricks::SLOT_TEXELS;
use vkengine::volume::data::{load, LoadOptions, Volume};
use vkengine::volume::device::layout::VolumeLayout;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};

fn render(ctx: &Context, r: &VolumeRenderer, cam: &Camera, s: &RenderSettings, size: [u32; 2]) -> Vec<[f32; 4]> {
    let mut t = Targets::new(ctx, size).expect("targets");
    render_frame(ctx, r, &mut t, cam, s, 0).expect("render");
    t.read_hdr(ctx).expect("readback")
}

fn lit(img: &[[f32; 4]]) -> usize {
    img.iter().filter(|p| p[..3].iter().any(|&c| c > 1e-3)).count()
}

/// What the script wrote: (whole cloud, crop), and per file the active bounding box (lower,
/// upper voxel, inclusive) and active voxel count as OpenVDB reports them.
struct Cloud {
    dir: PathBuf,
    whole: PathBuf,
    crop: PathBuf,
    info: serde_json::Value,
}

impl Cloud {
    fn bbox(&self, which: &str) -> ([i64; 3], [u32; 3]) {
        let v = |k: &str, a: usize| self.info[which][k][a].as_i64().expect("bbox from the script");
        let lo = [0, 1, 2].map(|a| v("lo", a));
        (lo, [0, 1, 2].map(|a| (v("hi", a) - lo[a] + 1) as u32))
    }

    fn active(&self, which: &str) -> u64 {
        self.info[which]["active"].as_u64().expect("active count from the script")
    }
}

impl Drop for Cloud {
    fn drop(&mut self) {
        std::fs::remove_dir_all(&self.dir).ok();
    }
}

/// Writes the cloud with OpenVDB's Python module, or (None) skips where pyopenvdb is missing —
/// a failure under CI or `VKENGINE_VALIDATION=required`, where tools/setup.sh installs it.
fn cloud(tag: &str) -> Option<Cloud> {
    let python = common::openvdb_python()?;
    let dir = std::env::temp_dir().join(format!("vkengine_vdb_cloud_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let (whole, crop) = (dir.join("cloud.vdb"), dir.join("column.vdb"));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/make_vdb_sparse_cloud.py");
    let out = Command::new(python).arg(script).arg(&whole).arg(&crop).output().expect("run the script");
    assert!(out.status.success(), "make_vdb_sparse_cloud.py: {}", String::from_utf8_lossy(&out.stderr));
    let info = serde_json::from_slice(&out.stdout).expect("the script's JSON line");
    Some(Cloud { dir, whole, crop, info })
}

fn load_whole(ctx: &Context, c: &Cloud) -> Volume {
    let max3d = ctx.info.limits.max_image_dimension3_d;
    let v = load(&c.whole, &LoadOptions { max_dimension: max3d, ..LoadOptions::default() }).expect("load");
    let (_, dims) = c.bbox("whole");
    assert_eq!(v.dims, dims, "the loaded box is not OpenVDB's active bounding box");
    assert!(v.dims.iter().all(|&d| d >= 1024), "{:?}: not past 1,024 voxels on every axis", v.dims);
    let voxels = v.dims.iter().map(|&d| d as f64).product::<f64>();
    let active = c.active("whole") as f64 / voxels;
    assert!(active <= 0.03, "{:.2} % of the box is active, over 3 %", 100.0 * active);
    assert!(v.sparse_only().is_some() && v.data.is_empty(), "the cloud was densified");
    v
}

/// The cloud loads sparse and the device holds at most 1.5 × its stored bricks: GPU bytes are
/// everything allocated for the volume (value and gradient atlases, page table, occupancy and
/// majorant grids); a stored brick's bytes are its value and gradient slots (9³ texels of 16
/// bits each: 2,916 bytes, 1.42 × its 8³ voxels', the apron included). Shared uniform slots
/// are not counted as stored. Every renderer draws it; tracking stays under the (coarsened)
/// majorant grid.
#[test]
fn an_openvdb_cloud_past_1024_cubed_takes_at_most_1_5_times_its_stored_bricks() {
    common::gpu_test(|ctx| {
        let Some(c) = cloud("bytes") else { return };
        let v = load_whole(ctx, &c);
        let tf = TransferFunction::preset("cloud").expect("tf");
        let r = VolumeRenderer::new(ctx, &v, &tf).expect("renderer");
        let l = r.layout;
        assert_eq!(l.layout, VolumeLayout::Sparse, "{l:?}");
        let stored = l.stored_bricks * 2 * 2 * SLOT_TEXELS as u64;
        let total = l.gpu_bytes + l.grid_bytes;
        let ratio = total as f64 / stored as f64;
        eprintln!(
            "{:?} box, {} active voxels: {l:?}\nGPU {total} bytes ({} images and page table, {} grids) = {ratio:.3} × the stored bricks' {stored} bytes; dense {} bytes",
            v.dims,
            c.active("whole"),
            l.gpu_bytes,
            l.grid_bytes,
            l.dense_bytes
        );
        assert!(ratio <= 1.5, "GPU bytes {total} are {ratio:.3} × the stored bricks' {stored}");
        let cam = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 1.3 });
        let mc = McSettings { budget: 16, seed: 5, max_events: 4, ..Default::default() };
        for renderer in [RendererKind::Mip, RendererKind::Eam, RendererKind::Mcm] {
            let s = RenderSettings { renderer, mc, empty_space_skipping: true, ..Default::default() };
            let n = lit(&render(ctx, &r, &cam, &s, [64, 64]));
            assert!(n >= 40, "{}: the puffs are not drawn ({n} lit pixels)", renderer.name());
        }
        assert_eq!(r.majorant_violations(), 0, "tracking exceeded the coarsened majorant grid");
        // EAM skips a brick whose page word says its grid cell (4³ bricks here) is empty and
        // keeps its sampling phase, so with exact filtering skipping changes nothing where the
        // skipped bricks are truly empty: bit for bit against EAM without skipping.
        assert!(l.grid_cell > 8, "{l:?}: the grids should merge bricks here");
        let cam = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 0.6 });
        let eam = |skip| RenderSettings {
            renderer: RendererKind::Eam,
            empty_space_skipping: skip,
            exact_filter: true,
            precomputed_gradients: false,
            ..Default::default()
        };
        let (a, b) = (render(ctx, &r, &cam, &eam(false), [96, 96]), render(ctx, &r, &cam, &eam(true), [96, 96]));
        assert!(lit(&a) >= 200, "EAM: too few lit pixels to compare ({})", lit(&a));
        assert!(a == b, "EAM with empty-space skipping differs from EAM without: a skipped brick was not empty");
    });
}

/// Largest difference between neighbouring voxels (normalized) of a dense volume: how much a
/// filtered value can change per voxel of position along one axis.
fn largest_step(v: &Volume) -> f32 {
    let n = v.normalized_u16();
    let [nx, ny, nz] = v.dims.map(|d| d as usize);
    let at = |i: usize| f32::from(n[i]) / 65535.0;
    let mut m = 0.0f32;
    for (i, _) in n.iter().enumerate() {
        let (x, y, z) = (i % nx, i / nx % ny, i / (nx * ny));
        for (d, ok) in [(1, x + 1 < nx), (nx, y + 1 < ny), (nx * ny, z + 1 < nz)] {
            if ok {
                m = m.max((at(i + d) - at(i)).abs());
            }
        }
    }
    m
}

/// The crop holds the column of puffs that spans the whole box along x, at the same voxel
/// positions: its dense load renders as the whole cloud's sparse one where the rays see the
/// same voxels. Orthographic MIP with exact filtering along −x, one pixel per voxel over the
/// crop's y–z window less one voxel at each side (there the crop's clamped edge and the whole
/// cloud's next voxels differ). Both boxes span the same x range and their longest axis is x,
/// so a ray meets the same voxels at the same steps; only its y–z position is computed
/// through a different camera target, so positions agree within rounding: 8 ulps of world
/// coordinates below 4 (2⁻²¹ each) on each axis, × 1,024+ voxels per world unit, × the largest
/// neighbour difference Δ per voxel on each of 3 axes. Also: the crop loaded sparse (its box
/// forced above `stream_above`) renders as its dense load bit for bit with exact filtering
/// (MIP, ISO, EAM, MCM with one seed).
#[test]
fn the_sparse_cloud_renders_as_the_dense_load_of_a_crop() {
    common::gpu_test(|ctx| {
        let Some(c) = cloud("crop") else { return };
        let whole = load_whole(ctx, &c);
        let tf = TransferFunction::preset("cloud").expect("tf");
        let big = VolumeRenderer::new(ctx, &whole, &tf).expect("renderer");
        assert_eq!(big.layout.layout, VolumeLayout::Sparse);
        let crop = load(&c.crop, &LoadOptions::default()).expect("crop");
        let (clo, cdims) = c.bbox("crop");
        let (wlo, wdims) = c.bbox("whole");
        assert_eq!(crop.dims, cdims);
        assert!(crop.sparse_only().is_none(), "the crop should load dense");
        assert_eq!((clo[0], cdims[0]), (wlo[0], wdims[0]), "the crop does not span the box along x");
        let longest = |d: [u32; 3]| d.into_iter().max().unwrap_or(1);
        assert!(longest(wdims) == wdims[0] && longest(cdims) == cdims[0], "x is not the longest axis");
        assert_eq!(crop.value_range, whole.value_range, "the crop normalizes differently");
        let dense = VolumeRenderer::with_layout(ctx, &crop, &tf, VolumeLayout::Dense).expect("dense crop");
        // Yaw π/2 looks along −x: the image's x runs along −z, its y along +y.
        let cam = |target: glam::Vec3, height: f32| Camera {
            rig: Rig::Orbit { target, distance: 2.0, yaw: std::f32::consts::FRAC_PI_2, pitch: 0.0 },
            ..Camera::orbit(2.0, 0.0, 0.0, Projection::Orthographic { height })
        };
        let scale = 1.0 / cdims[0] as f32;
        let size = [cdims[2] - 2, cdims[1] - 2];
        let height = size[1] as f32 * scale;
        // The crop's centre in the whole box's world units (voxel centre offsets, longest axis 1).
        let centre = |a: usize| ((clo[a] - wlo[a]) as f32 + cdims[a] as f32 / 2.0 - wdims[a] as f32 / 2.0) * scale;
        let s = RenderSettings { renderer: RendererKind::Mip, exact_filter: true, ..Default::default() };
        let a = render(ctx, &dense, &cam(glam::Vec3::ZERO, height), &s, size);
        let b = render(ctx, &big, &cam(glam::Vec3::new(0.0, centre(1), centre(2)), height), &s, size);
        let d = a.iter().zip(&b).flat_map(|(p, q)| (0..3).map(move |i| (p[i] - q[i]).abs())).fold(0.0, f32::max);
        let delta = largest_step(&crop);
        let bound = 3.0 * 8.0 * (2.0f32).powi(-21) * cdims[0] as f32 * delta;
        let same = a.iter().zip(&b).filter(|(p, q)| p == q).count();
        eprintln!(
            "max |dense crop − sparse whole| = {d:e} (bound {bound:e}, Δ {delta}); {same} of {} pixels bit for bit",
            a.len()
        );
        assert!(lit(&a) * 2 >= a.len(), "the crop's window is mostly empty ({} lit)", lit(&a));
        assert!(d <= bound, "the sparse cloud differs from the dense crop by {d}, over {bound}");

        // The crop through both layouts, one box: bit for bit.
        let sparse = load(&c.crop, &LoadOptions { stream_above: 0, ..LoadOptions::default() }).expect("sparse crop");
        assert!(sparse.sparse_only().is_some(), "not loaded sparse");
        let s_r = VolumeRenderer::with_layout(ctx, &sparse, &tf, VolumeLayout::Sparse).expect("sparse crop");
        let base = RenderSettings { empty_space_skipping: true, exact_filter: true, ..Default::default() };
        let mc = McSettings { seed: 7, max_events: 8, ..Default::default() };
        let view = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 0.5 });
        for (name, settings) in [
            ("mip", RenderSettings { renderer: RendererKind::Mip, ..base }),
            ("iso", RenderSettings { renderer: RendererKind::Iso, iso: 0.1, ..base }),
            ("eam", RenderSettings { renderer: RendererKind::Eam, precomputed_gradients: false, ..base }),
            ("mcm", RenderSettings { renderer: RendererKind::Mcm, mc, ..base }),
        ] {
            let (p, q) =
                (render(ctx, &dense, &view, &settings, [48, 48]), render(ctx, &s_r, &view, &settings, [48, 48]));
            assert!(lit(&p) >= 40, "{name}: too few lit pixels to compare ({})", lit(&p));
            assert!(p == q, "{name}: the crop loaded sparse renders differently from its dense load");
        }
    });
}
