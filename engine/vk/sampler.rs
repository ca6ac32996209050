//! Samplers.

use super::context::{Context, Garbage};
use crate::error::{Result, VkContext};
use ash::vk;

/// A sampler with deferred destruction.
pub struct Sampler {
    ctx: Context,
    /// Raw handle.
    pub raw: vk::Sampler,
}

impl Sampler {
    /// Clamp-to-edge sampler, linear (trilinear for 3D) or nearest.
    pub fn clamped(ctx: &Context, linear: bool) -> Result<Self> {
        let f = if linear { vk::Filter::LINEAR } else { vk::Filter::NEAREST };
        let m = if linear { vk::SamplerMipmapMode::LINEAR } else { vk::SamplerMipmapMode::NEAREST };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(f)
            .min_filter(f)
            .mipmap_mode(m)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(vk::LOD_CLAMP_NONE);
        // SAFETY: valid device.
        let raw = unsafe { ctx.device.create_sampler(&info, None) }.vk("vkCreateSampler")?;
        Ok(Self { ctx: ctx.clone(), raw })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        self.ctx.defer_destroy(Garbage::Sampler(self.raw));
    }
}
