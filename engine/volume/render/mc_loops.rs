//! llvmpipe's loop limit and the bounded Monte Carlo pass's worst case under it.

use crate::error::{Error, Result};

/// Push constants of `mc_bounded.comp`.
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub(crate) struct BoundedPush {
    pub(crate) budget: u32,
    pub(crate) reset: u32,
    /// Completed paths per pixel after which the pixel stops for this frame.
    pub(crate) cap: u32,
    /// Percentage of a row's lanes with an ended walk at which the row takes its events.
    pub(crate) regroup: u32,
    /// One in `interleave` tiles is advanced this frame: those of subset `subset`.
    pub(crate) interleave: u32,
    pub(crate) subset: u32,
    /// Adaptive sampling: the largest budget a tile may be given (`budget` without it).
    pub(crate) max_budget: u32,
}

/// llvmpipe ends all loops of a shader after 65,535 iterations per 8-lane row (silently: the
/// image would be wrong). `mc_bounded.comp`'s worst case per dispatch: at most `budget` events,
/// each lane's walk steps at most `budget` (8 lanes: 8 × budget for the row, plus one exit
/// iteration per event), and per event the environment map's two binary searches.
pub fn mc_loop_iterations(budget: u32, env_size: Option<[u32; 2]>) -> u64 {
    let search = |n: u32| u64::from(n.max(2).next_power_of_two().trailing_zeros()) + 2;
    let per_event = env_size.map_or(0, |[w, h]| search(w) + search(h));
    u64::from(budget) * (10 + per_event) + 1
}

/// The loop limit of llvmpipe's SIMD rows.
pub const LOOP_LIMIT: u64 = crate::graph::work::LLVMPIPE_LOOP_LIMIT;

/// The largest budget whose worst case stays under llvmpipe's loop limit.
pub(crate) fn largest_budget(env_size: Option<[u32; 2]>) -> u32 {
    let per = mc_loop_iterations(1, env_size) - 1;
    ((LOOP_LIMIT - 1) / per).min(u64::from(super::settings::MAX_BUDGET)) as u32
}

/// The bounded pass's worst case (for the graph's `loop_bound`), or an error naming `mc_budget`
/// when it is over llvmpipe's limit: a clearer message than the graph's, and on every device.
pub(crate) fn check_loop_budget(budget: u32, env_size: Option<[u32; 2]>) -> Result<u64> {
    let worst = mc_loop_iterations(budget, env_size);
    if worst <= LOOP_LIMIT {
        return Ok(worst);
    }
    Err(Error::Input(format!(
        "mc_budget={budget}: an 8-lane row could run {worst} loop iterations per frame{}, over llvmpipe's {LOOP_LIMIT} (it would silently cut the paths short); lower mc_budget to {} or less",
        env_size.map_or(String::new(), |[w, h]| format!(" with the {w}×{h} environment map")),
        largest_budget(env_size)
    )))
}
