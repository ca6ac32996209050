//! Post-processing passes shared by every renderer.

use crate::graph::{Access, GraphBuilder, GraphError, ImageId, ShaderStage};
use crate::vk::{pipeline::push_words, vk, Binding, Context, Descriptor, Pipeline};

/// The tone-map pipeline `add_tonemap_pass` binds (two storage images, 16 bytes of constants).
pub fn tonemap_pipeline(ctx: &Context) -> crate::Result<Pipeline> {
    let (c, storage) = (vk::ShaderStageFlags::COMPUTE, vk::DescriptorType::STORAGE_IMAGE);
    Pipeline::compute(
        ctx,
        &crate::shaders::POST_TONEMAP_COMP,
        &[Binding::new(0, storage, c), Binding::new(1, storage, c)],
        16,
    )
}

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
pub fn add_tonemap_pass<'a>(
    g: &mut GraphBuilder<'a>,
    pipeline: &'a Pipeline,
    hdr: ImageId,
    ldr: ImageId,
    params: [u32; 4],
    groups: [u32; 2],
) -> Result<(), GraphError> {
    let cs = ShaderStage::Compute;
    let mut p = g.add_compute_pass("tonemap");
    p.read_image(hdr, Access::StorageRead(cs))?;
    p.write_image(ldr, Access::StorageWrite(cs))?;
    p.record(move |pc| {
        let ds = [Descriptor::StorageImage(pc.image(hdr).view), Descriptor::StorageImage(pc.image(ldr).view)];
        pipeline.bind(pc.cmd, &ds, &push_words(&params))?;
        // SAFETY: pipeline and descriptors bound just above.
        unsafe { pc.device().cmd_dispatch(pc.cmd, groups[0], groups[1], 1) };
        Ok(())
    });
    Ok(())
}
