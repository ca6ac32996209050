//! Participating media in the mesh renderer: a homogeneous fog ray-marched from the camera to
//! the G-buffer depth after lighting (`shaders_glsl/mesh/fog.comp`), in-scattering the sun,
//! the spot lights, the ambient term and, with `lpv=1`, the light propagation volume.

use crate::graph::{Access, BufferId, GraphBuilder, GraphError, ImageId, ShaderStage, Work};
use crate::shaders;
use crate::vk::{pipeline::push_words, vk, Binding, Context, Descriptor, Pipeline};
use crate::{Error, Result};

/// Push-constant bytes of the fog pass (three vec4).
const PUSH_BYTES: u32 = 48;

pub use super::settings::{FogBounds, FogSettings};

/// The fog pass's pipelines (with and without the LPV term).
pub struct FogPipelines {
    plain: Pipeline,
    lpv: Pipeline,
}

impl FogPipelines {
    /// Creates both pipelines.
    pub fn new(ctx: &Context) -> Result<Self> {
        let cs = vk::ShaderStageFlags::COMPUTE;
        let sampler = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
        let mut b = vec![
            Binding::new(0, vk::DescriptorType::UNIFORM_BUFFER, cs),
            Binding::new(1, sampler, cs),
            Binding::new(2, sampler, cs),
            Binding::new(3, vk::DescriptorType::STORAGE_IMAGE, cs),
        ];
        let plain = Pipeline::compute(ctx, &shaders::MESH_FOG_COMP, &b, PUSH_BYTES)?;
        b.extend((4..=6).map(|i| Binding::new(i, sampler, cs)));
        Ok(Self { plain, lpv: Pipeline::compute(ctx, &shaders::MESH_FOG_COMP__LPV, &b, PUSH_BYTES)? })
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
    /// Samplers: nearest for the G-buffer and atlas, linear for the LPV.
    pub samplers: [vk::Sampler; 2],
}

fn ge(e: GraphError) -> Error {
    Error::Input(format!("frame graph: {e}"))
}

/// Declares the fog pass (call only when `s.enabled`).
pub fn add_fog_pass<'a>(
    g: &mut GraphBuilder<'a>,
    pipes: &'a FogPipelines,
    s: &FogSettings,
    input: FogInputs,
) -> Result<()> {
    s.validate()?;
    let (bounded, [lo, hi]) = match s.bounds {
        FogBounds::Scene => (1.0, input.scene_bounds.map(|v| v.to_array())),
        FogBounds::Unbounded => (0.0, [[0.0; 3]; 2]),
        FogBounds::Box { min, max } => (1.0, [min, max]),
    };
    let floats = [s.density, s.albedo, s.g, s.steps as f32, lo[0], lo[1], lo[2], bounded, hi[0], hi[1], hi[2], 0.0];
    let push = push_words(&floats.map(f32::to_bits));
    let FogInputs { ubo, depth, atlas, hdr, lpv, size: [w, h], lights, samplers: [near, lin], .. } = input;
    let pipe = if lpv.is_some() { &pipes.lpv } else { &pipes.plain };
    let cs = ShaderStage::Compute;
    let mut p = g.add_compute_pass("fog");
    // Per pixel: depth and the HDR texel in and out; per segment 4 shadow texels per light and
    // 8 cells × 3 RGBA32F texels of the LPV.
    let per_step = u64::from(lights) * 16 + if lpv.is_some() { 8 * 3 * 16 } else { 0 };
    let pixels = u64::from(w) * u64::from(h);
    p.work(Work { bytes: pixels * (4 + 32 + u64::from(s.steps) * per_step), ..Default::default() });
    p.read_buffer(ubo, Access::UniformRead(cs)).map_err(ge)?;
    for id in [depth, atlas].into_iter().chain(lpv.into_iter().flatten()) {
        p.read_image(id, Access::Sampled(cs)).map_err(ge)?;
    }
    p.write_image(hdr, Access::StorageReadWrite(cs)).map_err(ge)?;
    p.record(move |pc| {
        let mut ds = vec![
            Descriptor::UniformBuffer(pc.buffer(ubo).raw),
            Descriptor::CombinedImageSampler(pc.image(depth).view, near),
            Descriptor::CombinedImageSampler(pc.image(atlas).view, near),
            Descriptor::StorageImage(pc.image(hdr).view),
        ];
        if let Some(imgs) = lpv {
            ds.extend(imgs.map(|id| Descriptor::CombinedImageSampler(pc.image(id).view, lin)));
        }
        if pipe.bind(pc.cmd, &ds, &push).is_ok() {
            // SAFETY: pipeline, descriptors and push constants bound just above.
            unsafe { pc.device().cmd_dispatch(pc.cmd, w.div_ceil(8), h.div_ceil(8), 1) };
        }
    });
    Ok(())
}
