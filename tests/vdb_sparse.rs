//! OpenVDB grids kept sparse (`volume::data::sparse`, bricked by `volume::sparse_bricks`):
//! rendered against their dense load bit for bit, and a grid whose bounding box holds more than
//! 2³¹ voxels, written here by a minimal VDB writer (not an independent tool: it writes what
//! this project's reader reads; the fixtures in tests/data/formats are OpenVDB's own).

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::{load, LoadOptions, Volume};
use vkengine::volume::device::layout::VolumeLayout;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats").join(name)
}

fn render(ctx: &Context, r: &VolumeRenderer, cam: &Camera, s: &RenderSettings, size: [u32; 2]) -> Vec<[f32; 4]> {
    let mut t = Targets::new(ctx, size).expect("targets");
    render_frame(ctx, r, &mut t, cam, s, 0).expect("render");
    t.read_hdr(ctx).expect("readback")
}

/// Renderers whose every lookup goes through `sample_volume` (no gradient-magnitude image), so
/// exact filtering reads the same texels with the same weights in both layouts.
fn exact_cases() -> Vec<(&'static str, RenderSettings)> {
    let base = RenderSettings { empty_space_skipping: true, exact_filter: true, ..Default::default() };
    let mc = McSettings { seed: 7, max_events: 8, ..Default::default() };
    vec![
        ("mip", RenderSettings { renderer: RendererKind::Mip, ..base }),
        ("iso", RenderSettings { renderer: RendererKind::Iso, iso: 0.02, ..base }),
        ("eam", RenderSettings { renderer: RendererKind::Eam, precomputed_gradients: false, ..base }),
        ("mcm", RenderSettings { renderer: RendererKind::Mcm, mc, ..base }),
    ]
}

/// A VDB grid loaded sparse only (no dense copy: every box above `stream_above`) and bricked
/// leaf by leaf renders as the same grid loaded dense, bit for bit.
#[test]
fn a_sparse_vdb_renders_as_its_dense_load_bit_for_bit() {
    common::gpu_test(|ctx| {
        let tf = TransferFunction::preset("cloud").expect("tf");
        let cam = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 1.3 });
        for name in ["smoke.vdb", "sparse.vdb"] {
            let p = fixture(name);
            let dense = load(&p, &LoadOptions::default()).expect("dense load");
            let sparse = load(&p, &LoadOptions { stream_above: 0, ..LoadOptions::default() }).expect("sparse load");
            assert!(sparse.sparse_only().is_some(), "{name}: densified");
            let d = VolumeRenderer::with_layout(ctx, &dense, &tf, VolumeLayout::Dense).expect("dense");
            let s = VolumeRenderer::with_layout(ctx, &sparse, &tf, VolumeLayout::Sparse).expect("sparse");
            assert_eq!(s.layout.layout, VolumeLayout::Sparse);
            for (case, settings) in exact_cases() {
                let (a, b) = (render(ctx, &d, &cam, &settings, [40, 32]), render(ctx, &s, &cam, &settings, [40, 32]));
                let lit = a.iter().filter(|p| p[..3].iter().any(|&c| c > 1e-3)).count();
                assert!(lit >= 10, "{name} {case}: too few lit pixels to compare ({lit})");
                assert!(a == b, "{name} {case}: the sparse load renders differently from the dense one");
            }
        }
    });
}

/// Leaves (origin → 512 values, z fastest as OpenVDB numbers them), all voxels active.
type Leaves = BTreeMap<[i32; 3], Vec<f32>>;

/// An internal node's leaves: 128³ node origin → leaf origins.
type Internal = BTreeMap<[i32; 3], Vec<[i32; 3]>>;

/// A one-grid OpenVDB file (format 224, uncompressed, float grid `density`, background 0).
fn write_vdb(path: &Path, leaves: &Leaves) {
    fn string(out: &mut Vec<u8>, s: &str) {
        out.extend((s.len() as u32).to_le_bytes());
        out.extend(s.as_bytes());
    }
    let words = |out: &mut Vec<u8>, w: &[u64]| w.iter().for_each(|w| out.extend(w.to_le_bytes()));
    let floats = |out: &mut Vec<u8>, n: usize| out.extend(std::iter::repeat_n(0u8, 4 * n));
    // Root children (4096³) → internal children (128³) → leaves, each level in the order the
    // reader walks its child mask (x, then y, then z slowest to fastest).
    let mut tree: BTreeMap<[i32; 3], Internal> = BTreeMap::new();
    for o in leaves.keys() {
        let root = o.map(|c| c.div_euclid(4096) * 4096);
        let mid = o.map(|c| c.div_euclid(128) * 128);
        tree.entry(root).or_default().entry(mid).or_default().push(*o);
    }
    let mut topo = Vec::new();
    topo.extend(0u32.to_le_bytes()); // no compression
    topo.extend(0u32.to_le_bytes()); // no grid metadata
    string(&mut topo, "UniformScaleMap");
    for v in [[1.0f64; 3], [1.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]] {
        v.iter().for_each(|c| topo.extend(c.to_le_bytes()));
    }
    topo.extend(1u32.to_le_bytes()); // one buffer per node
    topo.extend(0f32.to_le_bytes()); // background
    topo.extend(0u32.to_le_bytes()); // no root tiles
    topo.extend((tree.len() as u32).to_le_bytes());
    let mut order = Vec::new();
    for (root, mids) in &tree {
        root.iter().for_each(|c| topo.extend(c.to_le_bytes()));
        let mut mask = vec![0u64; 512];
        for m in mids.keys() {
            let i = m.map(|c| (c >> 7 & 31) as usize);
            let i = (i[0] << 10) | (i[1] << 5) | i[2];
            mask[i / 64] |= 1 << (i % 64);
        }
        words(&mut topo, &mask);
        words(&mut topo, &[0; 512]);
        topo.push(0);
        floats(&mut topo, 32768);
        for ls in mids.values() {
            let mut ls = ls.clone();
            ls.sort_by_key(|o| o.map(|c| c >> 3 & 15));
            let mut mask = vec![0u64; 64];
            for o in &ls {
                let i = o.map(|c| (c >> 3 & 15) as usize);
                let i = (i[0] << 8) | (i[1] << 4) | i[2];
                mask[i / 64] |= 1 << (i % 64);
            }
            words(&mut topo, &mask);
            words(&mut topo, &[0; 64]);
            topo.push(0);
            floats(&mut topo, 4096);
            for _ in &ls {
                words(&mut topo, &[u64::MAX; 8]);
            }
            order.extend(ls);
        }
    }
    let mut data = Vec::new();
    for o in &order {
        words(&mut data, &[u64::MAX; 8]);
        data.push(0);
        leaves[o].iter().for_each(|v| data.extend(v.to_le_bytes()));
    }
    let mut head = vec![0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
    head.extend(224u32.to_le_bytes());
    head.extend(10u32.to_le_bytes());
    head.extend(0u32.to_le_bytes());
    head.push(1); // grid offsets follow
    head.extend([b'0'; 36]);
    head.extend(0u32.to_le_bytes()); // no file metadata
    head.extend(1u32.to_le_bytes());
    string(&mut head, "density");
    string(&mut head, "Tree_float_5_4_3");
    string(&mut head, "");
    let grid_pos = (head.len() + 24) as i64;
    let block_pos = grid_pos + topo.len() as i64;
    for p in [grid_pos, block_pos, block_pos + data.len() as i64] {
        head.extend(p.to_le_bytes());
    }
    head.extend(topo);
    head.extend(data);
    std::fs::write(path, head).expect("write vdb");
}

/// 16³-voxel blobs (2³ leaves, a rippled ball) with origins `step` apart on every axis.
fn corner_blobs(step: i32) -> Leaves {
    let mut leaves = Leaves::new();
    for c in 0..8 {
        let o = [c & 1, c >> 1 & 1, c >> 2].map(|b| b * step);
        for l in 0..8 {
            let lo = [0, 1, 2].map(|a| o[a] + 8 * ([l & 1, l >> 1 & 1, l >> 2][a]));
            let values = (0..512)
                .map(|i| {
                    let p = [lo[0] + (i >> 6), lo[1] + (i >> 3 & 7), lo[2] + (i & 7)];
                    let r = (0..3).map(|a| (p[a] - o[a]) as f32 + 0.5 - 8.0).map(|d| d * d).sum::<f32>().sqrt();
                    (1.0 - r / 8.0).max(0.0) * (1.0 + 0.1 * (c as f32))
                })
                .collect();
            leaves.insert(lo, values);
        }
    }
    leaves
}

/// Voxels between the blobs' origins on every axis, as the issue asks: a 4,112³ box of 514³
/// bricks, whose page table takes two levels (a flat one would be 543 MB).
const BLOB_SPACING: i32 = 4096;

/// Blobs `BLOB_SPACING` voxels apart on every axis: a box past 2³¹ voxels (4,112³: 7 · 10¹⁰)
/// loads without a dense copy and renders through its page table.
#[test]
fn a_grid_whose_box_holds_more_than_two_to_the_31_voxels_loads_and_renders() {
    common::gpu_test(|ctx| {
        let dir = std::env::temp_dir().join(format!("vkengine_vdb_sparse_{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let p = dir.join("far_blobs.vdb");
        write_vdb(&p, &corner_blobs(BLOB_SPACING));
        let max3d = ctx.info.limits.max_image_dimension3_d;
        let v: Volume = load(&p, &LoadOptions { max_dimension: max3d, ..LoadOptions::default() }).expect("load");
        let side = BLOB_SPACING as u32 + 16;
        assert_eq!(v.dims, [side; 3]);
        assert!(v.dims.iter().map(|&d| u64::from(d)).product::<u64>() > 1 << 31);
        assert!(v.data.is_empty() && v.normalized.is_none(), "densified");
        let g = v.sparse_only().expect("sparse grid");
        assert_eq!(g.leaves.len(), 64);
        let tf = TransferFunction::preset("cloud").expect("tf");
        let r = VolumeRenderer::new(ctx, &v, &tf).expect("renderer");
        let l = r.layout;
        assert_eq!(l.layout, VolumeLayout::Sparse, "{l:?}");
        assert_eq!(l.bricks, u64::from(side.div_ceil(8)).pow(3), "{l:?}");
        assert!(side.div_ceil(8) <= max3d, "the page table fits the device's 3D images");
        let brick_bytes = 2 * 2 * 512;
        let stored = l.stored_bricks * brick_bytes;
        eprintln!(
            "{l:?}: GPU {} bytes = {:.2} × the stored bricks' {stored} bytes (the page table alone {} bytes; grids {} bytes)",
            l.gpu_bytes + l.grid_bytes,
            (l.gpu_bytes + l.grid_bytes) as f64 / stored as f64,
            l.bricks * 4,
            l.grid_bytes
        );
        // 514³ bricks: 8³ a cell would be 65³ cells, past 64³; 16³ a cell is 33³.
        assert_eq!(l.grid_cell, 128, "the occupancy and majorant grids should merge 16³ bricks a cell");
        // Two levels: a directory word per 8³ bricks and a pool page per page that holds data,
        // not 4 bytes for each of the 514³ bricks (543 MB).
        assert_eq!(l.page_levels, 2, "{l:?}");
        assert!(l.page_bytes * 100 < l.bricks * 4, "{l:?}");
        // Each blob framed on its own (at 4,112 voxels a side the whole box puts a blob in under a
        // pixel): the far corners read their pages through the directory's far ends.
        let s = RenderSettings { renderer: RendererKind::Mip, empty_space_skipping: true, ..Default::default() };
        for c in 0..8 {
            let o = [c & 1, c >> 1 & 1, c >> 2].map(|b| (b * BLOB_SPACING) as f32 + 8.0);
            let centre = glam::Vec3::from(o.map(|v| v / side as f32 - 0.5));
            let cam = Camera::orbit(2.5, 0.7, 0.4, Projection::Orthographic { height: 1.0 }).framed(
                centre,
                glam::Vec3::splat(8.0 / side as f32),
                1.0,
                0.8,
            );
            let img = render(ctx, &r, &cam, &s, [32, 32]);
            let lit = img.iter().filter(|p| p[..3].iter().any(|&c| c > 1e-3)).count();
            eprintln!("blob {c}: {lit} lit pixels");
            assert!(lit >= 100, "blob {c} at {o:?} is not drawn ({lit} lit pixels of 1,024)");
        }
        std::fs::remove_dir_all(&dir).ok();
    });
}

/// Two leaves 8,000 voxels apart on every axis: within the loader's 8 × max_dimension per axis,
/// but a box of 1,001³ bricks, past the 2²⁸ the loader visits: one error naming the file.
#[test]
fn a_box_of_more_bricks_than_the_loader_visits_is_refused_before_allocating() {
    let dir = std::env::temp_dir().join(format!("vkengine_vdb_far_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let p = dir.join("far.vdb");
    let leaves: Leaves = [[0, 0, 0], [8000, 8000, 8000]].into_iter().map(|o| (o, vec![1.0; 512])).collect();
    write_vdb(&p, &leaves);
    let e = load(&p, &LoadOptions { max_dimension: 4096, ..LoadOptions::default() }).expect_err("refused").to_string();
    assert!(e.contains(&*p.display().to_string()) && e.contains("1003003001 bricks") && !e.contains('\n'), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A load reports its progress (the demos draw a bar from it past a second): over the grid's
/// leaf data twice (read, then made into the volume), growing, every 256 leaves of the first
/// half, ending at its total.
#[test]
fn a_vdb_load_reports_progress_over_its_leaves() {
    let dir = std::env::temp_dir().join(format!("vkengine_vdb_progress_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let p = dir.join("many.vdb");
    // 1,000 leaves in a 10³ block of leaves: a 80³ box.
    let leaves: Leaves = (0..1000)
        .map(|i| {
            let o = [i % 10, i / 10 % 10, i / 100].map(|c| c * 8);
            (o, (0..512).map(|v| (v + i) as f32 * 0.01).collect())
        })
        .collect();
    write_vdb(&p, &leaves);
    let mut calls = Vec::new();
    vkengine::volume::data::load_with_progress(&p, &LoadOptions::default(), &mut |done, total| {
        calls.push((done, total))
    })
    .expect("load");
    let file = std::fs::metadata(&p).expect("size").len();
    let total = calls.last().map_or(0, |c| c.1);
    // The leaves' values alone are 1,000 · 512 · 4 bytes; the grid's data lies within the file.
    assert!((2_048_000..file).contains(&(total / 2)), "total {total} for a {file}-byte file");
    assert!(calls.iter().all(|c| c.1 == total) && calls.windows(2).all(|w| w[0].0 <= w[1].0), "{calls:?}");
    assert_eq!(calls.last(), Some(&(total, total)));
    let reading = calls.iter().filter(|c| c.0 < total / 2).count();
    assert!(reading >= 4, "one call per 256 leaves while reading: {calls:?}");
    std::fs::remove_dir_all(&dir).ok();
}
