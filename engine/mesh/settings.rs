//! The mesh renderer's settings ([`MeshSettings`], [`FogSettings`]) and their schema: every key
//! scene files' `[settings]`, `--set` and the window's panel understand, declared once.

use crate::lpv::settings::LpvSettings;
use crate::post::ToneMap;
use crate::settings::{Key, Range, Schema, Type};
use crate::{field, Error, Result};

/// Renderer parameters (scene file `[settings]` and `--set` override them).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct MeshSettings {
    /// Shadow tile edge in texels (each cascade and each spot light gets one tile).
    pub shadow_tile: u32,
    /// Sun cascades (0 = no sun shadows).
    pub cascades: u32,
    /// Split scheme: 1 logarithmic, 0 uniform.
    pub cascade_lambda: f32,
    /// View distance the cascades cover.
    pub shadow_distance: f32,
    /// PCF radius in texels.
    pub pcf_radius: u32,
    /// Uniform ambient radiance (0 = only direct light).
    pub ambient: [f32; 3],
    /// Background radiance.
    pub sky: [f32; 3],
    /// Display transform.
    pub tonemap: ToneMap,
    /// Exposure multiplier.
    pub exposure: f32,
    /// Light propagation volumes (off: no LPV pass in the frame graph).
    pub lpv: LpvSettings,
    /// PCSS soft shadows: blocker search, penumbra from the light's size, PCF that wide (off:
    /// the plain PCF shader).
    pub soft_shadows: bool,
    /// The sun's angular diameter in degrees (its size for soft shadows).
    pub sun_angle: f32,
    /// Spot lights' emitter radius in metres (their size for soft shadows).
    pub spot_radius: f32,
    /// Screen-space sun rays: a radial blur of the sky pixels toward the sun, added to the HDR
    /// image (off: no pass).
    pub sun_rays: bool,
    /// Sun rays: radiance added per unit of sun irradiance (1/sr).
    pub sun_rays_intensity: f32,
    /// Sun rays: weight kept per sample along the blur (1 = no decay).
    pub sun_rays_decay: f32,
    /// Sun rays: samples along each pixel's ray toward the sun.
    pub sun_rays_samples: u32,
    /// Glossy reflections from the LPV: march it along the reflection vector (needs the LPV).
    pub lpv_glossy: bool,
    /// Participating medium (off: no fog pass in the frame graph).
    pub fog: FogSettings,
    /// Cull the back faces of single-sided materials (glTF `doubleSided: false`, every OBJ
    /// material) in every raster pass: camera, shadow maps, RSM.
    pub cull: bool,
    /// Cull each raster view's triangles that cannot cover a sample before drawing (same image).
    pub cull_triangles: bool,
}

impl Default for MeshSettings {
    fn default() -> Self {
        Self {
            shadow_tile: 1024,
            cascades: 3,
            cascade_lambda: 0.6,
            shadow_distance: 60.0,
            pcf_radius: 1,
            ambient: [0.02; 3],
            sky: [0.25, 0.3, 0.4],
            tonemap: ToneMap::Aces,
            exposure: 1.0,
            lpv: Default::default(),
            soft_shadows: false,
            sun_angle: 0.53,
            spot_radius: 0.05,
            sun_rays: false,
            sun_rays_intensity: 0.05,
            sun_rays_decay: 0.97,
            sun_rays_samples: 48,
            lpv_glossy: false,
            fog: Default::default(),
            cull: true,
            cull_triangles: true,
        }
    }
}

impl MeshSettings {
    /// Rejects values that would make an empty, unbounded or absurd frame: every key's range in
    /// [`SCHEMA`], then the checks that span several fields.
    pub fn validate(&self) -> Result<()> {
        SCHEMA.check(&MeshSetup { settings: *self, rsm: None })?;
        if self.ambient.iter().chain(&self.sky).any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(Error::Input("ambient and sky must be finite and >= 0".into()));
        }
        if self.lpv_glossy && !self.lpv.enabled {
            return Err(Error::Input("lpv_glossy=1 needs the light propagation volume (set lpv=1)".into()));
        }
        self.fog.validate()
    }
}
/// Where the medium is.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum FogBounds {
    /// The scene's bounding box.
    Scene,
    /// All space (the sun is then taken as unattenuated: see the shader).
    Unbounded,
    /// An explicit axis-aligned box.
    Box {
        /// Minimum corner.
        min: [f32; 3],
        /// Maximum corner.
        max: [f32; 3],
    },
}

impl FogBounds {
    /// Parses `scene`, `none` or `x0,y0,z0,x1,y1,z1`.
    pub fn parse(s: &str) -> Result<Self> {
        Self::from_text(s).map_err(|e| Error::Input(format!("fog_bounds={s}: {e}")))
    }

    fn from_text(s: &str) -> std::result::Result<Self, String> {
        match s {
            "scene" => return Ok(Self::Scene),
            "none" => return Ok(Self::Unbounded),
            _ => {}
        }
        let bad = || "expected scene, none or x0,y0,z0,x1,y1,z1".to_string();
        let v: Vec<f32> =
            s.split(',').map(|c| c.trim().parse::<f32>()).collect::<std::result::Result<_, _>>().map_err(|_| bad())?;
        match v.as_slice() {
            &[a, b, c, d, e, f] => Ok(Self::Box { min: [a, b, c], max: [d, e, f] }),
            _ => Err(bad()),
        }
    }

    /// The text [`FogBounds::parse`] reads.
    pub fn text(&self) -> String {
        match self {
            Self::Scene => "scene".into(),
            Self::Unbounded => "none".into(),
            Self::Box { min, max } => min.iter().chain(max).map(|c| c.to_string()).collect::<Vec<_>>().join(","),
        }
    }
}

/// Fog parameters (off: no fog pass in the frame graph).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FogSettings {
    /// Add the fog pass at all.
    pub enabled: bool,
    /// Extinction σt in 1/m.
    pub density: f32,
    /// Single-scattering albedo σs/σt.
    pub albedo: f32,
    /// Henyey–Greenstein asymmetry (> 0 scatters forward).
    pub g: f32,
    /// Segments per camera ray.
    pub steps: u32,
    /// Extent of the medium.
    pub bounds: FogBounds,
}

impl Default for FogSettings {
    fn default() -> Self {
        Self { enabled: false, density: 0.05, albedo: 0.9, g: 0.3, steps: 32, bounds: FogBounds::Scene }
    }
}

impl FogSettings {
    /// Largest accepted extinction (1/m): beyond it the fog is opaque within a millimetre.
    pub const MAX_DENSITY: f32 = 1.0e4;
    /// Largest accepted |g|: the HG lobe becomes narrower than f32 resolves beyond it.
    pub const MAX_G: f32 = 0.99;

    /// Rejects values that are not a physical medium, naming the setting.
    pub fn validate(&self) -> Result<()> {
        SCHEMA.check(&MeshSetup { settings: MeshSettings { fog: *self, ..Default::default() }, rsm: None })?;
        if let FogBounds::Box { min, max } = self.bounds {
            if min.iter().chain(&max).any(|c| !c.is_finite()) || (0..3).any(|i| min[i] >= max[i]) {
                return Err(Error::Input(format!(
                    "fog_bounds={min:?}..{max:?}: corners must be finite with min < max on every axis"
                )));
            }
        }
        Ok(())
    }
}

/// What a mesh scene's settings describe: the renderer's settings and the RSM size.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshSetup {
    /// Renderer settings.
    pub settings: MeshSettings,
    /// RSM edge in texels; `None` follows the LPV (256 with it, none without).
    pub rsm: Option<u32>,
}

impl MeshSetup {
    /// The RSM edge to allocate (0: no RSM).
    pub fn rsm_size(&self) -> u32 {
        // The LPV's light comes from the RSM: turning it on brings a default RSM along.
        self.rsm.unwrap_or(if self.settings.lpv.enabled { 256 } else { 0 })
    }

    /// Defaults, then `settings` (later entries win), validated.
    pub fn parse(settings: &[crate::settings::Setting]) -> Result<Self> {
        let mut s = Self::default();
        SCHEMA.apply(&mut s, settings)?;
        s.settings.validate()?;
        Ok(s)
    }
}

/// Every setting of the mesh renderer.
pub static SCHEMA: Schema<MeshSetup> =
    Schema { name: "mesh renderer", parts: &[&MAIN, &crate::lpv_keys!(s => s.settings.lpv), &LPV_EXTRA, &EFFECTS] };

const TONEMAPS: &[&str] = &["reinhard", "aces", "range"];

static MAIN: [Key<MeshSetup>; 15] = [
    field!(choice "tonemap", "Display", "display transform", TONEMAPS, ToneMap::parse, ToneMap::name, |s| s.settings.tonemap),
    field!(float "exposure", "Display", "exposure multiplier", Range::positive_from(0.0), Some((1e-3, 1e3)), true,
        |s| s.settings.exposure),
    Key {
        key: "ambient",
        group: "Display",
        doc: "uniform ambient radiance (a grey)",
        ui: true,
        ty: Type::Float {
            range: Range::at_least(0.0),
            slider: Some((0.0, 1.0)),
            log: false,
            get: |s| Some(s.settings.ambient[0]),
            set: |s, v| s.settings.ambient = [v; 3],
        },
    },
    Key {
        key: "sky",
        group: "Display",
        doc: "background radiance (a grey when set)",
        ui: true,
        ty: Type::Float {
            range: Range::at_least(0.0),
            slider: Some((0.0, 4.0)),
            log: false,
            get: |s| Some(s.settings.sky[0]),
            set: |s, v| s.settings.sky = [v; 3],
        },
    },
    field!(bool "cull", "Display", "cull back faces of single-sided materials (all passes; 0: draw both sides)",
        |s| s.settings.cull),
    field!(bool "cull_triangles", "Display",
        "per view, drop the triangles that cannot cover a sample before drawing (a compute pass; same image; scenes of 4096 triangles or more)",
        |s| s.settings.cull_triangles),
    field!(int "cascades", "Shadows", "sun shadow cascades (0: no sun shadows)", 0, 4, 1, |s| s.settings.cascades),
    field!(int "shadow_tile", "Shadows", "shadow tile edge in texels (one per cascade and spot light)", 16, 8192, 1,
        |s| s.settings.shadow_tile),
    field!(float "cascade_lambda", "Shadows", "cascade splits: 1 logarithmic, 0 uniform", Range::closed(0.0, 1.0), None,
        false, |s| s.settings.cascade_lambda),
    field!(float "shadow_distance", "Shadows", "view distance the cascades cover", Range::positive_from(0.0),
        Some((1.0, 1000.0)), true, |s| s.settings.shadow_distance),
    field!(int "pcf", "Shadows", "PCF radius in texels", 0, 4, 1, |s| s.settings.pcf_radius),
    field!(bool "soft_shadows", "Shadows", "PCSS soft shadows from the lights' sizes", |s| s.settings.soft_shadows),
    // Beyond ~10° the sun is no longer small next to the scene and the penumbra bound
    // (MAX_PENUMBRA_TEXELS) would clip almost every penumbra.
    field!(float "sun_angle", "Shadows", "the sun's angular diameter in degrees", Range::closed(0.0, 10.0), None, false,
        |s| s.settings.sun_angle),
    field!(float "spot_radius", "Shadows", "spot lights' emitter radius in metres", Range::closed(0.0, 5.0), None, false,
        |s| s.settings.spot_radius),
    Key {
        key: "rsm",
        group: "LPV",
        doc: "reflective shadow map edge in texels (0: none; default 256 with the LPV, else 0)",
        ui: true,
        ty: Type::Int {
            lo: 0,
            hi: 2048,
            step: 1,
            get: |s| i64::from(s.rsm_size()),
            set: |s, v| s.rsm = u32::try_from(v).ok(),
        },
    },
];

static LPV_EXTRA: [Key<MeshSetup>; 1] = [field!(bool "lpv_glossy", "LPV extensions",
    "glossy reflections marched through the LPV (needs lpv)", |s| s.settings.lpv_glossy)];

static EFFECTS: [Key<MeshSetup>; 10] = [
    field!(bool "sun_rays", "Sun rays", "screen-space sun rays", |s| s.settings.sun_rays),
    field!(float "sun_rays_intensity", "Sun rays", "radiance added per unit of sun irradiance (1/sr)",
        Range::closed(0.0, 10.0), None, true, |s| s.settings.sun_rays_intensity),
    field!(float "sun_rays_decay", "Sun rays", "weight kept per sample along the blur (1: no decay)",
        Range::above(0.0, 1.0), Some((0.5, 1.0)), false, |s| s.settings.sun_rays_decay),
    field!(int "sun_rays_samples", "Sun rays", "samples along each pixel's ray toward the sun", 1, 256, 1,
        |s| s.settings.sun_rays_samples),
    field!(bool "fog", "Fog", "homogeneous fog lit by the lights (and the LPV)", |s| s.settings.fog.enabled),
    field!(float "fog_density", "Fog", "extinction in 1/m", Range::closed(0.0, FogSettings::MAX_DENSITY as f64),
        Some((1e-3, 10.0)), true, |s| s.settings.fog.density),
    field!(float "fog_albedo", "Fog", "single-scattering albedo", Range::closed(0.0, 1.0), None, false,
        |s| s.settings.fog.albedo),
    field!(float "fog_g", "Fog", "Henyey–Greenstein asymmetry (> 0 forward)",
        Range::closed(-(FogSettings::MAX_G as f64), FogSettings::MAX_G as f64), None, false, |s| s.settings.fog.g),
    field!(int "fog_steps", "Fog", "segments per camera ray", 1, 1024, 1, |s| s.settings.fog.steps),
    Key {
        key: "fog_bounds",
        group: "Fog",
        doc: "extent of the medium",
        ui: false,
        ty: Type::Text {
            hint: "scene | none | x0,y0,z0,x1,y1,z1",
            presets: &[],
            sliders: None,
            get: |s| Some(s.settings.fog.bounds.text()),
            set: |s, t| {
                s.settings.fog.bounds = FogBounds::from_text(t)?;
                Ok(())
            },
        },
    },
];
