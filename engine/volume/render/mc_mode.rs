//! Monte Carlo's mode per device and scene (`mc_budget=auto`, the default): one whole path per
//! pixel per frame while its expected work fits what one dispatch may take on this device and the
//! device was not measured to reach an error sooner with bounded work (`super::mc_calibrate`),
//! bounded work per dispatch (`mc_bounded.comp`) otherwise. One path per frame has no bound of its own: at
//! density ×1e6 it ran 73 s in one dispatch on an H200 (a desktop GPU's watchdog resets the device
//! after ~2 s) and came out transparent on llvmpipe, whose loops stop after 65,535 iterations per
//! row. An explicit `mc_budget=0` past the bound is refused, not rendered wrong.

use super::renderer::{VolumeRenderer, LOOP_LIMIT};
use super::settings::{RenderSettings, RendererKind, BUDGET_AUTO, MAX_BUDGET};
use crate::vk::Context;
use crate::{Error, Result};

/// Tracking steps per second assumed of a GPU: a floor (an integrated GPU's order), so the
/// dispatch budget holds on slow devices; the H200 ran bounded work at ~1.7e11 steps/s
/// (512 steps per pixel at 1024² in 3.1 ms).
pub const GPU_STEPS_PER_S: f64 = 1e9;

/// Bounded work's steps per pixel and dispatch when `auto` picks it and the device allows it.
/// With the row-level cap (`mc_bounded.comp`) a frame ends at the cap, 4 paths per pixel on
/// average: 512 and 2048 steps made the same image on vpt's cloud at 256² on llvmpipe, so the
/// budget bounds only rows whose paths are all long, and the larger one cuts fewer of them
/// short. (Before the row cap, 512/4 reached its error in 1.17× one path per frame's time on an
/// H200.)
pub const AUTO_BUDGET: u32 = 2048;

/// What bounds one dispatch's work on a device.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DispatchBound {
    /// llvmpipe: all loops of a shader stop after [`LOOP_LIMIT`] iterations per 8-lane row.
    LoopLimit,
    /// Any other device: `mc_dispatch_ms` of GPU time at `steps_per_s` tracking steps a second.
    Time {
        /// Tracking steps a second the device is assumed (or was measured) to reach.
        steps_per_s: f64,
    },
}

impl DispatchBound {
    /// The bound of the device named `name` (llvmpipe's loop limit, or time at [`GPU_STEPS_PER_S`]).
    pub fn of_device(name: &str) -> Self {
        if crate::vk::is_llvmpipe(name) {
            Self::LoopLimit
        } else {
            Self::Time { steps_per_s: GPU_STEPS_PER_S }
        }
    }

    /// Most expected tracking steps per pixel one dispatch of `pixels` may take. llvmpipe: an
    /// eighth of the row limit, so a row's longest lane (a Poisson-like count around that mean)
    /// stays under it; a GPU: its share of `dispatch_ms` at the assumed rate.
    pub fn steps_per_pixel(&self, pixels: u64, dispatch_ms: f32) -> f64 {
        match *self {
            Self::LoopLimit => (LOOP_LIMIT / 8) as f64,
            Self::Time { steps_per_s } => steps_per_s * f64::from(dispatch_ms) * 1e-3 / pixels.max(1) as f64,
        }
    }
}

/// Filtered fetches of one tracking step at most (the cell's bounds, the volume, the gradient
/// magnitude, the table): a measured rate of fetches / this is a floor on the steps taken.
const FETCHES_PER_STEP: f64 = 4.0;

impl VolumeRenderer {
    /// The bound of `mc_budget=auto` on this device: llvmpipe's loop limit, or time at the
    /// larger of [`GPU_STEPS_PER_S`] and half the step rate measured by earlier frames
    /// ([`Self::note_mc_frame`]): a GPU starts cautious and keeps whole paths once it has shown
    /// they fit.
    pub fn dispatch_bound(&self, device_name: &str) -> DispatchBound {
        match DispatchBound::of_device(device_name) {
            DispatchBound::LoopLimit => DispatchBound::LoopLimit,
            DispatchBound::Time { steps_per_s } => {
                let measured = f64::from_bits(self.measured_steps_per_s.load(std::sync::atomic::Ordering::Relaxed));
                DispatchBound::Time { steps_per_s: steps_per_s.max(0.5 * measured) }
            }
        }
    }

    /// Records a Monte Carlo frame's filtered fetches and its pass's GPU milliseconds: the step
    /// rate it shows (a floor: fetches / [`FETCHES_PER_STEP`]), kept if it is the largest yet.
    /// Frames shorter than a millisecond say more about fixed costs than about the rate.
    pub fn note_mc_frame(&self, fetches: u64, gpu_ms: f64) {
        if gpu_ms < 1.0 || fetches == 0 {
            return;
        }
        let rate = fetches as f64 / FETCHES_PER_STEP / (gpu_ms * 1e-3);
        let cell = &self.measured_steps_per_s;
        let mut old = cell.load(std::sync::atomic::Ordering::Relaxed);
        while rate > f64::from_bits(old) {
            match cell.compare_exchange_weak(
                old,
                rate.to_bits(),
                std::sync::atomic::Ordering::Relaxed,
                std::sync::atomic::Ordering::Relaxed,
            ) {
                Ok(_) => break,
                Err(now) => old = now,
            }
        }
    }

    /// Expected tracking steps of one whole path, from above: per walk, one step plus the global
    /// majorant σ̄ times the distance the walk can cover, which is at most the box's diagonal and,
    /// where the extinction is at least σ_min > 0 everywhere, about 4/σ_min (a real collision
    /// ends delta tracking after 1/σ_min on average; ratio tracking's weight falls below its
    /// roulette threshold 0.05 within ln 20 ≈ 3 mean free paths); two walks (flight and shadow
    /// ray) per event, and the camera ray's own walk with the view-ray estimate. Events: at most
    /// the path's limit, and about 1 + τ + τ² for a medium of optical diameter τ (σ̄ times the
    /// diagonal): a few in a thin medium, a diffusive random walk's τ² in a thick one.
    pub fn path_steps(&self, s: &RenderSettings) -> f64 {
        let [max, min] = self.global_majorant().map(|m| f64::from(m) * f64::from(s.mc.density_scale));
        let diagonal = f64::from(self.diagonal());
        let reach = if min > 0.0 { diagonal.min(4.0 / min) } else { diagonal };
        let tau = max * diagonal;
        let limit = if s.renderer == RendererKind::Mcs { 1.0 } else { f64::from(s.mc.max_events) };
        let events = limit.min(1.0 + tau + tau * tau);
        let walks = 2.0 * (events + 1.0) + f64::from(u8::from(s.mc.view_estimate));
        (1.0 + max * reach) * walks
    }

    /// `s` with `mc_budget=auto` resolved for a frame of `size` on `ctx`'s device: its dispatch
    /// bound ([`Self::dispatch_bound`]) and whichever of whole paths and bounded work reaches an
    /// error sooner there, measured once per device (`super::mc_calibrate`).
    pub fn resolve_auto(&self, ctx: &Context, s: &RenderSettings, size: [u32; 2]) -> Result<RenderSettings> {
        let bound = self.dispatch_bound(&ctx.info.name);
        let resolved = self.resolve_mc(bound, s, size)?;
        // Measured only where it decides something: auto kept whole paths, and bounded work (which
        // needs subgroup ballots, votes and arithmetic) could replace them.
        let whole = s.mc.budget == BUDGET_AUTO
            && matches!(s.renderer, RendererKind::Mcs | RendererKind::Mcm)
            && !s.mc.debug_transmittance
            && !resolved.mc_bounded();
        if whole && ctx.info.bounded_mc() && super::mc_calibrate::cached(ctx)?.bounded() {
            return self.resolve_mc_preferring(bound, true, s, size);
        }
        Ok(resolved)
    }

    /// `s` with `mc_budget=auto` resolved for a frame of `size` on a device bounded by `bound`:
    /// 0 (one whole path per pixel) while [`Self::path_steps`] fits the dispatch, otherwise
    /// bounded work of [`AUTO_BUDGET`] steps, fewer where the dispatch allows fewer (at least 8).
    /// An explicit `mc_budget=0` past the bound is an error naming the numbers.
    pub fn resolve_mc(&self, bound: DispatchBound, s: &RenderSettings, size: [u32; 2]) -> Result<RenderSettings> {
        self.resolve_mc_preferring(bound, false, s, size)
    }

    /// [`Self::resolve_mc`], choosing bounded work for `auto` even where whole paths fit when
    /// `prefer_bounded` (the device measured it faster).
    pub fn resolve_mc_preferring(
        &self,
        bound: DispatchBound,
        prefer_bounded: bool,
        s: &RenderSettings,
        size: [u32; 2],
    ) -> Result<RenderSettings> {
        let mc = matches!(s.renderer, RendererKind::Mcs | RendererKind::Mcm) && !s.mc.debug_transmittance;
        let mut out = *s;
        if !mc {
            if out.mc.budget == BUDGET_AUTO {
                out.mc.budget = 0;
            }
            return Ok(out);
        }
        let pixels = u64::from(size[0]) * u64::from(size[1]);
        let allowed = bound.steps_per_pixel(pixels, s.mc.dispatch_ms);
        let steps = self.path_steps(s);
        match s.mc.budget {
            BUDGET_AUTO if steps <= allowed && !prefer_bounded => out.mc.budget = 0,
            BUDGET_AUTO => {
                let fits = ((allowed / 8.0).floor() as u32).saturating_mul(8);
                out.mc.budget = fits.clamp(8, AUTO_BUDGET.min(MAX_BUDGET));
            }
            0 if steps > allowed => {
                let what = match bound {
                    DispatchBound::LoopLimit => {
                        format!("llvmpipe stops a SIMD row's loops at {LOOP_LIMIT} iterations (pixels would be cut short and silently wrong)")
                    }
                    DispatchBound::Time { steps_per_s } => format!(
                        "past mc_dispatch_ms={} at {size:?} ({allowed:.0} steps per pixel at {steps_per_s:.1e} steps/s; a GPU watchdog resets the device after ~2 s)",
                        s.mc.dispatch_ms
                    ),
                };
                return Err(Error::Input(format!(
                    "mc_budget=0: one whole path per pixel here can take about {steps:.0} tracking steps, and {what}; use mc_budget=auto (the default) or bounded work such as mc_budget=512"
                )));
            }
            _ => {}
        }
        Ok(out)
    }
}
