//! `mc_budget=auto`'s choice per device by measurement: of the two bounded ways to run Monte
//! Carlo, one whole path per pixel per frame (where the device's dispatch bound allows it,
//! `super::mc_mode`) and bounded work, the one that reaches a given error sooner. Each is run
//! on a small synthetic scene shaped like vpt's (a dense fBm cloud, up to 8 events, a white
//! environment), interleaved over a few rounds; its cost is the image's estimated relative
//! variance (from the pixels' second moments) times the GPU seconds it took, so the time to a
//! relative error e is cost / e². On llvmpipe, whose SIMD rows wait for their longest path,
//! bounded work regroups paths and wins (vpt's scene: 0.34× vpt's time against one whole path's
//! 0.53×); on an H200 one whole path per frame reached Mitsuba's error 1.17× sooner. Measured
//! once per device and process, like the LPV's layout (`crate::lpv::passes::calibrate`).

use super::frame::{render_frame, Targets};
use super::renderer::VolumeRenderer;
use super::settings::VolumeSetup;
use crate::settings::{Origin, Setting};
use crate::vk::Context;
use crate::volume::camera::{Camera, Projection};
use crate::volume::data::procedural;
use crate::volume::optics::tf::TransferFunction;
use crate::Result;
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Both ways' cost on the synthetic scene: relative variance × GPU seconds (medians over the
/// rounds; lower reaches an error sooner).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Measured {
    /// One whole path per pixel per frame (`mc_budget=0`).
    pub whole_cost: f64,
    /// Bounded work of `super::mc_mode::AUTO_BUDGET` steps, 4 paths kept.
    pub bounded_cost: f64,
}

/// Bounded work must cost less than this share of whole paths' to be chosen. The choice changes
/// the image (the two draw different random numbers), so a measurement near the margin would make
/// the default image differ between runs of the same command: on llvmpipe the ratio measured
/// 0.98–1.04 in release builds, 0.80–0.85 in debug builds under the validation layer and 2.0 in
/// debug builds without it; an H200 ran whole paths 1.17× faster. Only a twofold gain switches.
pub const BOUNDED_MARGIN: f64 = 0.5;

impl Measured {
    /// Bounded work reaches an error sooner by the margin.
    pub fn bounded(&self) -> bool {
        self.bounded_cost < BOUNDED_MARGIN * self.whole_cost
    }
}

/// Image edge of the measurement.
const SIZE: u32 = 64;
/// Rounds (each way once per round, interleaved).
const ROUNDS: u64 = 3;
/// Frames per way and round: enough that every pixel has the two paths a variance needs.
const FRAMES: u64 = 6;

/// Every measurement of this process, per device name.
static MEASURED: OnceLock<Mutex<HashMap<String, Measured>>> = OnceLock::new();

/// The measurement for `ctx`'s device: made on first use (and reported on stderr), then cached.
pub fn cached(ctx: &Context) -> Result<Measured> {
    let map = MEASURED.get_or_init(|| Mutex::new(HashMap::new()));
    // Held while measuring: threads rendering at once wait for one measurement.
    let mut map = map.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(m) = map.get(&ctx.info.name) {
        return Ok(*m);
    }
    let m = measure(ctx)?;
    eprintln!(
        "mc_budget=auto on {}: bounded work {:.3e}, one whole path per frame {:.3e} (relative variance x GPU s): {}",
        ctx.info.name,
        m.bounded_cost,
        m.whole_cost,
        if m.bounded() { "bounded work" } else { "whole paths where they fit" }
    );
    map.insert(ctx.info.name.clone(), m);
    Ok(m)
}

/// The measurements made so far in this process (for reports).
pub fn measured() -> Vec<(String, Measured)> {
    MEASURED.get().map_or_else(Vec::new, |m| {
        m.lock().unwrap_or_else(|e| e.into_inner()).iter().map(|(k, v)| (k.clone(), *v)).collect()
    })
}

fn setup(extra: &[(&str, &str)]) -> Result<VolumeSetup> {
    let base = [("renderer", "mcm"), ("env", "1"), ("sun", "0"), ("bounces", "8"), ("phase", "iso")];
    let all: Vec<Setting> =
        base.iter().chain(extra).map(|(k, v)| Setting::new(*k, v.to_string(), Origin::Cli)).collect();
    VolumeSetup::parse(&all)
}

fn measure(ctx: &Context) -> Result<Measured> {
    let volume = procedural::cloud([64; 3], 3).map_err(|e| crate::Error::Input(e.to_string()))?;
    // vpt's table shape: extinction ramping to 100 over the middle of the value range.
    let tf = TransferFunction::ramp(0.25, 0.75, [0.9; 3], 100.0);
    let renderer = VolumeRenderer::new(ctx, &volume, &tf)?;
    let cam = Camera::orbit(2.0, 0.0, 0.0, Projection::Perspective { fov_y: 0.8 });
    let ways = [setup(&[("mc_budget", "0")])?, setup(&[("mc_budget", "512"), ("mc_paths", "4")])?];
    let mut costs = [Vec::new(), Vec::new()];
    for round in 0..ROUNDS {
        for (way, s) in ways.iter().enumerate() {
            let mut t = Targets::new(ctx, [SIZE; 2])?;
            let mut gpu_s = 0.0;
            for f in 0..FRAMES {
                gpu_s += render_frame(ctx, &renderer, &mut t, &cam, &s.render, 2_000_000 + round * FRAMES + f)?
                    .gpu_ms()
                    * 1e-3;
            }
            if let Some(rel) = t.error_estimate().and_then(|e| e.relative) {
                costs[way].push(rel * rel * gpu_s);
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::INFINITY)
    };
    let [mut whole, mut bounded] = costs;
    Ok(Measured { whole_cost: median(&mut whole), bounded_cost: median(&mut bounded) })
}
