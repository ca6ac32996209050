//! LPV parameters: which variants run and how large the grids are.

use crate::settings::{Key, Schema};
use crate::Result;

/// How VPLs get into the SH grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Injection {
    /// Compute scatter with 32-bit integer atomics in fixed point (portable everywhere).
    AtomicInt,
    /// Compute scatter with float atomics (`VK_EXT_shader_atomic_float`).
    AtomicFloat,
    /// Compute gather: each cell sums the RSM texels whose VPL falls into it; no atomics.
    Gather,
    /// Raster: one point per VPL, routed to its grid slice by a geometry shader, summed by
    /// additive blending (the thesis' classic path).
    Raster,
}

impl Injection {
    /// Parses `atomic`, `float`, `gather` or `raster`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "atomic" | "int" => Some(Injection::AtomicInt),
            "float" => Some(Injection::AtomicFloat),
            "gather" => Some(Injection::Gather),
            "raster" => Some(Injection::Raster),
            _ => None,
        }
    }

    /// The name [`Injection::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Injection::AtomicInt => "atomic",
            Injection::AtomicFloat => "float",
            Injection::Gather => "gather",
            Injection::Raster => "raster",
        }
    }
}

/// How light moves between cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Propagation {
    /// Each cell reads its six neighbours (no atomics).
    Gather,
    /// Each cell adds into its six neighbours with float atomics.
    Scatter,
}

impl Propagation {
    /// Parses `gather` or `scatter`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "gather" => Some(Self::Gather),
            "scatter" => Some(Self::Scatter),
            _ => None,
        }
    }

    /// The name [`Propagation::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Gather => "gather",
            Self::Scatter => "scatter",
        }
    }
}

/// How gather steps are dispatched over the cascades.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum StepDispatch {
    /// Whichever the device ran faster when measured (engine/lpv/passes/calibrate.rs).
    Auto,
    /// One dispatch per cascade and step, sparse where `sparse` is on: a cascade's steps stay in
    /// the caches (fastest on llvmpipe).
    Cascades,
    /// One dense dispatch per step for every cascade: a quarter of the dispatches and barriers
    /// (where a GPU pays per dispatch).
    Stacked,
}

impl StepDispatch {
    /// Parses `auto`, `cascades` or `stacked`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(Self::Auto),
            "cascades" => Some(Self::Cascades),
            "stacked" => Some(Self::Stacked),
            _ => None,
        }
    }

    /// The name [`StepDispatch::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Cascades => "cascades",
            Self::Stacked => "stacked",
        }
    }
}

/// Fixed-point scale of the integer injection.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum FixedPoint {
    /// The largest power of two for which the light's whole flux in one cell cannot overflow;
    /// values are rounded to nearest.
    Auto,
    /// The thesis: ×1000 with truncation toward zero (kept to measure what it costs).
    Thesis,
}

impl FixedPoint {
    /// Parses `auto` or `thesis`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(Self::Auto),
            "thesis" => Some(Self::Thesis),
            _ => None,
        }
    }

    /// The name [`FixedPoint::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Thesis => "thesis",
        }
    }
}

/// Everything the LPV passes need to know.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LpvSettings {
    /// Run the LPV at all (off: no LPV pass in the frame graph).
    pub enabled: bool,
    /// Cells per grid edge.
    pub size: u32,
    /// Nested cascades (1..=4); cascades that would contain nothing are skipped.
    pub cascades: u32,
    /// Edge of the finest cascade in metres (0: fit the scene's bounds).
    pub extent: f32,
    /// Propagation steps (light moves one cell per step).
    pub steps: u32,
    /// Injection variant.
    pub injection: Injection,
    /// Propagation variant.
    pub propagation: Propagation,
    /// VPL offset along its normal, in cells (0.5 in the paper, 1 in the thesis).
    pub vpl_offset: f32,
    /// How far along the normal, in cells, shading samples the LPV (0.5: the cell in front of
    /// the surface rather than the one its own VPLs are in).
    pub sample_offset: f32,
    /// Attenuate propagation by the geometry volume.
    pub occlusion: bool,
    /// Integer injection scale.
    pub fixed_point: FixedPoint,
    /// Multiplies the indirect light when shading (1 = physical).
    pub intensity: f32,
    /// The thesis' propagation weights: front and side face solid angles swapped.
    pub swap_face_weights: bool,
    /// Reuse the previous frame's LPV and RSM where light, geometry and cascades are unchanged:
    /// a moved camera recomputes only the cascades that moved, a static light keeps its RSM.
    pub reuse: bool,
    /// Cells a cascade's placement may lag behind the camera before it moves (with `reuse`:
    /// history-dependent placement, fewer recomputed cascades while walking; 0: always snap).
    pub follow_slack: f32,
    /// Linear gather steps run only the bricks of cells light can have reached
    /// (lpv/schedule.comp): the same result, computed where it is not zero.
    pub sparse: bool,
    /// How gather steps are dispatched over the cascades (same result either way).
    pub dispatch: StepDispatch,
    /// Damp light bleeding through thin walls when shading (compare front and back of a surface).
    pub damping: bool,
    /// Directional propagation (the thesis' §5.2): a grid of VPL normals, dilated one cell per
    /// step, onto whose direction every step's result is re-projected.
    pub directional: bool,
    /// Sky light (the thesis' §5.3): cells open to the sky (above a top-down height map) hold the
    /// sky's downward radiance, this many times the background `sky` colour (0: off).
    pub sky: f32,
    /// Subsurface LPV (the thesis' SSLPV) for translucent materials: a second grid set fed by the
    /// light entering them, read when shading them (off, or no translucent material: no pass).
    pub subsurface: bool,
}

impl Default for LpvSettings {
    fn default() -> Self {
        Self {
            enabled: false,
            size: 32,
            cascades: 1,
            extent: 0.0,
            steps: 8,
            injection: Injection::AtomicInt,
            propagation: Propagation::Gather,
            vpl_offset: 0.5,
            sample_offset: 0.5,
            occlusion: true,
            fixed_point: FixedPoint::Auto,
            intensity: 1.0,
            swap_face_weights: false,
            reuse: true,
            follow_slack: 0.0,
            sparse: true,
            dispatch: StepDispatch::Auto,
            damping: false,
            directional: false,
            sky: 0.0,
            subsurface: false,
        }
    }
}

impl LpvSettings {
    /// The thesis' choices as a baseline (REFERENCE.md): fixed point ×1000 with truncation, VPLs
    /// offset a full cell, front and side face weights swapped. (Its hand-tuned factors ×1.4,
    /// ×2.2, ×2.6 are not reproduced: the published shader versions read for this did not show
    /// where they apply.)
    pub fn thesis(self) -> Self {
        Self { fixed_point: FixedPoint::Thesis, vpl_offset: 1.0, swap_face_weights: true, ..self }
    }
}

impl LpvSettings {
    /// Rejects sizes and counts the passes cannot run with (the ranges of [`SCHEMA`]).
    pub fn validate(&self) -> Result<()> {
        SCHEMA.check(self)
    }

    /// Whether the thesis' three baseline choices are all set (what `lpv_preset` reads back).
    pub fn is_thesis(&self) -> bool {
        self.fixed_point == FixedPoint::Thesis && self.vpl_offset == 1.0 && self.swap_face_weights
    }
}

/// The LPV's keys, declared once for any settings struct `$s` whose LPV settings are at the
/// place `$l` (`lpv_keys!(s => *s)` here, `lpv_keys!(s => s.settings.lpv)` in the mesh schema).
#[macro_export]
macro_rules! lpv_keys {
    ($s:ident => $l:expr) => {
        [
            $crate::settings::Key {
                key: "lpv_preset",
                group: "LPV",
                doc: "`thesis`: the thesis' fixed point, VPL offset and face weights as a baseline (before the other lpv_* keys)",
                ui: false,
                ty: $crate::settings::Type::Choice {
                    names: &["engine", "thesis"],
                    get: |$s| if $l.is_thesis() { "thesis" } else { "engine" },
                    set: |$s, n| {
                        let d = $crate::lpv::settings::LpvSettings::default();
                        $l = if n == "thesis" {
                            $l.thesis()
                        } else {
                            $crate::lpv::settings::LpvSettings {
                                fixed_point: d.fixed_point,
                                vpl_offset: d.vpl_offset,
                                swap_face_weights: d.swap_face_weights,
                                ..$l
                            }
                        };
                    },
                },
            },
            $crate::field!(bool "lpv", "LPV", "light propagation volumes (brings a 256² RSM along)", |$s| $l.enabled),
            $crate::field!(int "lpv_size", "LPV", "cells per grid edge", 4, 128, 4, |$s| $l.size),
            $crate::field!(int "lpv_cascades", "LPV", "nested cascades", 1, 4, 1, |$s| $l.cascades),
            $crate::field!(float "lpv_extent", "LPV", "edge of the finest cascade in metres (0: fit the scene)",
                $crate::settings::Range::at_least(0.0), Some((0.0, 500.0)), true, |$s| $l.extent),
            $crate::field!(int "lpv_steps", "LPV", "propagation steps (light moves one cell per step)", 0, 256, 1, |$s| $l.steps),
            $crate::field!(choice "lpv_injection", "LPV", "how VPLs get into the grid",
                &["atomic", "float", "gather", "raster"], $crate::lpv::settings::Injection::parse,
                $crate::lpv::settings::Injection::name, |$s| $l.injection),
            $crate::field!(choice "lpv_propagation", "LPV", "how light moves between cells", &["gather", "scatter"],
                $crate::lpv::settings::Propagation::parse, $crate::lpv::settings::Propagation::name, |$s| $l.propagation),
            $crate::field!(bool "lpv_occlusion", "LPV", "attenuate propagation by the geometry volume", |$s| $l.occlusion),
            $crate::field!(float "lpv_intensity", "LPV", "multiplies the indirect light (1 = physical)",
                $crate::settings::Range::at_least(0.0), Some((1e-2, 1e2)), true, |$s| $l.intensity),
            $crate::field!(float "lpv_offset", "LPV", "VPL offset along its normal, in cells",
                $crate::settings::Range::closed(0.0, 2.0), None, false, |$s| $l.vpl_offset),
            $crate::field!(float "lpv_sample_offset", "LPV", "how far along the normal shading samples the LPV, in cells",
                $crate::settings::Range::closed(0.0, 2.0), None, false, |$s| $l.sample_offset),
            $crate::field!(choice "lpv_fixed_point", "LPV", "integer injection scale", &["auto", "thesis"],
                $crate::lpv::settings::FixedPoint::parse, $crate::lpv::settings::FixedPoint::name, |$s| $l.fixed_point),
            $crate::field!(bool "lpv_damping", "LPV", "damp light bleeding through thin walls", |$s| $l.damping),
            $crate::field!(bool "lpv_reuse", "LPV", "reuse the previous frame's LPV (and RSM) where nothing changed: a moved camera recomputes only the cascades that moved", |$s| $l.reuse),
            $crate::field!(float "lpv_follow", "LPV", "cells a cascade may lag behind the camera before it moves (needs lpv_reuse; 0: snap every cell)",
                $crate::settings::Range::closed(0.0, 8.0), None, false, |$s| $l.follow_slack),
            $crate::field!(bool "lpv_sparse", "LPV", "propagate only where light can have reached (same result)", |$s| $l.sparse),
            $crate::field!(choice "lpv_dispatch", "LPV", "gather steps: one dispatch per cascade (sparse), all cascades in one (stacked), or whichever this device ran faster (same result)",
                &["auto", "cascades", "stacked"], $crate::lpv::settings::StepDispatch::parse, $crate::lpv::settings::StepDispatch::name, |$s| $l.dispatch),
            $crate::field!(bool "lpv_directional", "LPV extensions", "directional propagation (thesis §5.2)", |$s| $l.directional),
            $crate::field!(float "lpv_sky", "LPV extensions", "sky light, times the background sky colour (0: off)",
                $crate::settings::Range::closed(0.0, 1e6), Some((0.0, 4.0)), false, |$s| $l.sky),
            $crate::field!(bool "lpv_subsurface", "LPV extensions", "subsurface LPV for translucent materials", |$s| $l.subsurface),
        ]
    };
}

/// The LPV's keys on [`LpvSettings`] alone, for [`LpvSettings::validate`].
pub static SCHEMA: Schema<LpvSettings> = Schema { name: "light propagation volume", parts: &[&LPV_KEYS] };

static LPV_KEYS: [Key<LpvSettings>; 21] = crate::lpv_keys!(s => *s);
