//! The Monte Carlo renderers' settings ([`McSettings`]) and their keys in the volume schema.

use super::settings::{pick, VolumeSetup, PHASES};
use crate::field;
use crate::settings::{Key, Range, Type};

/// How shadow rays estimate transmittance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum TransmittanceEstimator {
    /// The default: delta tracking for multiple scattering, ratio tracking otherwise
    /// ([`TransmittanceEstimator::resolve`]).
    Auto,
    /// Delta tracking: 0 or 1 (the baseline).
    Delta,
    /// Ratio tracking (Novák 2014).
    Ratio,
    /// Residual ratio tracking with the cell minimum as control.
    ResidualRatio,
}

impl TransmittanceEstimator {
    /// Parses `auto`, `ratio`, `residual` or `delta`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(Self::Auto),
            "ratio" => Some(Self::Ratio),
            "residual" => Some(Self::ResidualRatio),
            "delta" => Some(Self::Delta),
            _ => None,
        }
    }

    /// The name [`TransmittanceEstimator::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Ratio => "ratio",
            Self::ResidualRatio => "residual",
            Self::Delta => "delta",
        }
    }

    /// The estimator `Auto` stands for. Multiple scattering (`multiple`): delta tracking, as a
    /// shadow ray then ends at its first real collision. A path's many shadow rays each carry a
    /// small part of its radiance, so their cost counts more than their variance: on llvmpipe
    /// (bounded work, 256²) delta's variance × time was 0.83–0.97× ratio tracking's on vpt's
    /// cloud, the MR template, the quick start's cloud and the OpenVDB cloud. Otherwise ratio
    /// tracking: single scattering's one shadow ray is most of the image (ratio's variance × time
    /// 0.7–0.9× delta's with the sun, 1.1× under the environment alone), and the view-ray
    /// estimate and the transmittance test mode exist for ratio tracking's lower variance.
    pub fn resolve(self, multiple: bool, view_estimate: bool, debug: bool) -> Self {
        match self {
            Self::Auto if multiple && !view_estimate && !debug => Self::Delta,
            Self::Auto => Self::Ratio,
            other => other,
        }
    }
}

/// Monte Carlo renderer parameters.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct McSettings {
    /// Direction towards the sun; `None` turns it off.
    pub sun_dir: Option<[f32; 3]>,
    /// Sun radiance (RGB).
    pub sun_radiance: [f32; 3],
    /// Point light: world position and radiant intensity (RGB); `None` turns it off.
    pub point_light: Option<([f32; 3], [f32; 3])>,
    /// Constant environment radiance (RGB).
    pub env_radiance: [f32; 3],
    /// Multiplies the transfer function's extinction.
    pub density_scale: f32,
    /// Emissive media: the medium emits σa·S·c (c the transfer function's colour, the one EAM
    /// emits); 0 (the default) emits nothing and runs none of the emission code.
    pub emission: f32,
    /// Multiplies the transfer function's colour as the single-scattering albedo; 1 (the
    /// default) scatters as before, 0 makes the medium absorb (and emit) only.
    pub albedo: f32,
    /// Phase function packed as the shader's `Phase` (kind, g, g2, w as bits).
    pub phase: [u32; 4],
    /// Maximum scattering events for MCM (MCS always uses 1).
    pub max_events: u32,
    /// Russian roulette from this scattering event on.
    pub roulette_start: u32,
    /// Track with the majorant grid (true) or one global majorant.
    pub majorant_grid: bool,
    /// Shadow-ray transmittance estimator.
    pub transmittance: TransmittanceEstimator,
    /// Test mode: output the camera ray's transmittance estimate instead of radiance.
    pub debug_transmittance: bool,
    /// The environment seen straight through the medium: estimated along the camera ray by the
    /// `transmittance` estimator (one extra walk per path), instead of counted only when the path
    /// escapes unscattered — a coin flip per path, as vpt does, and all the signal of a channel
    /// whose albedo is 0. Off by default: on vpt's scene it cost more time than it saved.
    pub view_estimate: bool,
    /// The environment estimated along each flight of the path (the next-flight estimator): one
    /// walk delta-tracks the next collision and ratio-tracks the transmittance to the box at the
    /// same tentative points, and β·T·L_env is the vertex's whole environment term — no
    /// environment NEE ray, no MIS, nothing at the escape, and the camera ray's estimate for free.
    /// Off: NEE of the environment with MIS against the escape.
    pub env_flight: bool,
    /// Multiplies every majorant; 1 is correct. Below 1 the trackers are biased and must report
    /// violations (how the tests prove the counter works).
    pub majorant_scale: f32,
    /// Light with the environment map set by `VolumeRenderer::set_environment` instead of the
    /// constant `env_radiance` (an error if none is set).
    pub env_map: bool,
    /// Multiplies the environment map's radiance.
    pub env_intensity: f32,
    /// Turns the environment map about +Y (world up), in degrees.
    pub env_rotation_deg: f32,
    /// Hybrid scattering blend factor in [0, 1]: 0 scatters by the phase function only.
    pub hybrid: f32,
    /// Bounded work: tracking steps and events per pixel and frame, the paths persisting
    /// across frames (`mc_bounded.comp`); 0 traces one whole path per pixel per frame (`mc.comp`);
    /// [`BUDGET_AUTO`] (the default) picks per device and scene (`super::mc_mode`).
    pub budget: u32,
    /// GPU time one Monte Carlo dispatch may take, in ms, on a device without llvmpipe's loop
    /// limit: what `mc_budget=auto` keeps one whole path per frame under, and refuses
    /// `mc_budget=0` past (far under a desktop GPU's ~2 s watchdog).
    pub dispatch_ms: f32,
    /// Bounded work: completed paths per pixel and frame at most (a pixel whose paths are short
    /// stops there instead of spending its whole budget on them).
    pub paths_per_frame: u32,
    /// Bounded work: a SIMD row's walks in progress pause (in registers) for the others' events
    /// once this percentage of its lanes has a walk ended, instead of idling until the row's
    /// longest walk ends (100). Each lane's own sequence of steps is unchanged, so the image is
    /// too; only the schedule, and so the time, changes.
    pub regroup_percent: u32,
    /// Bounded work: each frame advances one in `interleave` of the image's 8×8-pixel tiles (the
    /// first frame of a mean all of them), so a frame costs about 1/`interleave` of a full one
    /// and every pixel is advanced every `interleave` frames: short frames without the fixed
    /// per-pixel cost of a dispatch (its path-state load and store) eating the budget.
    pub interleave: u32,
    /// Bounded work: the GPU frame time (ms) the host steers `budget` toward, frame by frame
    /// ([`McSettings::steer_budget`]); 0 keeps the budget fixed.
    pub frame_ms: f32,
    /// Random stream: the same seed and frame index give the same image, another seed an
    /// independent one (the demos' `--seed`).
    pub seed: u32,
    /// Adaptive sampling and the run's error target (`super::convergence`).
    pub convergence: super::convergence::ConvergenceSettings,
}

impl McSettings {
    /// Bounded work: the budget of a mean's first frame, which advances every tile: with
    /// interleaving 1/`interleave` of `budget` (in steps of 8), so that frame is no longer than
    /// the others.
    pub fn first_budget(&self) -> u32 {
        match self.interleave {
            0 | 1 => self.budget,
            k => (self.budget / k).next_multiple_of(8).clamp(8, self.budget.max(8)),
        }
    }

    /// The next frame's budget for a `frame_ms` target after a frame of `last_ms` at `budget`:
    /// proportional (frame time is linear in the budget), at most doubling or halving per frame
    /// so one slow frame (a compile, a resize) does not swing it, in steps of 8 within 8 ..= `MAX_BUDGET`.
    pub fn steer_budget(&self, budget: u32, last_ms: f64) -> u32 {
        if self.frame_ms <= 0.0 || last_ms.is_nan() || last_ms <= 0.0 || budget == 0 || budget == BUDGET_AUTO {
            return budget;
        }
        let f = (f64::from(self.frame_ms) / last_ms).clamp(0.5, 2.0);
        // In steps of 8, as the setting is.
        ((f64::from(budget) * f / 8.0).round() as u32 * 8).clamp(8, MAX_BUDGET)
    }
}

/// Largest `mc_budget` (10 × 6,000 + 1 loop iterations per 8-lane row, under llvmpipe's 65,535).
pub const MAX_BUDGET: u32 = 6000;

/// `mc_budget=auto`: one whole path per frame or bounded work, chosen per device and scene
/// (`super::mc_mode`); resolved before a frame is built.
pub const BUDGET_AUTO: u32 = u32::MAX;

/// Parses `mc_budget`: `auto`, or 0 ..= [`MAX_BUDGET`] in steps of 8.
fn parse_budget(v: &str) -> std::result::Result<u32, String> {
    if v.trim() == "auto" {
        return Ok(BUDGET_AUTO);
    }
    match v.trim().parse::<u32>() {
        Ok(n) if n <= MAX_BUDGET && n % 8 == 0 => Ok(n),
        _ => Err(format!("`{v}`: expected auto, or 0 ..= {MAX_BUDGET} in steps of 8")),
    }
}

impl Default for McSettings {
    fn default() -> Self {
        Self {
            sun_dir: Some([0.4, 0.8, 0.45]),
            sun_radiance: [3.0; 3],
            point_light: None,
            env_radiance: [0.3, 0.35, 0.45],
            density_scale: 1.0,
            emission: 0.0,
            albedo: 1.0,
            phase: crate::volume::optics::phase::PhaseFunction::HenyeyGreenstein { g: 0.3 }.to_gpu(),
            max_events: 64,
            roulette_start: 3,
            majorant_grid: true,
            transmittance: TransmittanceEstimator::Auto,
            debug_transmittance: false,
            view_estimate: false,
            env_flight: false,
            majorant_scale: 1.0,
            env_map: false,
            env_intensity: 1.0,
            env_rotation_deg: 0.0,
            hybrid: 0.0,
            budget: BUDGET_AUTO,
            dispatch_ms: 100.0,
            paths_per_frame: 4,
            regroup_percent: 25,
            interleave: 1,
            frame_ms: 0.0,
            seed: 0,
            convergence: Default::default(),
        }
    }
}

pub(super) static MONTE_CARLO: [Key<VolumeSetup>; 25] = [
    field!(float "density", "Monte Carlo", "multiplies the extinction", Range::closed(1e-6, 1e6), Some((1e-3, 1e3)), true,
        |s| s.render.mc.density_scale),
    field!(float "emission", "Monte Carlo", "emissive medium: emits σa·S·c, c the transfer function's colour (0: no emission)",
        Range::closed(0.0, 1e6), Some((0.0, 10.0)), false, |s| s.render.mc.emission),
    field!(float "albedo", "Monte Carlo", "multiplies the transfer function's colour as the single-scattering albedo (0: absorbs and emits only)",
        Range::closed(0.0, 1.0), None, false, |s| s.render.mc.albedo),
    Key {
        key: "phase",
        group: "Monte Carlo",
        doc: "phase function",
        ui: true,
        ty: Type::Choice {
            names: PHASES,
            get: |s| s.phase,
            set: |s, n| {
                s.phase = pick(PHASES, n, s.phase);
                s.pack_phase();
            },
        },
    },
    Key {
        key: "g",
        group: "Monte Carlo",
        doc: "asymmetry (first lobe)",
        ui: true,
        ty: Type::Float {
            range: Range::closed(-1.0, 1.0),
            slider: None,
            log: false,
            get: |s| Some(s.g),
            set: |s, v| {
                s.g = v;
                s.pack_phase();
            },
        },
    },
    Key {
        key: "g2",
        group: "Monte Carlo",
        doc: "second lobe's asymmetry (mixtures)",
        ui: true,
        ty: Type::Float {
            range: Range::closed(-1.0, 1.0),
            slider: None,
            log: false,
            get: |s| Some(s.g2),
            set: |s, v| {
                s.g2 = v;
                s.pack_phase();
            },
        },
    },
    Key {
        key: "w",
        group: "Monte Carlo",
        doc: "first lobe's weight (mixtures)",
        ui: true,
        ty: Type::Float {
            range: Range::closed(0.0, 1.0),
            slider: None,
            log: false,
            get: |s| Some(s.w),
            set: |s, v| {
                s.w = v;
                s.pack_phase();
            },
        },
    },
    field!(int "bounces", "Monte Carlo", "maximum scattering events (MCM)", 1, 4096, 1, |s| s.render.mc.max_events),
    // 6,000: an 8-lane row then runs at most 10 × 6,000 + 1 loop iterations per dispatch, under
    // llvmpipe's 65,535 (an environment map's searches lower it; the renderer checks).
    Key {
        key: "mc_budget",
        group: "Monte Carlo",
        doc: "tracking steps and events per pixel and frame, paths kept across frames (0: one whole path per pixel per frame; auto: of one whole path per frame, where it fits mc_dispatch_ms or llvmpipe's loop limit, and bounded work, whichever reached an error sooner when measured once on this device)",
        ui: true,
        ty: Type::Text {
            hint: "auto | 0 | 8 ..= 6000 (steps of 8)",
            presets: &["auto", "0", "64", "512"],
            sliders: None,
            get: |s| Some(match s.render.mc.budget {
                BUDGET_AUTO => "auto".to_string(),
                n => n.to_string(),
            }),
            set: |s, v| {
                s.render.mc.budget = parse_budget(v)?;
                Ok(())
            },
        },
    },
    field!(float "mc_dispatch_ms", "Monte Carlo", "GPU time one Monte Carlo dispatch may take (ms): mc_budget=auto keeps whole paths under it, mc_budget=0 past it is refused (not on llvmpipe, whose loop limit rules)",
        Range::closed(1.0, 1000.0), Some((10.0, 1000.0)), false, |s| s.render.mc.dispatch_ms),
    field!(int "mc_paths", "Monte Carlo", "bounded work: completed paths per pixel and frame, on average over a SIMD row (each pixel at least one unless the budget ends first, at most 4× as many where its neighbours' paths are longer)", 1, 1024, 1,
        |s| s.render.mc.paths_per_frame),
    field!(int "mc_regroup", "Monte Carlo", "bounded work: a SIMD row takes its events once this percentage of its lanes has a walk ended (100: only when all have; the image is the same)", 1, 100, 1,
        |s| s.render.mc.regroup_percent),
    field!(int "mc_interleave", "Monte Carlo", "bounded work: each frame advances one in this many 8×8 pixel tiles (the first frame of a mean all), for frames 1/N as long", 1, 16, 1,
        |s| s.render.mc.interleave),
    field!(float "mc_frame_ms", "Monte Carlo", "bounded work: steer mc_budget frame by frame toward this GPU frame time in ms (0: fixed budget)",
        Range::closed(0.0, 10000.0), Some((0.0, 500.0)), false, |s| s.render.mc.frame_ms),
    field!(pair "majorant", "Monte Carlo", "track with the majorant grid or one global majorant", ["global", "grid"],
        |s| s.render.mc.majorant_grid),
    field!(choice "transmittance", "Monte Carlo", "shadow-ray transmittance estimator (auto: delta tracking for multiple scattering without view_ray=estimate, ratio tracking otherwise)", &["auto", "ratio", "residual", "delta"],
        TransmittanceEstimator::parse, TransmittanceEstimator::name, |s| s.render.mc.transmittance),
    field!(pair "view_ray", "Monte Carlo", "the environment seen through the medium: estimated along the camera ray by the transmittance estimator, or counted when a path escapes unscattered (vpt's coin flip)",
        ["escape", "estimate"], |s| s.render.mc.view_estimate),
    field!(pair "env_light", "Monte Carlo", "the environment's light at each vertex: by NEE (a shadow ray, MIS with the escape) or along the path's next flight (its walk also ratio-tracks the transmittance; no shadow ray)",
        ["nee", "flight"], |s| s.render.mc.env_flight),
    Key {
        key: "sun",
        group: "Lights",
        doc: "the sun",
        ui: true,
        ty: Type::Bool {
            get: |s| s.render.mc.sun_dir.is_some(),
            set: |s, on| s.render.mc.sun_dir = if on { McSettings::default().sun_dir } else { None },
        },
    },
    Key {
        key: "point",
        group: "Lights",
        doc: "point light above the volume with this intensity (default: none)",
        ui: true,
        ty: Type::Float {
            range: Range::closed(0.0, 1e9),
            slider: Some((0.0, 100.0)),
            log: true,
            get: |s| Some(s.render.mc.point_light.map_or(0.0, |(_, i)| i[0])),
            // A point light above and in front of the volume; its intensity is the value.
            set: |s, v| s.render.mc.point_light = Some(([0.6, 0.9, 0.8], [v; 3])),
        },
    },
    Key {
        key: "env",
        group: "Lights",
        doc: "constant environment radiance (grey)",
        ui: true,
        ty: Type::Float {
            range: Range::closed(0.0, 1e6),
            slider: Some((0.0, 4.0)),
            log: false,
            get: |s| Some(s.render.mc.env_radiance[0]),
            set: |s, v| s.render.mc.env_radiance = [v; 3],
        },
    },
    Key {
        key: "env_map",
        group: "Lights",
        doc: "environment map: the procedural sky or an .exr/.hdr file",
        ui: true,
        ty: Type::Text {
            hint: "off | sky | FILE.exr | FILE.hdr",
            presets: &["off", "sky"],
            sliders: None,
            get: |s| Some(s.env_map.clone().unwrap_or_else(|| "off".into())),
            set: |s, t| {
                s.env_map = (t != "off").then(|| t.to_string());
                s.render.mc.env_map = s.env_map.is_some();
                Ok(())
            },
        },
    },
    field!(float "env_intensity", "Lights", "multiplies the environment map", Range::closed(0.0, 1e6), Some((1e-2, 1e2)),
        true, |s| s.render.mc.env_intensity),
    field!(float "env_rotation", "Lights", "turns the environment map about +Y, degrees", Range::closed(-360.0, 360.0),
        None, false, |s| s.render.mc.env_rotation_deg),
    field!(float "hybrid", "Lights", "hybrid scattering blend (0: phase function only)", Range::closed(0.0, 1.0), None,
        false, |s| s.render.mc.hybrid),
];

#[cfg(test)]
mod tests {
    use super::TransmittanceEstimator::{self, *};

    #[test]
    fn auto_is_delta_only_for_multiple_scattering_without_a_view_ray_estimate() {
        let auto = |multiple, view, debug| Auto.resolve(multiple, view, debug);
        assert_eq!(auto(true, false, false), Delta);
        assert_eq!(auto(false, false, false), Ratio);
        assert_eq!(auto(true, true, false), Ratio);
        assert_eq!(auto(true, false, true), Ratio);
        for e in [Delta, Ratio, ResidualRatio] {
            assert_eq!(e.resolve(true, false, false), e, "an explicit choice is kept");
            assert_eq!(e.resolve(false, true, true), e, "an explicit choice is kept");
        }
        assert_eq!(TransmittanceEstimator::parse("auto"), Some(Auto));
    }
}
