//! Post-processing passes shared by every renderer.

use crate::graph::{GraphBuilder, GraphError, ImageId};

/// Display transform after rendering.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum ToneMap {
    /// `L / (1/exposure + L)`.
    Reinhard,
    /// `(L - lo) / (hi - lo)`, clamped.
    Range {
        /// Maps to black.
        lo: f32,
        /// Maps to white.
        hi: f32,
    },
    /// ACES filmic fit (Narkowicz), after multiplying by exposure.
    Aces,
}

impl ToneMap {
    /// The tone-map shader's push constants: [mode, exposure, lo, hi].
    pub fn params(self, exposure: f32) -> [u32; 4] {
        let (mode, lo, hi) = match self {
            ToneMap::Reinhard => (0u32, 0.0f32, 1.0f32),
            ToneMap::Range { lo, hi } => (1, lo, hi),
            ToneMap::Aces => (2, 0.0, 1.0),
        };
        [mode, exposure.to_bits(), lo.to_bits(), hi.to_bits()]
    }

    /// The name [`ToneMap::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            ToneMap::Reinhard => "reinhard",
            ToneMap::Aces => "aces",
            ToneMap::Range { .. } => "range",
        }
    }

    /// Parses `reinhard`, `aces` or `range`.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "reinhard" => Some(ToneMap::Reinhard),
            "aces" => Some(ToneMap::Aces),
            "range" => Some(ToneMap::Range { lo: 0.0, hi: 1.0 }),
            _ => None,
        }
    }
}

/// Declares the tone-map pass (`post/tonemap.comp`): linear `hdr` → display `ldr`.
/// `params` = [mode (0 Reinhard, 1 range, 2 ACES), exposure, lo, hi] as the shader's push constants.
pub fn add_tonemap_pass(
    g: &mut GraphBuilder<'_>,
    hdr: ImageId,
    ldr: ImageId,
    params: [u32; 4],
    groups: [u32; 3],
) -> Result<(), GraphError> {
    g.compute("tonemap", &crate::shaders::POST_TONEMAP_COMP).read(hdr).write(ldr).constants(&params).dispatch(groups)
}

/// Declares the tone-map pass of `hdr` plus `added` (RGBA16F, the denoiser's difference from the
/// mean) into `ldr`, with [`add_tonemap_pass`]'s `params`.
pub fn add_tonemap_sum_pass(
    g: &mut GraphBuilder<'_>,
    [hdr, added]: [ImageId; 2],
    ldr: ImageId,
    params: [u32; 4],
    groups: [u32; 3],
) -> Result<(), GraphError> {
    g.compute("tonemap", &crate::shaders::POST_TONEMAP_COMP__ADD_IMAGE)
        .read(hdr)
        .read(added)
        .write(ldr)
        .constants(&params)
        .dispatch(groups)
}
