//! When a Monte Carlo image is done: its estimated relative error (`super::variance`), the target
//! a run stops at, and adaptive sampling's settings, with their keys in the volume schema.

use super::settings::VolumeSetup;
use crate::field;
use crate::settings::{Key, Range};

/// Adaptive sampling and the error target of a Monte Carlo run.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ConvergenceSettings {
    /// Adaptive sampling: 8×8 tiles whose estimated relative error is at most the target get no
    /// more paths (bounded work gives their budget to the others); off keeps every pixel sampled
    /// alike, as without it.
    pub adaptive: bool,
    /// The tiles' target relative error when `until_error` is not set.
    pub adaptive_error: f32,
    /// Paths every pixel of a tile has before the tile may stop.
    pub adaptive_min_paths: u32,
    /// Headless and Python runs end once the image's estimated relative error (foreground) is at
    /// most this, or after their frame count; 0: the frame count alone. With adaptive sampling it
    /// is also the tiles' target.
    pub until_error: f32,
}

impl Default for ConvergenceSettings {
    fn default() -> Self {
        Self { adaptive: false, adaptive_error: 0.02, adaptive_min_paths: 16, until_error: 0.0 }
    }
}

impl ConvergenceSettings {
    /// The relative error an adaptive tile stops at.
    pub fn tile_target(&self) -> f32 {
        if self.until_error > 0.0 {
            self.until_error
        } else {
            self.adaptive_error
        }
    }
}

pub(super) static CONVERGENCE: [Key<VolumeSetup>; 4] = [
    field!(pair "adaptive", "Convergence", "Monte Carlo: 8×8 tiles whose estimated relative error is below the target get no more paths; bounded work gives their budget to the noisiest tiles",
        ["off", "on"], |s| s.render.mc.convergence.adaptive),
    field!(float "adaptive_error", "Convergence", "adaptive sampling: the relative error a tile stops at (until_error replaces it when set)",
        Range::closed(1e-4, 1.0), Some((1e-3, 0.5)), true, |s| s.render.mc.convergence.adaptive_error),
    field!(int "adaptive_min_paths", "Convergence", "adaptive sampling: paths every pixel of a tile has before the tile may stop", 2, 65536, 1,
        |s| s.render.mc.convergence.adaptive_min_paths),
    field!(float "until_error", "Convergence", "Monte Carlo, headless and Python: stop once the image's estimated relative error (foreground) is at most this (0: after the frame count); with adaptive sampling also the tiles' target",
        Range::closed(0.0, 1.0), Some((0.0, 0.2)), false, |s| s.render.mc.convergence.until_error),
];
