//! What a label map costs each renderer: GPU ms per frame of the CT-like volume without and with
//! a three-label map (body, bone shell, spine), frames alternating, in rounds within one run
//! (`volume_bench --labels`, `labels.csv`; docs/labels.md "Cost").

use crate::layout_bench::{ct_like, ct_like_region};
use std::fmt::Write as _;
use std::path::Path;
use vkengine::vk::Context;
use vkengine::volume::camera::{Camera, Projection};
use vkengine::volume::data::labels::LabelVolume;
use vkengine::volume::optics::label_table::LabelTable;
use vkengine::volume::optics::tf::TransferFunction;
use vkengine::volume::render::renderer::{
    render_frame, McSettings, RenderSettings, RendererKind, Targets, VolumeRenderer,
};

type BenchResult<T> = Result<T, Box<dyn std::error::Error>>;

/// [`ct_like`]'s regions as labels ([`ct_like_region`]).
pub fn ct_like_labels(n: u32) -> LabelVolume {
    let mut labels = Vec::with_capacity((n as usize).pow(3));
    for _z in 0..n {
        for y in 0..n {
            labels.extend((0..n).map(|x| ct_like_region(x, y, n)));
        }
    }
    LabelVolume {
        dims: [n; 3],
        spacing: [1.0; 3],
        labels,
        source: format!("ct-like labels {n}^3"),
        segments: Vec::new(),
        patient_axes: false,
        directions: None,
    }
}

/// Median GPU ms of the whole frame of each renderer over `frames` frames after `warm` warm-up
/// frames, their frames alternating (so a change of the machine's load falls on both alike).
fn median_ms(
    ctx: &Context,
    r: [&VolumeRenderer; 2],
    s: &RenderSettings,
    size: u32,
    warm: u64,
    frames: u64,
) -> BenchResult<[f64; 2]> {
    let cam = Camera::orbit(2.0, 0.6, 0.35, Projection::Perspective { fov_y: 0.8 });
    let mut t = [Targets::new(ctx, [size; 2])?, Targets::new(ctx, [size; 2])?];
    let mut ms = [Vec::new(), Vec::new()];
    for f in 0..warm + frames {
        for v in 0..2 {
            let run = render_frame(ctx, r[v], &mut t[v], &cam, s, f)?;
            if f >= warm {
                ms[v].push(run.gpu_ms());
            }
        }
    }
    Ok(ms.map(|mut m| {
        m.sort_by(f64::total_cmp);
        m[m.len() / 2]
    }))
}

/// Times `renderers` (mip, eam, lao, mcm) on an `n`³ CT-like volume at `size`², without and with
/// labels, `rounds` times; writes `out/labels.csv`.
pub fn run(
    ctx: &Context,
    out: &Path,
    n: u32,
    size: u32,
    frames: u64,
    rounds: u32,
    renderers: &[String],
) -> BenchResult<()> {
    let vol = ct_like(n)?;
    let tf = TransferFunction::ramp(0.2, 1.0, [0.9, 0.8, 0.7], 20.0);
    let plain = VolumeRenderer::new(ctx, &vol, &tf)?;
    let mut labelled = VolumeRenderer::new(ctx, &vol, &tf)?;
    let labels = ct_like_labels(n);
    labelled.set_labels(ctx, Some((&labels, &LabelTable::for_volume(&labels))))?;
    let kinds = [RendererKind::Eam, RendererKind::Mip, RendererKind::Lao, RendererKind::Mcm];
    let wanted = |k: &RendererKind| renderers.is_empty() || renderers.iter().any(|r| r == k.name());
    let mut csv = format!(
        "# device: {} ({}); ct-like {n}^3 with 3 labels, image {size}^2, GPU ms per frame, median of {frames} (LAO, MCM: {}) after 2 warm-up, frames alternating\nround,renderer,without_ms,with_ms,ratio\n",
        ctx.info.name,
        ctx.info.driver,
        frames.min(6)
    );
    for round in 1..=rounds {
        for kind in kinds.iter().filter(|k| wanted(k)) {
            let mut s = RenderSettings { renderer: *kind, ..Default::default() };
            s.mc = McSettings { budget: 512, seed: 1, ..Default::default() };
            // The MC renderers' frames restart the mean each time here (new targets): the same
            // work every frame.
            let (fr, warm) =
                if matches!(kind, RendererKind::Lao | RendererKind::Mcm) { (frames.min(6), 2) } else { (frames, 2) };
            let [without, with] = median_ms(ctx, [&plain, &labelled], &s, size, warm, fr)?;
            let ratio = with / without;
            println!(
                "round {round} {:<4} without {without:>9.2} ms  with labels {with:>9.2} ms  ratio {ratio:.3}",
                kind.name()
            );
            writeln!(csv, "{round},{},{without:.3},{with:.3},{ratio:.4}", kind.name())?;
        }
    }
    std::fs::create_dir_all(out)?;
    let path = out.join("labels.csv");
    std::fs::write(&path, csv)?;
    println!("wrote {}", path.display());
    Ok(())
}
