//! The volume renderers' settings ([`RenderSettings`], [`McSettings`], [`OcclusionSettings`]) and
//! their schema: every key `--set`, session files and the window's panel understand, declared once.

use crate::error::{Error, Result};
use crate::field;
use crate::settings::{Key, Range, Schema, Setting, Type};
use crate::volume::optics::phase::PhaseFunction;

pub use super::clip_settings::ClipSettings;
use super::clip_settings::CLIPPING;
use super::convergence::CONVERGENCE;
use super::label_settings::LABEL_KEYS;
use super::mc_settings::MONTE_CARLO;
pub use super::mc_settings::{McSettings, TransmittanceEstimator, BUDGET_AUTO, MAX_BUDGET};
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
    /// MCS/MCM: the denoised image (`super::denoise`).
    pub denoise: super::denoise::DenoiseSettings,
    /// Tone mapper.
    pub tonemap: ToneMap,
    /// Exposure for Reinhard/ACES.
    pub exposure: f32,
    /// LAO / DOS parameters and the ray marchers' depth output.
    pub occlusion: OcclusionSettings,
    /// Crop box and clip planes (every renderer).
    pub clip: ClipSettings,
    /// Label maps: mode and hidden labels (every renderer; `label_settings`).
    pub labels: super::label_settings::LabelSettings,
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
            denoise: Default::default(),
            tonemap: ToneMap::Reinhard,
            exposure: 1.0,
            occlusion: OcclusionSettings::default(),
            clip: ClipSettings::default(),
            labels: Default::default(),
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

    /// The shadow rays' transmittance estimator these settings render with (`transmittance=auto`
    /// resolved by [`TransmittanceEstimator::resolve`]).
    pub fn transmittance_estimator(&self) -> TransmittanceEstimator {
        self.mc.transmittance.resolve(
            self.renderer == RendererKind::Mcm,
            self.mc.view_estimate,
            self.mc.debug_transmittance,
        )
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
    /// OpenVDB: the grid of temperatures (kelvin) that drives the Monte Carlo emission; `None`: the
    /// transfer function's colour does.
    pub temperature_grid: Option<String>,
    /// Kelvin the blackbody emission spans: colder emits nothing, `[1]` has luminance 1.
    pub temperature_range: [f32; 2],
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
    /// How the volume is stored on the device (`volume_layout`).
    pub layout: crate::volume::device::layout::VolumeLayout,
    /// Bytes of GPU memory a loaded volume may take (`gpu_memory`; `None`: the device-local heap).
    pub gpu_memory: Option<u64>,
    /// Pyramid level a file loaded into bricks is shown at (`lod`; `None`: the finest that fits).
    pub lod: Option<u32>,
    /// View-dependent residency (`residency=view`): the brick pyramid on the host, the bricks
    /// the view needs on the device within `gpu_memory`.
    pub residency: bool,
    /// Bytes residency uploads at most per frame (`upload_budget`).
    pub upload_budget: u64,
    /// Label map and colour table files (`labels`, `label_colors`).
    pub labels: super::label_settings::LabelFiles,
}

impl Default for VolumeSetup {
    fn default() -> Self {
        let mut s = Self {
            render: RenderSettings { background: [0.02; 3], ..Default::default() },
            scene: "cloud",
            n: 128,
            tf: None,
            env_map: None,
            temperature_grid: None,
            temperature_range: [1000.0, 3000.0],
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
            layout: crate::volume::device::layout::VolumeLayout::Auto,
            gpu_memory: None,
            lod: None,
            residency: false,
            upload_budget: 256 << 10,
            labels: Default::default(),
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

    pub(super) fn pack_phase(&mut self) {
        self.render.mc.phase = self.phase_function().to_gpu();
    }
}

/// Names `renderer` accepts.
pub const RENDERERS: &[&str] = &["mip", "iso", "eam", "eam-b2f", "lao", "dos", "mcs", "mcm"];
/// Procedural scenes.
pub const SCENES: &[&str] = &["cloud", "sparse", "sphere", "box", "checker", "furnace"];
pub(super) const PHASES: &[&str] = &["iso", "hg", "schlick", "rayleigh", "hg-mix", "schlick-mix"];
const TONEMAPS: &[&str] = &["reinhard", "aces", "range"];

/// The name in `names` equal to `n` (choices are stored as the schema's own strings).
pub(super) fn pick(names: &'static [&'static str], n: &str, or: &'static str) -> &'static str {
    names.iter().copied().find(|x| *x == n).unwrap_or(or)
}

/// Every setting of the volume renderers (`--renderer` is the `renderer` key).
pub static SCHEMA: Schema<VolumeSetup> = Schema {
    name: "volume renderer",
    parts: &[
        &RENDER,
        &OCCLUSION,
        &MONTE_CARLO,
        &CONVERGENCE,
        &super::denoise::DENOISE,
        &CLIPPING,
        &LABEL_KEYS,
        &INPUTS,
    ],
};

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
            sliders: None,
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

/// Three numbers `X,Y,Z`, finite and within ±1e4 (a point in world units).
pub(super) fn xyz(t: &str) -> std::result::Result<[f32; 3], String> {
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

/// A byte count: digits with an optional binary suffix K, M or G (KiB, MiB, GiB), at least 1.
fn bytes(t: &str) -> std::result::Result<u64, String> {
    let t = t.trim();
    let u = t.to_ascii_uppercase();
    let u = u.strip_suffix("IB").or_else(|| u.strip_suffix('B')).unwrap_or(&u);
    let (digits, shift) = match u.chars().last() {
        Some('K') => (&u[..u.len() - 1], 10),
        Some('M') => (&u[..u.len() - 1], 20),
        Some('G') => (&u[..u.len() - 1], 30),
        _ => (u, 0),
    };
    match digits.trim().parse::<u64>() {
        Ok(n) if n > 0 && n.leading_zeros() >= shift => Ok(n << shift),
        _ => Err(format!("`{t}`: expected a byte count of at least 1, e.g. 1500000, 512M or 2G")),
    }
}

static INPUTS: [Key<VolumeSetup>; 15] = [
    Key {
        key: "temperature_grid",
        group: "Inputs",
        doc: "OpenVDB: the grid of temperatures (kelvin, on the density grid's box) whose blackbody radiance the Monte Carlo renderers emit, × emission (none: the transfer function's colour)",
        ui: false,
        ty: Type::Text {
            hint: "none | NAME",
            presets: &[],
            sliders: None,
            get: |s| Some(s.temperature_grid.clone().unwrap_or_else(|| "none".into())),
            set: |s, t| {
                s.temperature_grid = (t != "none").then(|| t.to_string());
                Ok(())
            },
        },
    },
    Key {
        key: "temperature_range",
        group: "Inputs",
        doc: "kelvin the blackbody emission spans: colder emits nothing, HI has luminance 1 (hotter is clamped)",
        ui: false,
        ty: Type::Text {
            hint: "LO,HI with 0 < LO < HI",
            presets: &[],
            sliders: None,
            get: |s| Some(format!("{},{}", s.temperature_range[0], s.temperature_range[1])),
            set: |s, t| {
                let v: Vec<f32> = t.split(',').map(|c| c.trim().parse::<f32>()).collect::<std::result::Result<_, _>>().map_err(|_| format!("`{t}`: expected LO,HI in kelvin"))?;
                match v[..] {
                    [lo, hi] if lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo => {
                        s.temperature_range = [lo, hi];
                        Ok(())
                    }
                    _ => Err(format!("`{t}`: expected LO,HI in kelvin with 0 < LO < HI")),
                }
            },
        },
    },
    hidden(field!(int "n", "Inputs", "procedural grid edge", 2, 1024, 1, |s| s.n)),
    Key {
        key: "gpu_memory",
        group: "Inputs",
        doc: "GPU memory a loaded volume may take (default: the device-local heap); a file loaded into bricks past it is shown at the finest pyramid level that fits",
        ui: false,
        ty: Type::Text {
            hint: "BYTES, or with K, M or G (binary)",
            presets: &[],
            sliders: None,
            get: |s| s.gpu_memory.map(|b| b.to_string()),
            set: |s, t| {
                s.gpu_memory = Some(bytes(t)?);
                Ok(())
            },
        },
    },
    Key {
        key: "lod",
        group: "Inputs",
        doc: "pyramid level a file loaded into bricks is shown at, each level halving the voxels along every axis by block means; auto: the finest whose bricks fit the GPU memory, 0: full resolution or refused",
        ui: false,
        ty: Type::Text {
            hint: "auto | 0..=27",
            presets: &[],
            sliders: None,
            get: |s| Some(s.lod.map_or("auto".to_string(), |l| l.to_string())),
            set: |s, t| {
                s.lod = match t.trim() {
                    "auto" => None,
                    n => match n.parse::<u32>() {
                        Ok(k) if k <= crate::volume::data::bricks::pyramid::MAX_LEVEL => Some(k),
                        _ => return Err(format!("`{t}`: expected auto or a level 0..=27")),
                    },
                };
                Ok(())
            },
        },
    },
    Key {
        key: "residency",
        group: "Inputs",
        doc: "view: keep the volume's brick pyramid on the host and, within gpu_memory (default: the device-local heap), the finest bricks where the view needs them on the device (in the frustum, nearest the eye), coarser ones elsewhere, updated every frame; a changed residency restarts the progressive mean; off: the volume as loaded",
        ui: false,
        ty: Type::Choice {
            names: &["off", "view"],
            get: |s| if s.residency { "view" } else { "off" },
            set: |s, n| s.residency = n == "view",
        },
    },
    Key {
        key: "upload_budget",
        group: "Inputs",
        doc: "bytes residency=view uploads at most per frame (bricks and page-table words), so a moving camera never waits on a whole new residency",
        ui: false,
        ty: Type::Text {
            hint: "BYTES, or with K, M or G (binary)",
            presets: &[],
            sliders: None,
            get: |s| Some(s.upload_budget.to_string()),
            set: |s, t| {
                s.upload_budget = bytes(t)?;
                Ok(())
            },
        },
    },
    Key {
        key: "volume_layout",
        group: "Inputs",
        doc: "how the volume is stored on the device: dense images, or 8³ bricks behind a page table (only bricks that vary are stored; past the 3D-image limit); auto: dense where it fits and is small or mostly occupied",
        ui: false,
        ty: Type::Choice {
            names: crate::volume::device::layout::VolumeLayout::NAMES,
            get: |s| s.layout.name(),
            set: |s, n| {
                if let Ok(l) = crate::volume::device::layout::VolumeLayout::parse(n) {
                    s.layout = l;
                }
            },
        },
    },
    Key {
        key: "tf",
        group: "Inputs",
        doc: "transfer function: preset, ramp in data units or JSON file (default: the scene's, or chosen from a file's data and printed)",
        ui: false,
        ty: Type::Text {
            hint: "default | cloud | bone | edges | auto | mr | ct-bone | ct-soft | ct-lung | ramp:LO,HI | FILE.json",
            presets: &[],
            sliders: None,
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
            sliders: None,
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
