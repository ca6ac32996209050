//! The context's lazy pipeline cache: one compute pipeline per shader (and variant), its layout
//! derived from the bindings `build.rs` reflected, created on first use; plus the standard
//! samplers passes name by [`Sampling`]. Handles live until the context is dropped.

use super::{Binding, Pipeline};
use crate::error::{Error, Result, VkContext};
use crate::shaders::{DescriptorKind, Shader};
use crate::vk::context::Context;
use ash::vk;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Which sampler a sampled binding uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Sampling {
    /// Clamp to edge, nearest.
    Nearest,
    /// Clamp to edge, (tri)linear.
    Linear,
    /// Repeat, trilinear with mipmaps (material textures).
    Repeat,
    /// A sampler the caller owns and keeps alive while the graph runs.
    Custom(vk::Sampler),
}

/// A cached pipeline's raw handles.
#[derive(Debug)]
pub struct CachedPipeline {
    /// Pipeline.
    pub raw: vk::Pipeline,
    /// Its layout (set 0 push descriptors + the shader's push-constant range).
    pub layout: vk::PipelineLayout,
    /// Set 0 layout.
    pub set_layout: vk::DescriptorSetLayout,
    /// Descriptor type per binding index.
    pub types: Vec<vk::DescriptorType>,
}

/// A compute pipeline's identity: shader path, variant and specialization constants.
type PipelineKey = (&'static str, &'static str, Vec<u32>);

/// Lazily created pipelines and samplers, owned by the context.
#[derive(Default)]
pub struct PipelineCache {
    compute: Mutex<HashMap<PipelineKey, Arc<CachedPipeline>>>,
    samplers: Mutex<HashMap<Sampling, vk::Sampler>>,
}

/// The Vulkan descriptor type of a reflected binding.
pub fn descriptor_type(kind: DescriptorKind) -> vk::DescriptorType {
    match kind {
        DescriptorKind::UniformBuffer => vk::DescriptorType::UNIFORM_BUFFER,
        DescriptorKind::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
        DescriptorKind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
        DescriptorKind::CombinedImageSampler => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
        DescriptorKind::SampledImage => vk::DescriptorType::SAMPLED_IMAGE,
        DescriptorKind::Sampler => vk::DescriptorType::SAMPLER,
        DescriptorKind::StorageTexelBuffer => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
    }
}

impl PipelineCache {
    /// The compute pipeline of `shader`, created on first use with the layout its reflection gives.
    pub fn compute(&self, ctx: &Context, shader: &'static Shader) -> Result<Arc<CachedPipeline>> {
        self.compute_specialized(ctx, shader, &[])
    }

    /// The compute pipeline of `shader` with specialization constants `spec` (see
    /// [`Pipeline::compute_specialized`]), one per distinct set of values.
    pub fn compute_specialized(
        &self,
        ctx: &Context,
        shader: &'static Shader,
        spec: &[u32],
    ) -> Result<Arc<CachedPipeline>> {
        let key = (shader.path, shader.variant, spec.to_vec());
        let mut map = self.compute.lock().map_err(|_| Error::Graph("pipeline cache poisoned".into()))?;
        if let Some(p) = map.get(&key) {
            return Ok(p.clone());
        }
        let c = vk::ShaderStageFlags::COMPUTE;
        let bindings: Vec<Binding> =
            shader.bindings.iter().map(|b| Binding::new(b.binding, descriptor_type(b.kind), c)).collect();
        let pipe = Pipeline::compute_specialized(ctx, shader, &bindings, shader.push_size, spec)?;
        let mut types = vec![
            vk::DescriptorType::UNIFORM_BUFFER;
            bindings.iter().map(|b| b.binding as usize + 1).max().unwrap_or(0)
        ];
        for b in &bindings {
            types[b.binding as usize] = b.ty;
        }
        let (raw, layout, set_layout) = pipe.into_raw();
        let cached = Arc::new(CachedPipeline { raw, layout, set_layout, types });
        map.insert(key, cached.clone());
        Ok(cached)
    }

    /// The sampler for `s`, created on first use.
    pub fn sampler(&self, ctx: &Context, s: Sampling) -> Result<vk::Sampler> {
        let (filter, mip, address) = match s {
            Sampling::Custom(raw) => return Ok(raw),
            Sampling::Nearest => {
                (vk::Filter::NEAREST, vk::SamplerMipmapMode::NEAREST, vk::SamplerAddressMode::CLAMP_TO_EDGE)
            }
            Sampling::Linear => {
                (vk::Filter::LINEAR, vk::SamplerMipmapMode::LINEAR, vk::SamplerAddressMode::CLAMP_TO_EDGE)
            }
            Sampling::Repeat => (vk::Filter::LINEAR, vk::SamplerMipmapMode::LINEAR, vk::SamplerAddressMode::REPEAT),
        };
        let mut map = self.samplers.lock().map_err(|_| Error::Graph("sampler cache poisoned".into()))?;
        if let Some(&raw) = map.get(&s) {
            return Ok(raw);
        }
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(filter)
            .min_filter(filter)
            .mipmap_mode(mip)
            .address_mode_u(address)
            .address_mode_v(address)
            .address_mode_w(address)
            .max_lod(vk::LOD_CLAMP_NONE);
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_sampler(&info, None) }.vk("vkCreateSampler")?;
        map.insert(s, raw);
        Ok(raw)
    }

    /// Destroys every cached object; the caller guarantees the device is idle.
    pub(crate) fn destroy(&mut self, device: &ash::Device) {
        let compute = std::mem::take(self.compute.get_mut().unwrap_or_else(|p| p.into_inner()));
        for p in compute.into_values() {
            // SAFETY: the device is idle and no graph holds these handles any more.
            unsafe {
                device.destroy_pipeline(p.raw, None);
                device.destroy_pipeline_layout(p.layout, None);
                device.destroy_descriptor_set_layout(p.set_layout, None);
            }
        }
        for s in std::mem::take(self.samplers.get_mut().unwrap_or_else(|p| p.into_inner())).into_values() {
            // SAFETY: as above.
            unsafe { device.destroy_sampler(s, None) };
        }
    }
}
