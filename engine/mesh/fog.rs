//! Participating media in the mesh renderer: a homogeneous fog ray-marched from the camera to
//! the G-buffer depth after lighting (`shaders_glsl/mesh/fog.comp`), in-scattering the sun,
//! the spot lights, the ambient term and, with `lpv=1`, the light propagation volume.

use crate::graph::{BufferId, GraphBuilder, ImageId, Work};
use crate::shaders;
use crate::vk::Sampling;
use crate::{Error, Result};

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
        match s {
            "scene" => return Ok(Self::Scene),
            "none" => return Ok(Self::Unbounded),
            _ => {}
        }
        let bad = || Error::Input(format!("fog_bounds={s}: expected scene, none or x0,y0,z0,x1,y1,z1"));
        let v: Vec<f32> =
            s.split(',').map(|c| c.trim().parse::<f32>()).collect::<std::result::Result<_, _>>().map_err(|_| bad())?;
        match v.as_slice() {
            &[a, b, c, d, e, f] => Ok(Self::Box { min: [a, b, c], max: [d, e, f] }),
            _ => Err(bad()),
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
        let bad = |m: String| Err(Error::Input(m));
        if !(self.density.is_finite() && (0.0..=Self::MAX_DENSITY).contains(&self.density)) {
            return bad(format!(
                "fog_density={}: must be finite and in [0, {}] (1/m)",
                self.density,
                Self::MAX_DENSITY
            ));
        }
        if !(0.0..=1.0).contains(&self.albedo) {
            return bad(format!("fog_albedo={}: must be in [0, 1]", self.albedo));
        }
        if !(-Self::MAX_G..=Self::MAX_G).contains(&self.g) {
            return bad(format!("fog_g={}: must be in [-{m}, {m}]", self.g, m = Self::MAX_G));
        }
        if !(1..=1024).contains(&self.steps) {
            return bad(format!("fog_steps={}: must be in 1..=1024", self.steps));
        }
        if let FogBounds::Box { min, max } = self.bounds {
            if min.iter().chain(&max).any(|c| !c.is_finite()) || (0..3).any(|i| min[i] >= max[i]) {
                return bad(format!(
                    "fog_bounds={min:?}..{max:?}: corners must be finite with min < max on every axis"
                ));
            }
        }
        Ok(())
    }
}

/// What the fog pass reads and writes.
pub struct FogInputs {
    /// The frame's uniform buffer.
    pub ubo: BufferId,
    /// Camera depth.
    pub depth: ImageId,
    /// Shadow atlas.
    pub atlas: ImageId,
    /// Lit HDR radiance, attenuated and added to in place.
    pub hdr: ImageId,
    /// The LPV's light grids, when the LPV is on.
    pub lpv: Option<[ImageId; 3]>,
    /// The scene's bounding box (for [`FogBounds::Scene`]).
    pub scene_bounds: [glam::Vec3; 2],
    /// Image size.
    pub size: [u32; 2],
    /// Lights with a shadow tile (sun counts once), for the declared work.
    pub lights: u32,
}

/// Declares the fog pass (call only when `s.enabled`).
pub fn add_fog_pass(g: &mut GraphBuilder<'_>, s: &FogSettings, input: FogInputs) -> Result<()> {
    s.validate()?;
    let (bounded, [lo, hi]) = match s.bounds {
        FogBounds::Scene => (1.0, input.scene_bounds.map(|v| v.to_array())),
        FogBounds::Unbounded => (0.0, [[0.0; 3]; 2]),
        FogBounds::Box { min, max } => (1.0, [min, max]),
    };
    let push = [s.density, s.albedo, s.g, s.steps as f32, lo[0], lo[1], lo[2], bounded, hi[0], hi[1], hi[2], 0.0];
    let FogInputs { ubo, depth, atlas, hdr, lpv, size: [w, h], lights, .. } = input;
    // Per pixel: depth and the HDR texel in and out; per segment 4 shadow texels per light and
    // 8 cells × 3 RGBA32F texels of the LPV.
    let per_step = u64::from(lights) * 16 + if lpv.is_some() { 8 * 3 * 16 } else { 0 };
    let pixels = u64::from(w) * u64::from(h);
    let shader = if lpv.is_some() { &shaders::MESH_FOG_COMP__LPV } else { &shaders::MESH_FOG_COMP };
    g.compute("fog", shader)
        .work(Work { bytes: pixels * (4 + 32 + u64::from(s.steps) * per_step), ..Default::default() })
        .uniform(ubo)
        .sampled(depth, Sampling::Nearest)
        .sampled(atlas, Sampling::Nearest)
        .read_write(hdr)
        .each(lpv.into_iter().flatten(), |p, id| p.sampled(id, Sampling::Linear))
        .constants(&push)
        .dispatch([w.div_ceil(8), h.div_ceil(8), 1])?;
    Ok(())
}
