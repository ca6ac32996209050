//! Sparse gather steps' schedule (lpv/schedule.comp): which bricks each step runs.

use super::gather::GatherGrids;
use super::GRID_FORMAT;
use crate::graph::{BufferDesc, BufferId, GraphBuilder};
use crate::shaders;
use crate::vk::vk;
use crate::Result;

/// Bricks, the workgroups of a propagation step (8 × 4 × 2 cells), per cascade along each axis
/// (`brick_grid` in lpv/common.glsl).
fn brick_grid(n: u32) -> [u32; 3] {
    [n.div_ceil(8), n.div_ceil(4), n.div_ceil(2)]
}

/// Most bricks the activation pass looks at around each brick; longer step counts propagate
/// every brick (light has then reached most of the grid anyway).
const MAX_BRICK_WINDOW: u32 = 1024;

/// Push constants of `lpv/schedule.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SchedulePush {
    /// xyz: the radius in bricks within which an occupied brick's light arrives in the steps;
    /// w: the steps.
    window: [i32; 4],
}

/// What sparse steps read: per cascade and step, the list of bricks the step runs (in index
/// order) and its indirect dispatch.
#[derive(Clone, Copy)]
pub(super) struct SparseSchedule {
    /// Per cascade and step, the bricks it runs.
    pub list: BufferId,
    /// Per cascade and step, its `VkDispatchIndirectCommand`.
    pub commands: BufferId,
    /// Entries per list: a cascade's bricks.
    pub per_list: u32,
}

/// The passes of lpv/schedule.comp for `steps` linear gather steps over `count` cascades of
/// `n`³ cells; None when every step runs dense (a window past MAX_BRICK_WINDOW, or too many
/// bricks for the list pass's loop).
pub(super) fn sparse_schedule(
    g: &mut GraphBuilder<'_>,
    tag: &str,
    x: &GatherGrids,
    steps: u32,
    n: u32,
    count: u32,
) -> Result<Option<SparseSchedule>> {
    let grid = brick_grid(n);
    // An occupied brick d bricks away along an axis of brick edge e is (d − 1)·e + 1 cells away.
    let window = [8, 4, 2].map(|edge| (steps.saturating_sub(1) / edge + 1) as i32);
    let scanned: u32 = window.iter().map(|r| (2 * r + 1) as u32).product();
    // The list pass loops over a cascade's bricks in one invocation (llvmpipe's loop limit).
    if scanned > MAX_BRICK_WINDOW || grid.iter().product::<u32>() >= 65_535 {
        return Ok(None);
    }
    let push = SchedulePush { window: [window[0], window[1], window[2], steps as i32] };
    let per = grid.iter().product::<u32>();
    let bricks = per * count;
    let buffer = |g: &mut GraphBuilder<'_>, what: &str, bytes: u32| {
        g.create_buffer(format!("{tag} bricks ({what})"), BufferDesc::new(u64::from(bytes)))
    };
    let occupied = buffer(g, "occupied", 4 * bricks);
    let first = buffer(g, "first step", 4 * bricks);
    let list = buffer(g, "lists", 4 * bricks * steps);
    let commands = buffer(g, "dispatches", 12 * count * steps);
    let groups = [bricks.div_ceil(8), 1, 1];
    let (occupancy, injected, format) = match x.injected_int {
        Some(b) => (&shaders::LPV_SCHEDULE_COMP__OCCUPANCY_INT, b, vk::Format::R32G32B32A32_SINT),
        None => (&shaders::LPV_SCHEDULE_COMP__OCCUPANCY, x.injected, GRID_FORMAT),
    };
    g.compute(format!("{tag} bricks occupied"), occupancy)
        .uniform(x.ubo)
        .read_texels(injected, format)
        .write(occupied)
        .constants(&push)
        .loop_bound(65)
        .dispatch(groups)?;
    let [rx, ry, rz] = window.map(|r| 2 * r as u64 + 1);
    g.compute(format!("{tag} bricks first step"), &shaders::LPV_SCHEDULE_COMP__ACTIVATION)
        .uniform(x.ubo)
        .read_texels(occupied, vk::Format::R32_UINT)
        .write(first)
        .constants(&push)
        // Three nested loops over the window, each with its exits.
        .loop_bound(rz * (ry * (rx + 1) + 1) + 1)
        .dispatch(groups)?;
    // One invocation per cascade and step, each looping over its cascade's bricks.
    g.compute(format!("{tag} bricks listed"), &shaders::LPV_SCHEDULE_COMP)
        .uniform(x.ubo)
        .read(first)
        .write(list)
        .write(commands)
        .constants(&push)
        .loop_bound(u64::from(per) + 1)
        .dispatch([(count * steps).div_ceil(8), 1, 1])?;
    Ok(Some(SparseSchedule { list, commands, per_list: per }))
}
