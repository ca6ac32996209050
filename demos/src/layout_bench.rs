//! Dense against sparse volume layout (`volume_bench --layout`): GPU ms per frame of the same
//! renderer on the same volume in both layouts, frames interleaved (dense, sparse, then sparse,
//! dense, …) so drift in the machine's load falls on both, medians and their ratio, and the
//! largest difference of the two images (equal output). Writes `layout.csv`. With a VDB file
//! (`--layout-vdb`), empty-space skipping on that sparse cloud against its dense bounding box
//! instead (`layout_cloud.csv`, [`run_cloud`]).

use std::fmt::Write as _;
use std::path::Path;
use vkengine::settings::{Origin, Setting};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{load, procedural, LoadOptions, Volume};
use vkengine::volume::device::layout::VolumeLayout;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};
use vkengine::volume::render::settings::VolumeSetup;

type BenchResult<T> = Result<T, Box<dyn std::error::Error>>;

/// A CT-like n³ volume: an elliptic body of soft tissue with a bone shell and a spine in air,
/// with noise everywhere (as a scanner's), so every brick varies: the sparse layout's worst case.
pub fn ct_like(n: u32) -> BenchResult<Volume> {
    let mut data = Vec::with_capacity((n as usize).pow(3));
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let h = x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663) ^ z.wrapping_mul(83_492_791);
                let noise = (h % 1000) as f32 / 1000.0 * 0.03;
                let v = [0.0, 0.35, 0.8, 0.9][usize::from(ct_like_region(x, y, n))];
                data.push(v + noise);
            }
        }
    }
    Ok(Volume::new([n; 3], [1.0; 3], data, format!("ct-like {n}^3"))?)
}

/// The region of [`ct_like`] at voxel column (`x`, `y`) of `n`: 0 air, 1 soft tissue, 2 the bone
/// shell, 3 the spine.
pub fn ct_like_region(x: u32, y: u32, n: u32) -> u8 {
    let [px, py] = [x, y].map(|c| (c as f32 + 0.5) / n as f32 * 2.0 - 1.0);
    let r = (px / 0.8).powi(2) + (py / 0.6).powi(2);
    let spine = px * px + (py + 0.3).powi(2) < 0.01;
    match r {
        _ if spine => 3,
        r if r < 0.8 => 1,
        r if r < 1.0 => 2,
        _ => 0,
    }
}

/// One scene of the comparison: its volume, table, camera and the renderers timed on it.
struct Scene {
    name: &'static str,
    volume: Volume,
    tf: TransferFunction,
    camera: Camera,
    variants: Vec<(&'static str, RenderSettings)>,
}

/// Times each renderer on the default cloud, vpt's scene (its MCM settings, when `vpt_volume`
/// exists) and the CT-like volume in both layouts; `only` keeps the renderers it names.
pub fn run(
    ctx: &Context,
    out: &Path,
    n: u32,
    size: u32,
    frames: u64,
    vpt_volume: &Path,
    only: &[String],
) -> BenchResult<()> {
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    let mc = McSettings { budget: 256, seed: 1, ..Default::default() };
    let variants = vec![
        ("mip", RenderSettings { renderer: RendererKind::Mip, ..Default::default() }),
        ("eam", RenderSettings::default()),
        ("lao", RenderSettings { renderer: RendererKind::Lao, ..Default::default() }),
        ("mcm", RenderSettings { renderer: RendererKind::Mcm, mc, ..Default::default() }),
    ];
    let mut scenes = vec![Scene {
        name: "cloud",
        volume: procedural::cloud([n; 3], 0)?,
        tf: TransferFunction::preset("cloud")?,
        camera: cam,
        variants: variants.clone(),
    }];
    if vpt_volume.is_file() {
        let (volume, tf) = crate::vpt_peer::vpt_scene(vpt_volume)?;
        let settings: Vec<Setting> =
            crate::vpt_peer::VPT_SETTINGS.iter().map(|(k, v)| Setting::new(*k, v.to_string(), Origin::Cli)).collect();
        let setup = VolumeSetup::parse(&settings)?;
        let box_half = VolumeRenderer::new(ctx, &volume, &tf)?.box_half();
        let camera = crate::volume_scene::camera(&setup, &volume, box_half, 1.0);
        scenes.push(Scene { name: "vpt", volume, tf, camera, variants: vec![("mcm", setup.render)] });
    } else {
        println!("{}: not found, vpt's scene skipped", vpt_volume.display());
    }
    scenes.push(Scene {
        name: "ct-like",
        volume: ct_like(n)?,
        tf: TransferFunction::preset("bone")?,
        camera: cam,
        variants,
    });
    let mut csv = format!(
        "# device: {} ({}); volume {n}^3 (vpt: its 128^3 cloud), image {size}^2, {frames} frames per layout interleaved, GPU ms medians\nscene,renderer,stored_bricks,bricks,skipped_fraction,dense_gpu_bytes,sparse_gpu_bytes,dense_ms,sparse_ms,ratio,max_abs_diff\n",
        ctx.info.name, ctx.info.driver
    );
    for Scene { name: scene, volume: vol, tf, camera: cam, variants } in &scenes {
        let variants = variants.iter().filter(|(name, _)| only.is_empty() || only.iter().any(|o| o == name));
        let dense = VolumeRenderer::with_layout(ctx, vol, tf, VolumeLayout::Dense)?;
        let sparse = VolumeRenderer::with_layout(ctx, vol, tf, VolumeLayout::Sparse)?;
        let l = sparse.layout;
        for (name, s) in variants {
            let (ms, t) = time_interleaved(ctx, &[(&dense, s), (&sparse, s)], cam, size, frames)?;
            let (d, sp) = (ms[0], ms[1]);
            let diff = max_abs_diff(&t[0].read_hdr(ctx)?, &t[1].read_hdr(ctx)?);
            println!(
                "{scene:<8} {name:<4} dense {d:>9.2} ms  sparse {sp:>9.2} ms  ratio {:.3}  max |Δ| {diff:.2e}  ({} of {} bricks stored)",
                sp / d,
                l.stored_bricks,
                l.bricks
            );
            writeln!(
                csv,
                "{scene},{name},{},{},{:.4},{},{},{d:.3},{sp:.3},{:.4},{diff:.3e}",
                l.stored_bricks,
                l.bricks,
                l.skipped_fraction,
                dense.layout.gpu_bytes,
                l.gpu_bytes,
                sp / d
            )?;
        }
    }
    std::fs::create_dir_all(out)?;
    let path = out.join("layout.csv");
    std::fs::write(&path, csv)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Empty-space skipping on a sparse cloud (`path`, loaded without a dense copy) against its
/// dense bounding box: EAM with and without the occupancy grid and MCM (one path per pixel and
/// frame) with the majorant grid and with one global majorant, each in the dense and the sparse layout, all four variants of
/// a renderer interleaved frame by frame (the order rotating). GPU ms medians, device bytes
/// (images, page table, occupancy and majorant grids), the ratio to the dense box without
/// skipping, and the largest image difference to it. Writes `layout_cloud.csv`.
pub fn run_cloud(ctx: &Context, out: &Path, path: &Path, size: u32, frames: u64) -> BenchResult<()> {
    let max3d = ctx.info.limits.max_image_dimension3_d;
    let vol = load(path, &LoadOptions { max_dimension: max3d, ..LoadOptions::default() })?;
    let tf = TransferFunction::preset("cloud")?;
    let layouts = [
        ("dense", VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Dense)?),
        ("sparse", VolumeRenderer::with_layout(ctx, &vol, &tf, VolumeLayout::Sparse)?),
    ];
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    // One whole path per pixel a frame (`mc_budget=0`): time per frame is the cost of a path.
    let mc = |grid, density_scale| McSettings {
        budget: 0,
        seed: 1,
        majorant_grid: grid,
        density_scale,
        ..Default::default()
    };
    let eam = |skip| RenderSettings { empty_space_skipping: skip, ..Default::default() };
    let mcm = |grid, d| RenderSettings { renderer: RendererKind::Mcm, mc: mc(grid, d), ..Default::default() };
    // The cloud as the preset makes it, and 4 × denser (where null collisions under one global
    // majorant cost more than walking the grid's cells).
    let renderers = [
        ("eam", [eam(false), eam(true)]),
        ("mcm", [mcm(false, 1.0), mcm(true, 1.0)]),
        ("mcm-density4", [mcm(false, 4.0), mcm(true, 4.0)]),
    ];
    let [nx, ny, nz] = vol.dims;
    let mut csv = format!(
        "# device: {} ({}); {} ({nx}x{ny}x{nz}), image {size}^2, {frames} frames per variant interleaved, GPU ms medians, MCM one path per pixel a frame; bytes: images, page table, occupancy and majorant grids\nrenderer,layout,skipping,gpu_bytes,stored_bricks,bricks,grid_cell,gpu_ms,ratio_to_dense_unskipped,max_abs_diff\n",
        ctx.info.name,
        ctx.info.driver,
        path.display()
    );
    for (name, settings) in &renderers {
        // Variant v: layout v / 2, skipping v % 2.
        let variants: Vec<_> = (0..4).map(|v| (&layouts[v / 2].1, &settings[v % 2])).collect();
        let (medians, t) = time_interleaved(ctx, &variants, &cam, size, frames)?;
        let base = t[0].read_hdr(ctx)?;
        for (v, target) in t.iter().enumerate() {
            let diff = max_abs_diff(&base, &target.read_hdr(ctx)?);
            let (layout, r) = (&layouts[v / 2].0, &layouts[v / 2].1);
            let l = r.layout;
            let skip = v % 2 == 1;
            println!(
                "{name} {layout:<6} skipping {skip:<5} {:>9.2} ms  ratio {:.3}  {} bytes  max |Δ| {diff:.2e}",
                medians[v],
                medians[v] / medians[0],
                l.gpu_bytes + l.grid_bytes
            );
            writeln!(
                csv,
                "{name},{layout},{skip},{},{},{},{},{:.3},{:.4},{diff:.3e}",
                l.gpu_bytes + l.grid_bytes,
                l.stored_bricks,
                l.bricks,
                l.grid_cell,
                medians[v],
                medians[v] / medians[0]
            )?;
        }
    }
    std::fs::create_dir_all(out)?;
    let path = out.join("layout_cloud.csv");
    std::fs::write(&path, csv)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Renders each (renderer, settings) variant `frames` + 1 times at `size`², the variants'
/// frames interleaved with the order rotating each round (so drift in the machine's load falls
/// on all); the first round compiles the pipelines and is not timed. Returns each variant's GPU
/// ms median and its targets (holding its last frame).
fn time_interleaved(
    ctx: &Context,
    variants: &[(&VolumeRenderer, &RenderSettings)],
    cam: &Camera,
    size: u32,
    frames: u64,
) -> BenchResult<(Vec<f64>, Vec<Targets>)> {
    let n = variants.len();
    let mut t = Vec::with_capacity(n);
    for _ in 0..n {
        t.push(Targets::new(ctx, [size; 2])?);
    }
    let mut ms = vec![Vec::new(); n];
    for frame in 0..=frames {
        for k in 0..n {
            let v = (k + frame as usize) % n;
            let (r, s) = variants[v];
            let run = render_frame(ctx, r, &mut t[v], cam, s, 0)?;
            if frame > 0 {
                ms[v].push(run.timings.last().map(|t| t.gpu_end_ns as f64 * 1e-6).unwrap_or(0.0));
            }
        }
    }
    let medians = ms
        .iter_mut()
        .map(|v| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        })
        .collect();
    Ok((medians, t))
}

/// The largest difference of two images' colour channels.
fn max_abs_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    a.iter().zip(b).flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs())).fold(0.0, f32::max)
}
