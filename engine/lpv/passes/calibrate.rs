//! The gather steps' dispatch layout, chosen per device by measurement: one cascade per
//! dispatch keeps a cascade's step grids in a CPU's caches, and its flat accumulation with one
//! copy costs llvmpipe less than storage-image stores (it ran stacked steps 2–4× slower on a
//! 2-core EPYC), while a GPU pays a fixed cost per dispatch, barrier and copy that stacking every
//! cascade into one dispatch, whose last step writes the images, cuts by the cascade count. Each propagation shape is
//! timed once per process with GPU timestamps, both layouts interleaved over the same synthetic
//! grid (dense: the arithmetic does not depend on the values), and the faster one kept.

use super::gather::{horner_steps, GatherGrids, Target};
use super::{flat_bytes, grid_desc, LpvParams, GV_SCALE};
use crate::graph::execute::{run_graph, ExecuteOptions, Imports};
use crate::graph::{Access, BufferDesc, GraphBuilder, ImageDesc};
use crate::vk::{vk, Context};
use crate::Result;
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// What a measurement depends on: the propagation's shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct Shape {
    /// Cells per grid edge.
    pub n: u32,
    /// Cascades propagated together.
    pub cascades: u32,
    /// Propagation steps.
    pub steps: u32,
    /// Geometry-volume sources (0: no occlusion).
    pub gv_sources: u32,
    /// Steps read integer injection's fixed-point buffer.
    pub int_seed: bool,
}

/// Both layouts' GPU time for one shape (medians over the measured rounds).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Measured {
    /// All steps, one cascade per dispatch, ms.
    pub cascades_ms: f64,
    /// All steps, every cascade in one dispatch, ms.
    pub stacked_ms: f64,
}

/// Stacked steps must take less than this share of the per-cascade time to be chosen: the
/// measurement is dense, and per cascade a real frame also skips the bricks light has not reached
/// (sparse steps took 0.4–0.5× the dense time on the atrium), which stacked steps cannot. On
/// llvmpipe the two dense layouts measured within 0.85–1.0× of each other, where noise alone
/// could pick either.
pub const STACKED_MARGIN: f64 = 0.8;

impl Measured {
    /// The stacked layout wins by the margin.
    pub fn stacked(&self) -> bool {
        self.stacked_ms < STACKED_MARGIN * self.cascades_ms
    }
}

/// Every measurement of this process, per device name and shape.
static MEASURED: OnceLock<Mutex<HashMap<(String, Shape), Measured>>> = OnceLock::new();

/// Both layouts' times for `shape` on `ctx`'s device: measured on first use (and reported on
/// stderr), then cached for the process.
pub fn cached(ctx: &Context, shape: Shape) -> Result<Measured> {
    let map = MEASURED.get_or_init(Default::default);
    let key = (ctx.info.name.clone(), shape);
    // Held while measuring: renderers of one process measure each shape once.
    let mut map = map.lock().unwrap_or_else(|p| p.into_inner());
    if let Some(m) = map.get(&key) {
        return Ok(*m);
    }
    let m = measure(ctx, shape)?;
    eprintln!(
        "LPV: {}³ × {} cascades, {} steps on {}: one cascade per dispatch {:.3} ms, stacked {:.3} ms; using {}",
        shape.n,
        shape.cascades,
        shape.steps,
        key.0,
        m.cascades_ms,
        m.stacked_ms,
        if m.stacked() { "stacked" } else { "one cascade per dispatch" }
    );
    map.insert(key, m);
    Ok(m)
}

/// The layouts measured so far in this process: device, shape, times.
pub fn measured() -> Vec<(String, Shape, Measured)> {
    let Some(map) = MEASURED.get() else { return Vec::new() };
    let map = map.lock().unwrap_or_else(|p| p.into_inner());
    map.iter().map(|((d, s), m)| (d.clone(), *s, *m)).collect()
}

/// Rounds after one warm-up round; each runs both layouts.
const ROUNDS: usize = 3;

/// Times both layouts for `shape` on `ctx`'s device.
pub fn measure(ctx: &Context, shape: Shape) -> Result<Measured> {
    let mut samples = [Vec::new(), Vec::new()];
    for round in 0..=ROUNDS {
        for (i, stacked) in [false, true].into_iter().enumerate() {
            let ms = propagate_once(ctx, shape, stacked)?;
            if round > 0 {
                samples[i].push(ms);
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok(Measured { cascades_ms: median(&mut samples[0]), stacked_ms: median(&mut samples[1]) })
}

/// One propagation of `shape` over a synthetic lit grid; its steps' GPU ms.
fn propagate_once(ctx: &Context, shape: Shape, stacked: bool) -> Result<f64> {
    let Shape { n, cascades: count, steps, gv_sources, int_seed } = shape;
    let cells = u64::from(n).pow(3) * u64::from(count);
    let mut params: LpvParams = bytemuck::Zeroable::zeroed();
    params.cascade = [[0.0, 0.0, 0.0, 1.0]; 4];
    params.dims = [n, count, 0, 0];
    params.params = [0.5, 1.0, 1.0, GV_SCALE];
    let ubo_bytes = bytemuck::bytes_of(&params).to_vec();
    let mut g = GraphBuilder::new();
    let ubo = g.create_buffer("calibrate params", BufferDesc::new(ubo_bytes.len() as u64));
    let light_bytes = if int_seed { 12 * cells * 4 } else { flat_bytes(cells) };
    let light = g.create_buffer("calibrate light", BufferDesc::new(light_bytes));
    let grid_desc = grid_desc(n, count);
    let m = n + 1;
    let gv = (gv_sources > 0)
        .then(|| g.create_image("calibrate gv", ImageDesc { extent: [m, m, m * count * gv_sources], ..grid_desc }));
    {
        let mut p = g.add_transfer_pass("calibrate inputs");
        p.write_buffer(ubo, Access::TransferDst)?;
        p.write_buffer(light, Access::TransferDst)?;
        if let Some(gv) = gv {
            p.write_image(gv, Access::TransferDst)?;
        }
        // Fixed point 1000 or float 1.0 in every value: every cell lit.
        let fill = if int_seed { 1000 } else { 1.0f32.to_bits() };
        p.record(move |pc| {
            // SAFETY: transfer pass; every resource was declared as written here.
            unsafe {
                pc.device().cmd_update_buffer(pc.cmd, pc.buffer(ubo).raw, 0, &ubo_bytes);
                pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(light).raw, 0, vk::WHOLE_SIZE, fill);
                if let Some(gv) = gv {
                    let img = pc.image(gv);
                    let clear = vk::ClearColorValue { float32: [0.1; 4] };
                    let layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
                    pc.device().cmd_clear_color_image(pc.cmd, img.raw, layout, &clear, &[img.info.full_range()]);
                }
            }
            Ok(())
        });
    }
    let x = GatherGrids {
        ubo,
        injected: light,
        injected_int: int_seed.then_some(light),
        accum: light,
        gv,
        normals: None,
        gv_sources,
        grid_desc,
        cell_groups: [n.div_ceil(8), n.div_ceil(4), (n * count).div_ceil(2)],
        sparse: false,
    };
    let images = ["r", "g", "b"].map(|ch| g.create_image(format!("calibrate grid {ch}"), grid_desc));
    let slots: Vec<u32> = (0..count).collect();
    horner_steps(&mut g, "calibrate", steps, &x, stacked, &Target { images, slots: &slots })?;
    for img in images {
        g.export_image(img, None)?;
    }
    let run = run_graph(ctx, g.compile()?, &Imports::default(), ExecuteOptions::default())?;
    // Per cascade, the copy of the accumulation into the images belongs to the layout's cost.
    let counted = |n: &str| n.starts_with("calibrate propagate") || n == "calibrate accumulated copy";
    Ok(run.timings.iter().filter(|t| counted(&t.name)).map(|t| t.gpu_ms()).sum())
}
