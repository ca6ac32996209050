//! LPV parameters: which variants run and how large the grids are.

use crate::{Error, Result};

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
}

/// How light moves between cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Propagation {
    /// Each cell reads its six neighbours (no atomics).
    Gather,
    /// Each cell adds into its six neighbours with float atomics.
    Scatter,
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
    /// Reuse the previous frame's LPV when light, geometry and cascades are unchanged.
    pub reuse: bool,
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
    /// Rejects sizes and counts the passes cannot run with.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Input(m));
        if !(4..=128).contains(&self.size) || self.size % 4 != 0 {
            return bad(format!("lpv_size={}: must be a multiple of 4 in 4..=128", self.size));
        }
        if !(1..=4).contains(&self.cascades) {
            return bad(format!("lpv_cascades={}: must be in 1..=4", self.cascades));
        }
        if !(self.extent.is_finite() && self.extent >= 0.0) {
            return bad(format!("lpv_extent={}: must be finite and >= 0 (0 = fit the scene)", self.extent));
        }
        if self.steps > 256 {
            return bad(format!("lpv_steps={}: must be in 0..=256", self.steps));
        }
        if !(0.0..=2.0).contains(&self.vpl_offset) {
            return bad(format!("lpv_offset={}: must be in [0, 2] cells", self.vpl_offset));
        }
        if !(0.0..=2.0).contains(&self.sample_offset) {
            return bad(format!("lpv_sample_offset={}: must be in [0, 2] cells", self.sample_offset));
        }
        if !(self.sky.is_finite() && (0.0..=1e6).contains(&self.sky)) {
            return bad(format!("lpv_sky={}: must be in [0, 1e6] (a multiple of the sky colour; 0 = off)", self.sky));
        }
        if !(self.intensity.is_finite() && self.intensity >= 0.0) {
            return bad(format!("lpv_intensity={}: must be finite and >= 0", self.intensity));
        }
        Ok(())
    }
}
