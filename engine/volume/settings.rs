//! The volume renderers' settings ([`RenderSettings`], [`McSettings`], [`OcclusionSettings`]) and
//! their schema: every key `--set`, session files and the window's panel understand, declared once.

use super::phase::PhaseFunction;
use crate::error::{Error, Result};
use crate::field;
use crate::settings::{Key, Range, Schema, Setting, Type};

pub use crate::post::ToneMap;

/// Which renderer draws the volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum RendererKind {
    /// Maximum intensity projection.
    Mip,
    /// First-hit isosurface with deferred shading.
    Iso,
    /// Emission–absorption, front to back.
    Eam,
    /// Emission–absorption, back to front (reference for the front-to-back recurrence).
    EamBackToFront,
    /// Monte Carlo single scattering.
    Mcs,
    /// Monte Carlo multiple scattering.
    Mcm,
    /// Emission–absorption with local ambient occlusion (`occlusion.rs`).
    Lao,
    /// Directional occlusion shading, slice-based (`occlusion.rs`).
    Dos,
}

impl RendererKind {
    /// Parses `mip`, `iso`, `eam`, `eam-b2f`.
    pub fn parse(s: &str) -> Result<Self> {
        Ok(match s {
            "mip" => Self::Mip,
            "iso" => Self::Iso,
            "eam" => Self::Eam,
            "eam-b2f" => Self::EamBackToFront,
            "mcs" => Self::Mcs,
            "mcm" => Self::Mcm,
            "lao" => Self::Lao,
            "dos" => Self::Dos,
            _ => {
                return Err(Error::Input(format!(
                    "--renderer `{s}`: expected mip, iso, eam, eam-b2f, mcs, mcm, lao or dos"
                )))
            }
        })
    }

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Mip => "mip",
            Self::Iso => "iso",
            Self::Eam => "eam",
            Self::EamBackToFront => "eam-b2f",
            Self::Mcs => "mcs",
            Self::Mcm => "mcm",
            Self::Lao => "lao",
            Self::Dos => "dos",
        }
    }
}

/// How shadow rays estimate transmittance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum TransmittanceEstimator {
    /// Delta tracking: 0 or 1 (the baseline).
    Delta,
    /// Ratio tracking (Novák 2014).
    Ratio,
    /// Residual ratio tracking with the cell minimum as control.
    ResidualRatio,
}

impl TransmittanceEstimator {
    /// Parses `ratio`, `residual` or `delta`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "ratio" => Some(Self::Ratio),
            "residual" => Some(Self::ResidualRatio),
            "delta" => Some(Self::Delta),
            _ => None,
        }
    }

    /// The name [`TransmittanceEstimator::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Ratio => "ratio",
            Self::ResidualRatio => "residual",
            Self::Delta => "delta",
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
            phase: super::phase::PhaseFunction::HenyeyGreenstein { g: 0.3 }.to_gpu(),
            max_events: 64,
            roulette_start: 3,
            majorant_grid: true,
            transmittance: TransmittanceEstimator::Ratio,
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
        }
    }
}

/// Per-frame renderer parameters.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct RenderSettings {
    /// Renderer.
    pub renderer: RendererKind,
    /// Ray-march step in world units (volume's largest axis = 1); `None` = half a voxel.
    pub step: Option<f32>,
    /// Iso value (normalized) for ISO.
    pub iso: f32,
    /// Direction towards the light (ISO shading).
    pub light_dir: [f32; 3],
    /// Light intensity (ISO shading).
    pub light_intensity: f32,
    /// Background radiance.
    pub background: [f32; 3],
    /// EAM early termination once transmittance falls below this.
    pub termination: f32,
    /// EAM empty-space skipping.
    pub empty_space_skipping: bool,
    /// Sub-pixel jitter (for accumulation); off renders pixel centres.
    pub jitter: bool,
    /// EAM: read gradient magnitudes from a precomputed texture instead of six fetches.
    pub precomputed_gradients: bool,
    /// Interpolate the volume and the transfer function in f32 from texel fetches instead of
    /// with the texture unit's fixed-point weights (`filter=exact`; `volume/common.glsl`).
    pub exact_filter: bool,
    /// MCS/MCM parameters.
    pub mc: McSettings,
    /// Tone mapper.
    pub tonemap: ToneMap,
    /// Exposure for Reinhard/ACES.
    pub exposure: f32,
    /// LAO / DOS parameters and the ray marchers' depth output.
    pub occlusion: OcclusionSettings,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            renderer: RendererKind::Eam,
            step: None,
            iso: 0.5,
            light_dir: [0.4, 0.8, 0.45],
            light_intensity: 1.0,
            background: [0.0; 3],
            termination: 1e-3,
            empty_space_skipping: true,
            jitter: false,
            precomputed_gradients: true,
            exact_filter: false,
            mc: McSettings::default(),
            tonemap: ToneMap::Reinhard,
            exposure: 1.0,
            occlusion: OcclusionSettings::default(),
        }
    }
}

impl RenderSettings {
    /// Checks every setting's range ([`SCHEMA`]); the error names the setting. The renderer
    /// calls it on every frame, so settings built in code are checked like parsed ones.
    pub fn validate(&self) -> Result<()> {
        SCHEMA.check(&VolumeSetup { render: *self, ..Default::default() })
    }

    /// Monte Carlo with bounded work per frame (`mc_budget` > 0; not the estimator-test mode).
    pub fn mc_bounded(&self) -> bool {
        matches!(self.renderer, RendererKind::Mcs | RendererKind::Mcm)
            && self.mc.budget > 0
            && self.mc.budget != BUDGET_AUTO
            && !self.mc.debug_transmittance
    }
}

/// LAO, DOS and depth-output parameters (`--set lao_radius=… dos_angle=… depth_threshold=…`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct OcclusionSettings {
    /// LAO: length of the occlusion rays in world units (largest box axis = 1), in (0, 1].
    pub lao_radius: f32,
    /// LAO: occlusion directions per sample (a fixed Fibonacci sphere), 1..=256.
    pub lao_samples: u32,
    /// LAO: samples along each occlusion ray, 1..=64.
    pub lao_steps: u32,
    /// DOS: half-angle of the occlusion cone in degrees, in (0, 89].
    pub dos_angle: f32,
    /// DOS: slices across the volume's depth range, 1..=2048 (one pass each).
    pub dos_slices: u32,
    /// EAM/LAO/DOS: write the depth where accumulated opacity first reaches this, in (0, 1); `None` = off.
    pub depth_threshold: Option<f32>,
    /// LAO: intensity of the spherical light, in [0, 1e6]; 0 = off (the plain shader runs).
    pub lao_light: f32,
    /// LAO: the light's centre in world units (the box is centred on the origin, largest axis 1).
    pub lao_light_pos: [f32; 3],
    /// LAO: the light's radius in world units, in [0, 10]; 0 = a point light (hard shadows).
    pub lao_light_radius: f32,
    /// LAO: shadow rays per sample, stratified over the light's cone, 1..=256.
    pub lao_light_samples: u32,
    /// LAO: weight of the ambient-occlusion term, in [0, 1e6] (1 = plain LAO; 0 = light only).
    pub lao_ambient: f32,
    /// LAO: camera-ray samples per dispatch; 0 (the default) takes as many as llvmpipe's loop
    /// limit allows. Not a user setting: the tests force small chunks to check the split.
    pub lao_chunk: u32,
}

impl Default for OcclusionSettings {
    fn default() -> Self {
        Self {
            lao_radius: 0.1,
            lao_samples: 16,
            lao_steps: 4,
            // terier/vpt `src/js/renderers/DOSRenderer.js`: `aperture` 30°, `slices` 200.
            dos_angle: 30.0,
            dos_slices: 200,
            depth_threshold: None,
            lao_light: 0.0,
            lao_light_pos: [1.0, 1.5, 1.0],
            lao_light_radius: super::occlusion::VPT_LIGHT_RADIUS,
            lao_light_samples: super::occlusion::VPT_LIGHT_SAMPLES,
            lao_ambient: 1.0,
            lao_chunk: 0,
        }
    }
}

impl OcclusionSettings {
    /// Checks every setting's range ([`SCHEMA`]); the error names the setting.
    pub fn validate(&self) -> Result<()> {
        RenderSettings { occlusion: *self, ..Default::default() }.validate()
    }
}

/// What a volume session's settings describe: the renderer's settings plus the inputs around
/// them (procedural scene, transfer function, environment map, camera) and the phase function's
/// parameters before they are packed into [`McSettings::phase`].
#[derive(Clone, Debug)]
pub struct VolumeSetup {
    /// Renderer settings.
    pub render: RenderSettings,
    /// Procedural scene (without a volume file).
    pub scene: &'static str,
    /// Procedural grid edge.
    pub n: u32,
    /// Transfer function: preset name or JSON file; `None`: the scene's own.
    pub tf: Option<String>,
    /// Environment map: `sky` or an `.exr`/`.hdr` file; `None`: constant environment.
    pub env_map: Option<String>,
    /// Phase function name.
    pub phase: &'static str,
    /// Phase asymmetry (first lobe).
    pub g: f32,
    /// Second lobe's asymmetry (mixtures).
    pub g2: f32,
    /// First lobe's weight (mixtures).
    pub w: f32,
    /// `persp` or `ortho`.
    pub camera: &'static str,
    /// Orbit yaw in radians.
    pub yaw: f32,
    /// Orbit pitch in radians.
    pub pitch: f32,
    /// Orbit distance (`None`: the distance that frames the object).
    pub distance: Option<f32>,
    /// Orbit centre in world units (`None`: the object's centre).
    pub target: Option<[f32; 3]>,
    /// Orthographic view height in world units (`None`: the height that frames the object).
    pub height: Option<f32>,
}

impl Default for VolumeSetup {
    fn default() -> Self {
        let mut s = Self {
            render: RenderSettings { background: [0.02; 3], ..Default::default() },
            scene: "cloud",
            n: 128,
            tf: None,
            env_map: None,
            phase: "hg",
            g: 0.3,
            g2: -0.3,
            w: 0.7,
            camera: "persp",
            yaw: 0.6,
            pitch: 0.35,
            distance: None,
            target: None,
            height: None,
        };
        s.pack_phase();
        s
    }
}

impl VolumeSetup {
    /// Defaults, then `settings` (later entries win), validated.
    pub fn parse(settings: &[Setting]) -> Result<Self> {
        let mut s = Self::default();
        SCHEMA.apply(&mut s, settings)?;
        s.render.validate()?;
        Ok(s)
    }

    /// The phase function the name and parameters describe.
    pub fn phase_function(&self) -> PhaseFunction {
        let (g, g2, w) = (self.g, self.g2, self.w);
        match self.phase {
            "iso" => PhaseFunction::Isotropic,
            "schlick" => PhaseFunction::Schlick { g },
            "rayleigh" => PhaseFunction::Rayleigh,
            "hg-mix" => PhaseFunction::HgMixture { g1: g, g2, w },
            "schlick-mix" => PhaseFunction::SchlickMixture { g1: g, g2, w },
            _ => PhaseFunction::HenyeyGreenstein { g },
        }
    }

    fn pack_phase(&mut self) {
        self.render.mc.phase = self.phase_function().to_gpu();
    }
}

/// Names `renderer` accepts.
pub const RENDERERS: &[&str] = &["mip", "iso", "eam", "eam-b2f", "lao", "dos", "mcs", "mcm"];
/// Procedural scenes.
pub const SCENES: &[&str] = &["cloud", "sparse", "sphere", "box", "checker", "furnace"];
const PHASES: &[&str] = &["iso", "hg", "schlick", "rayleigh", "hg-mix", "schlick-mix"];
const TONEMAPS: &[&str] = &["reinhard", "aces", "range"];

/// The name in `names` equal to `n` (choices are stored as the schema's own strings).
fn pick(names: &'static [&'static str], n: &str, or: &'static str) -> &'static str {
    names.iter().copied().find(|x| *x == n).unwrap_or(or)
}

/// Every setting of the volume renderers (`--renderer` is the `renderer` key).
pub static SCHEMA: Schema<VolumeSetup> =
    Schema { name: "volume renderer", parts: &[&RENDER, &OCCLUSION, &MONTE_CARLO, &INPUTS] };

static RENDER: [Key<VolumeSetup>; 10] = [
    Key {
        key: "renderer",
        group: "Renderer",
        doc: "which renderer draws the volume (also `--renderer`)",
        ui: true,
        ty: Type::Choice {
            names: RENDERERS,
            get: |s| s.render.renderer.name(),
            set: |s, n| {
                if let Ok(r) = RendererKind::parse(n) {
                    s.render.renderer = r;
                }
            },
        },
    },
    Key {
        key: "scene",
        group: "Renderer",
        doc: "procedural scene (without `--volume`)",
        ui: true,
        ty: Type::Choice { names: SCENES, get: |s| s.scene, set: |s, n| s.scene = pick(SCENES, n, s.scene) },
    },
    field!(choice "tonemap", "Display", "tone mapper", TONEMAPS, ToneMap::parse, ToneMap::name, |s| s.render.tonemap),
    field!(float "exposure", "Display", "exposure (Reinhard, ACES)", Range::closed(1e-4, 1e4), Some((1e-3, 1e3)), true,
        |s| s.render.exposure),
    Key {
        key: "background",
        group: "Display",
        doc: "background radiance (grey)",
        ui: true,
        ty: Type::Float {
            range: Range::at_least(0.0),
            slider: Some((0.0, 1.0)),
            log: false,
            get: |s| Some(s.render.background[0]),
            set: |s, v| s.render.background = [v; 3],
        },
    },
    field!(bool "ess", "Ray marching", "empty-space skipping (EAM)", |s| s.render.empty_space_skipping),
    field!(pair "filter", "Ray marching", "interpolation of the volume and transfer function: the texture unit's (fixed-point weights on GPUs) or exact f32 from texel fetches (every volume renderer)",
        ["hardware", "exact"], |s| s.render.exact_filter),
    Key {
        key: "step",
        group: "Ray marching",
        doc: "ray-march step in world units (largest axis = 1; default half a voxel)",
        ui: true,
        ty: Type::Float {
            range: Range::closed(1e-4, 0.5),
            slider: Some((1e-4, 0.05)),
            log: true,
            // Unset means half a voxel, which the slider shows as a 128³ volume's.
            get: |s| Some(s.render.step.unwrap_or(1.0 / 256.0)),
            set: |s, v| s.render.step = Some(v),
        },
    },
    field!(float "termination", "Ray marching", "EAM early termination below this transmittance",
        Range::closed(0.0, 1.0), Some((1e-5, 1.0)), true, |s| s.render.termination),
    field!(float "iso", "Ray marching", "iso value (normalized) for ISO", Range::closed(0.0, 1.0), None, false,
        |s| s.render.iso),
];

const OCC: &str = "Occlusion (LAO, DOS)";

static OCCLUSION: [Key<VolumeSetup>; 11] = [
    field!(float "lao_radius", "Occlusion (LAO, DOS)", "LAO occlusion ray length (world units)", Range::above(0.0, 1.0),
        Some((0.01, 1.0)), false, |s| s.render.occlusion.lao_radius),
    field!(int "lao_samples", "Occlusion (LAO, DOS)", "LAO occlusion directions per sample", 1, 256, 1,
        |s| s.render.occlusion.lao_samples),
    field!(int "lao_steps", "Occlusion (LAO, DOS)", "LAO samples along each occlusion ray", 1, 64, 1,
        |s| s.render.occlusion.lao_steps),
    field!(float "lao_light", "Occlusion (LAO, DOS)", "LAO spherical light intensity (0: off)",
        Range::closed(0.0, 1e6), Some((0.0, 100.0)), true, |s| s.render.occlusion.lao_light),
    Key {
        key: "lao_light_pos",
        group: OCC,
        doc: "LAO light centre in world units",
        ui: false,
        ty: Type::Text {
            hint: "X,Y,Z within ±1e4",
            presets: &[],
            get: |s| Some(s.render.occlusion.lao_light_pos.map(|c| c.to_string()).join(",")),
            set: |s, t| {
                s.render.occlusion.lao_light_pos = xyz(t)?;
                Ok(())
            },
        },
    },
    field!(float "lao_light_radius", "Occlusion (LAO, DOS)", "LAO light radius (0: point light)",
        Range::closed(0.0, 10.0), None, false, |s| s.render.occlusion.lao_light_radius),
    field!(int "lao_light_samples", "Occlusion (LAO, DOS)", "LAO shadow rays per sample", 1, 256, 1,
        |s| s.render.occlusion.lao_light_samples),
    field!(float "lao_ambient", "Occlusion (LAO, DOS)", "LAO ambient-occlusion weight (1: plain LAO)",
        Range::closed(0.0, 1e6), Some((0.0, 4.0)), false, |s| s.render.occlusion.lao_ambient),
    field!(float "dos_angle", "Occlusion (LAO, DOS)", "DOS occlusion cone half-angle in degrees",
        Range::above(0.0, 89.0), Some((1.0, 89.0)), false, |s| s.render.occlusion.dos_angle),
    field!(int "dos_slices", "Occlusion (LAO, DOS)", "DOS slices (one pass each)", 1, 2048, 1,
        |s| s.render.occlusion.dos_slices),
    Key {
        key: "depth_threshold",
        group: OCC,
        doc: "write the depth where opacity first reaches this (EAM, LAO, DOS; headless)",
        ui: false,
        ty: Type::Float {
            range: Range::open(0.0, 1.0),
            slider: None,
            log: false,
            get: |s| s.render.occlusion.depth_threshold,
            set: |s, v| s.render.occlusion.depth_threshold = Some(v),
        },
    },
];

static MONTE_CARLO: [Key<VolumeSetup>; 23] = [
    field!(float "density", "Monte Carlo", "multiplies the extinction", Range::closed(1e-6, 1e6), Some((1e-3, 1e3)), true,
        |s| s.render.mc.density_scale),
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
        doc: "tracking steps and events per pixel and frame, paths kept across frames (0: one whole path per pixel per frame; auto: one whole path while it fits mc_dispatch_ms or llvmpipe's loop limit, bounded work past it)",
        ui: true,
        ty: Type::Text {
            hint: "auto | 0 | 8 ..= 6000 (steps of 8)",
            presets: &["auto", "0", "64", "512"],
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
    field!(int "mc_paths", "Monte Carlo", "bounded work: completed paths per pixel and frame at most", 1, 1024, 1,
        |s| s.render.mc.paths_per_frame),
    field!(int "mc_regroup", "Monte Carlo", "bounded work: a SIMD row takes its events once this percentage of its lanes has a walk ended (100: only when all have; the image is the same)", 1, 100, 1,
        |s| s.render.mc.regroup_percent),
    field!(int "mc_interleave", "Monte Carlo", "bounded work: each frame advances one in this many 8×8 pixel tiles (the first frame of a mean all), for frames 1/N as long", 1, 16, 1,
        |s| s.render.mc.interleave),
    field!(float "mc_frame_ms", "Monte Carlo", "bounded work: steer mc_budget frame by frame toward this GPU frame time in ms (0: fixed budget)",
        Range::closed(0.0, 10000.0), Some((0.0, 500.0)), false, |s| s.render.mc.frame_ms),
    field!(pair "majorant", "Monte Carlo", "track with the majorant grid or one global majorant", ["global", "grid"],
        |s| s.render.mc.majorant_grid),
    field!(choice "transmittance", "Monte Carlo", "shadow-ray transmittance estimator", &["ratio", "residual", "delta"],
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

/// Three numbers `X,Y,Z`, finite and within ±1e4 (a point in world units).
fn xyz(t: &str) -> std::result::Result<[f32; 3], String> {
    let parts: Vec<&str> = t.split(',').collect();
    let v: Vec<f32> = parts.iter().filter_map(|p| p.trim().parse().ok()).collect();
    match v[..] {
        [x, y, z] if parts.len() == 3 && v.iter().all(|c| c.is_finite() && c.abs() <= 1e4) => Ok([x, y, z]),
        _ => Err("expected three numbers X,Y,Z within ±1e4".into()),
    }
}

/// Keys the panel does not show (the camera is edited in its own section).
const fn hidden(k: Key<VolumeSetup>) -> Key<VolumeSetup> {
    Key { ui: false, ..k }
}

static INPUTS: [Key<VolumeSetup>; 8] = [
    hidden(field!(int "n", "Inputs", "procedural grid edge", 2, 1024, 1, |s| s.n)),
    Key {
        key: "tf",
        group: "Inputs",
        doc: "transfer function: preset, ramp in data units or JSON file (default: the scene's, or chosen from a file's data and printed)",
        ui: false,
        ty: Type::Text {
            hint: "default | cloud | bone | edges | auto | mr | ct-bone | ct-soft | ct-lung | ramp:LO,HI | FILE.json",
            presets: &[],
            get: |s| s.tf.clone(),
            set: |s, t| {
                s.tf = Some(t.to_string());
                Ok(())
            },
        },
    },
    Key {
        key: "camera",
        group: "Inputs",
        doc: "projection",
        ui: false,
        ty: Type::Choice {
            names: &["persp", "ortho"],
            get: |s| s.camera,
            set: |s, n| s.camera = pick(&["persp", "ortho"], n, s.camera),
        },
    },
    hidden(field!(float "yaw", "Inputs", "orbit yaw in radians", Range::ANY, None, false, |s| s.yaw)),
    hidden(field!(float "pitch", "Inputs", "orbit pitch in radians", Range::ANY, None, false, |s| s.pitch)),
    Key {
        key: "target",
        group: "Inputs",
        doc: "orbit centre in world units (default: the object's centre)",
        ui: false,
        ty: Type::Text {
            hint: "X,Y,Z within ±1e4",
            presets: &[],
            get: |s| s.target.map(|t| t.map(|c| c.to_string()).join(",")),
            set: |s, t| {
                s.target = Some(xyz(t)?);
                Ok(())
            },
        },
    },
    hidden(Key {
        key: "height",
        group: "Inputs",
        doc: "orthographic view height (default: frames the object)",
        ui: false,
        ty: Type::Float {
            range: Range::positive_from(0.0),
            slider: None,
            log: false,
            get: |s| s.height,
            set: |s, v| s.height = Some(v),
        },
    }),
    hidden(Key {
        key: "distance",
        group: "Inputs",
        doc: "orbit distance (default: the volume's box fills 90 % of the view)",
        ui: false,
        ty: Type::Float {
            range: Range::positive_from(0.0),
            slider: None,
            log: false,
            get: |s| s.distance,
            set: |s, v| s.distance = Some(v),
        },
    }),
];
