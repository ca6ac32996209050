//! Gather propagation: each step a dispatch that reads the previous step's flat buffer as
//! texels and writes its own (see lpv/images.glsl). Linear steps accumulate by Horner's rule
//! (propagate.comp: each adds the injected light, the last the accumulation's start);
//! directional steps add pairs of steps into the accumulation's flat start.
//!
//! Two layouts of linear steps compute the same values: one cascade per dispatch (its step grids
//! stay in the caches; with `sparse`, only the bricks light can have reached, [`sparse_schedule`])
//! into a flat accumulation copied into the images once, or every cascade in one dense dispatch
//! per step, the last writing the images (a quarter of the dispatches and barriers, no copy).
//! Which is faster depends on the device (engine/lpv/passes/calibrate.rs).

use super::copies::{copy_to_images, flat_bytes, zero_fill};
use super::schedule::{sparse_schedule, SparseSchedule};
use crate::graph::{BufferDesc, BufferId, GraphBuilder, ImageDesc, ImageId, Work};
use crate::shaders::{self, Shader};
use crate::vk::vk;
use crate::Result;

use super::GRID_FORMAT;

/// What gather propagation reads and writes besides its own step grids.
pub(crate) struct GatherGrids {
    pub ubo: BufferId,
    /// The injected light of all cascades as a flat buffer (lpv/images.glsl).
    pub injected: BufferId,
    /// Integer injection's fixed-point buffer (12 values per cell, lpv/common.glsl), when the
    /// accumulation starts from the injected light alone (so never with directional steps):
    /// linear steps then read it in place of `injected` and `accum` (propagate.comp, SEED_INT).
    pub injected_int: Option<BufferId>,
    /// The accumulation's start as a flat buffer (lpv/images.glsl): the injected light, or its
    /// copy with the sky's share; the directional steps add into it.
    pub accum: BufferId,
    pub gv: Option<ImageId>,
    /// Directional propagation's undilated normal grid.
    pub normals: Option<ImageId>,
    pub gv_sources: u32,
    /// All cascades stacked along z.
    pub grid_desc: ImageDesc,
    /// Workgroups of a pass over every cell of every cascade.
    pub cell_groups: [u32; 3],
    /// Linear steps skip the bricks light has not reached (`lpv_sparse`).
    pub sparse: bool,
}

/// The grid images the last linear step writes: cascade k of this frame at slot `slots[k]`.
pub(crate) struct Target<'s> {
    pub images: [ImageId; 3],
    pub slots: &'s [u32],
}

/// Push constants of the linear steps (propagate.comp's `Step`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct StepPush {
    /// This step's brick list in the schedule's buffer.
    list_at: u32,
    pad: [u32; 3],
    /// Each cascade's slot in the target images.
    slots: [u32; 4],
}

/// The linear steps' shaders: a middle step and the last, which writes the images.
fn horner_shaders(int_seed: bool, gv_sources: u32) -> [&'static Shader; 2] {
    use shaders::*;
    match (int_seed, gv_sources) {
        (true, 0) => [&LPV_PROPAGATE_COMP__HORNER_INT, &LPV_PROPAGATE_COMP__HORNER_INT_LAST],
        (true, 1) => [&LPV_PROPAGATE_COMP__HORNER_INT_OCC1, &LPV_PROPAGATE_COMP__HORNER_INT_LAST_OCC1],
        (true, _) => [&LPV_PROPAGATE_COMP__HORNER_INT_OCC2, &LPV_PROPAGATE_COMP__HORNER_INT_LAST_OCC2],
        (false, 0) => [&LPV_PROPAGATE_COMP__HORNER, &LPV_PROPAGATE_COMP__HORNER_LAST],
        (false, 1) => [&LPV_PROPAGATE_COMP__HORNER_OCC1, &LPV_PROPAGATE_COMP__HORNER_LAST_OCC1],
        (false, _) => [&LPV_PROPAGATE_COMP__HORNER_OCC2, &LPV_PROPAGATE_COMP__HORNER_LAST_OCC2],
    }
}

/// Per step, averaged over a pair: 6 neighbours, the step, half an accumulation RMW and half a
/// previous-step read, plus each cell's 8 GV corners per source.
fn step_work(cells: u64, gv_sources: u32) -> Work {
    Work { bytes: cells * (6 * 48 + 48 + 48 + 24 + 8 * 16 * u64::from(gv_sources)), ..Default::default() }
}

/// Linear (Horner) gather steps, `steps` ≥ 1, leaving the accumulated light in `target`.
/// `stacked`: every cascade in one dense dispatch per step, the last writing the images itself.
/// Otherwise one cascade per dispatch (sparse where `x.sparse`), the last steps writing a flat
/// accumulation that one copy turns into the images: llvmpipe stores an RGBA32F storage-image
/// texel 2.4× slower than a buffer vec4, and there a sparse last step and the copy cost less
/// than a dense last step into the images.
pub(crate) fn horner_steps(
    g: &mut GraphBuilder<'_>,
    tag: &str,
    steps: u32,
    x: &GatherGrids,
    stacked: bool,
    target: &Target<'_>,
) -> Result<()> {
    let [n, _, depth] = x.grid_desc.extent;
    let count = depth / n;
    let sparse = match x.sparse && !stacked {
        true => sparse_schedule(g, tag, x, steps, n, count)?,
        false => None,
    };
    // The float injected light and the accumulation's start, or the fixed-point buffer that
    // stands for both (step 1 then reads it through the seed binding, not its float source's).
    let (injected, seed, seed_format) = match x.injected_int {
        Some(b) => (b, b, vk::Format::R32G32B32A32_SINT),
        None => (x.injected, x.accum, GRID_FORMAT),
    };
    let [mid_shader, last_shader] = horner_shaders(x.injected_int.is_some(), x.gv_sources);
    let mut push = StepPush { list_at: 0, pad: [0; 3], slots: [0; 4] };
    for (k, &slot) in target.slots.iter().take(4).enumerate() {
        push.slots[k] = slot;
    }
    // One cascade at a time: the last steps write a flat accumulation of all cascades. A sparse
    // one writes over the accumulation's start in place (a brick it skips holds what it would
    // compute, and each reads its own cells' start before writing them), except where the start
    // is the fixed-point buffer, or the source of a single step (which reads its neighbours):
    // then a zeroed grid (a brick it skips has no injected light within reach: it computes 0).
    let in_place = x.injected_int.is_none() && !(steps == 1 && x.accum == x.injected);
    let accumulated = match (stacked, sparse) {
        (true, _) => None,
        (false, Some(_)) if in_place => Some(x.accum),
        (false, sparse) => {
            let bytes = flat_bytes(u64::from(n).pow(3) * u64::from(count));
            let acc = g.create_buffer(format!("{tag} accumulated (flat)"), BufferDesc::new(bytes));
            if sparse.is_some() {
                zero_fill(g, format!("{tag} clear accumulated"), [acc])?;
            }
            Some(acc)
        }
    };
    let per_dispatch = if stacked { count } else { 1 };
    let cells = u64::from(n).pow(3) * u64::from(per_dispatch);
    let groups = [n.div_ceil(8), n.div_ceil(4), (n * per_dispatch).div_ceil(2)];
    let work = step_work(cells, x.gv_sources);
    let units: Vec<Option<u32>> = if stacked { vec![None] } else { (0..count).map(Some).collect() };
    for unit in units {
        let c = unit.unwrap_or(0);
        let suffix = match unit {
            Some(c) if count > 1 => format!(", cascade {c}"),
            _ => String::new(),
        };
        let step_bytes = flat_bytes(cells);
        // Sparse steps write a pair of buffers in turn, cleared first: the bricks a step skips
        // hold zeros, as they did two steps before (the bricks reached only grow).
        let pair = match sparse {
            Some(_) if steps > 1 => {
                let pair = [0, 1]
                    .map(|i| g.create_buffer(format!("{tag} steps {i}{suffix} (flat)"), BufferDesc::new(step_bytes)));
                zero_fill(g, format!("{tag} clear steps{suffix}"), pair)?;
                Some(pair)
            }
            _ => None,
        };
        // Step 1 reads the injected grid (all cascades); later steps the last step's grid.
        let mut src = (injected, true);
        for step in 1..=steps {
            let last = step == steps;
            // The last step writes its cascade's share of the stacked accumulation.
            let dst_stacked = last && !stacked;
            let spec =
                [0, 1, c, u32::from(src.1), u32::from(dst_stacked), u32::from(sparse.is_some()), u32::from(stacked)];
            // Step `step` of cascade c: list and dispatch c · steps + step − 1.
            let at = c * steps + step - 1;
            push.list_at = sparse.map_or(0, |s: SparseSchedule| at * s.per_list);
            let name = format!("{tag} propagate {step} (gather{suffix})");
            let out = match (last, accumulated, pair) {
                (true, acc, _) => acc,
                (false, _, Some(pair)) => Some(pair[(step % 2) as usize]),
                (false, _, None) => {
                    Some(g.create_buffer(format!("{tag} step {step}{suffix} (flat)"), BufferDesc::new(step_bytes)))
                }
            };
            let shader = if out.is_none() { last_shader } else { mid_shader };
            let pass = g.compute(name, shader).work(work).specialize(&spec).uniform(x.ubo);
            let pass = pass.read_texels(src.0, GRID_FORMAT);
            let Some(out) = out else {
                // Stacked: the last step writes the images (dense: every cell).
                pass.each(target.images, |p, id| p.write(id))
                    .read_texels(seed, seed_format)
                    .each(x.gv, |p, id| p.read(id))
                    .read(injected)
                    .constants(&push)
                    .dispatch(groups)?;
                break;
            };
            // A sparse step leaves what it skips as it was.
            let pass = if sparse.is_some() { pass.read_write(out) } else { pass.write(out) };
            // Every step adds the injected light, the last one the accumulation's start.
            let pass = pass.read_texels(if last { seed } else { injected }, seed_format).each(x.gv, |p, id| p.read(id));
            let pass = match sparse {
                Some(s) => pass.read(s.list).constants(&push).dispatch_indirect(s.commands, 12 * u64::from(at)),
                None => pass.read(injected).constants(&push).dispatch(groups),
            };
            pass?;
            src = (out, false);
        }
    }
    if let Some(acc) = accumulated {
        let extent = x.grid_desc.extent;
        copy_to_images(g, format!("{tag} accumulated copy"), acc, target.images, extent, target.slots)?;
    }
    Ok(())
}

/// Directional gather steps (thesis §5.2), one cascade per dispatch: each step re-projects onto
/// the dilated VPL normals, and pairs of steps add into `x.accum`, which is returned.
pub(crate) fn directional_steps(g: &mut GraphBuilder<'_>, tag: &str, steps: u32, x: &GatherGrids) -> Result<BufferId> {
    let [n, _, depth] = x.grid_desc.extent;
    let count = depth / n;
    // The normal grid dilated one cell per step, for all cascades at once.
    let mut step_normals = Vec::new();
    let mut normals = x.normals;
    for step in 1..=steps {
        if let Some(prev) = normals {
            let next = g.create_image(format!("{tag} normals step {step}"), x.grid_desc);
            g.compute(format!("{tag} dilate {step}"), &shaders::LPV_DILATE_COMP)
                .uniform(x.ubo)
                .read(prev)
                .write(next)
                .dispatch(x.cell_groups)?;
            normals = Some(next);
        }
        step_normals.push(normals);
    }
    let shader = match x.gv_sources {
        0 => &shaders::LPV_PROPAGATE_COMP__DIRECTIONAL,
        1 => &shaders::LPV_PROPAGATE_COMP__DIRECTIONAL_OCC1,
        _ => &shaders::LPV_PROPAGATE_COMP__DIRECTIONAL_OCC2,
    };
    let cells = u64::from(n).pow(3);
    let work = step_work(cells, x.gv_sources);
    for c in 0..count {
        let suffix = if count == 1 { String::new() } else { format!(", cascade {c}") };
        let mut src = (x.injected, true);
        for (step, step_normals) in (1..=steps).zip(step_normals.iter().copied()) {
            // Accumulate in pairs of steps (see propagate.comp); an odd last step alone.
            let accumulate = match (step % 2, step == steps) {
                (1, false) => 0,
                (1, true) => 1,
                _ => 2,
            };
            // The last step writes only the accumulation.
            let store = step < steps;
            let out = g.create_buffer(format!("{tag} step {step}{suffix} (flat)"), BufferDesc::new(flat_bytes(cells)));
            let spec = [accumulate, u32::from(store), c, u32::from(src.1), u32::from(step == steps), 0, 0];
            g.compute(format!("{tag} propagate {step} (gather{suffix})"), shader)
                .work(work)
                .specialize(&spec)
                .uniform(x.ubo)
                .read_texels(src.0, GRID_FORMAT)
                .write(out)
                .read_write(x.accum)
                .read_texels(x.accum, GRID_FORMAT)
                .each(x.gv, |p, id| p.read(id))
                .each(step_normals, |p, id| p.read(id))
                .dispatch([n.div_ceil(8), n.div_ceil(4), n.div_ceil(2)])?;
            src = (out, false);
        }
    }
    Ok(x.accum)
}
