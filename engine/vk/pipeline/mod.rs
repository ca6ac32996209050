//! Compute and graphics pipelines from embedded SPIR-V, with push-descriptor set layouts, and
//! the context's lazy cache of them (`cache`).

pub mod cache;

use crate::error::{Error, Result, VkContext};
use crate::shaders::{Shader, Stage};
use crate::vk::context::{Context, Garbage};
use ash::vk;
use std::ffi::CStr;

const ENTRY: &CStr = c"main";

/// One descriptor binding of set 0.
#[derive(Clone, Copy, Debug)]
pub struct Binding {
    /// Binding index.
    pub binding: u32,
    /// Descriptor type.
    pub ty: vk::DescriptorType,
    /// Stages that access it.
    pub stages: vk::ShaderStageFlags,
}

impl Binding {
    /// Shorthand constructor.
    pub const fn new(binding: u32, ty: vk::DescriptorType, stages: vk::ShaderStageFlags) -> Self {
        Self { binding, ty, stages }
    }
}

/// A descriptor write for push descriptors.
#[derive(Clone, Copy, Debug)]
pub enum Descriptor {
    /// Storage buffer (whole range).
    StorageBuffer(vk::Buffer),
    /// Uniform buffer (whole range).
    UniformBuffer(vk::Buffer),
    /// Storage image in GENERAL layout.
    StorageImage(vk::ImageView),
    /// Sampled image + sampler in SHADER_READ_ONLY_OPTIMAL layout.
    CombinedImageSampler(vk::ImageView, vk::Sampler),
}

/// A pipeline with its layout and (push-descriptor) set layout.
pub struct Pipeline {
    ctx: Context,
    /// Raw pipeline.
    pub raw: vk::Pipeline,
    /// Pipeline layout.
    pub layout: vk::PipelineLayout,
    /// Set 0 layout (push descriptors).
    pub set_layout: vk::DescriptorSetLayout,
    /// Compute or graphics.
    pub bind_point: vk::PipelineBindPoint,
    bindings: Vec<Binding>,
    push_stages: vk::ShaderStageFlags,
    /// First shader's path, for messages.
    name: &'static str,
}

/// Colour blending of a graphics pipeline.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Blend {
    /// Write the shader's output.
    #[default]
    Off,
    /// dst + src (splatting, accumulation).
    Additive,
    /// src + (1 − src.a)·dst for premultiplied colours (UI overlays).
    PremultipliedAlpha,
}

/// Fixed-function state of a graphics pipeline (dynamic rendering, dynamic viewport/scissor).
#[derive(Clone, Debug)]
pub struct GraphicsDesc {
    /// Colour attachment formats.
    pub color_formats: Vec<vk::Format>,
    /// Depth attachment format, if any.
    pub depth_format: Option<vk::Format>,
    /// Depth test enabled.
    pub depth_test: bool,
    /// Depth writes enabled.
    pub depth_write: bool,
    /// Blending on every colour attachment.
    pub blend: Blend,
    /// Primitive topology.
    pub topology: vk::PrimitiveTopology,
    /// Face culling.
    pub cull_mode: vk::CullModeFlags,
    /// Culling is dynamic state (`vkCmdSetCullMode` before each draw), for draws whose
    /// materials differ in sidedness; `cull_mode` is then ignored.
    pub dynamic_cull: bool,
    /// Vertex buffer bindings.
    pub vertex_bindings: Vec<vk::VertexInputBindingDescription>,
    /// Vertex attributes.
    pub vertex_attributes: Vec<vk::VertexInputAttributeDescription>,
}

impl Default for GraphicsDesc {
    fn default() -> Self {
        Self {
            color_formats: vec![],
            depth_format: None,
            depth_test: false,
            depth_write: false,
            blend: Blend::Off,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            cull_mode: vk::CullModeFlags::NONE,
            dynamic_cull: false,
            vertex_bindings: vec![],
            vertex_attributes: vec![],
        }
    }
}

fn stage_flags(s: Stage) -> vk::ShaderStageFlags {
    match s {
        Stage::Compute => vk::ShaderStageFlags::COMPUTE,
        Stage::Vertex => vk::ShaderStageFlags::VERTEX,
        Stage::Fragment => vk::ShaderStageFlags::FRAGMENT,
        Stage::Geometry => vk::ShaderStageFlags::GEOMETRY,
    }
}

struct Module<'a>(&'a Context, vk::ShaderModule);

impl<'a> Module<'a> {
    fn new(ctx: &'a Context, shader: &Shader) -> Result<Self> {
        let info = vk::ShaderModuleCreateInfo::default().code(shader.words);
        // SAFETY: words are SPIR-V compiled by build.rs.
        let m = unsafe { ctx.device.create_shader_module(&info, None) }.vk("vkCreateShaderModule")?;
        Ok(Self(ctx, m))
    }
}

impl Drop for Module<'_> {
    fn drop(&mut self) {
        // SAFETY: modules may be destroyed right after pipeline creation.
        unsafe { self.0.device.destroy_shader_module(self.1, None) };
    }
}

fn layouts(
    ctx: &Context,
    bindings: &[Binding],
    push_size: u32,
    push_stages: vk::ShaderStageFlags,
) -> Result<(vk::DescriptorSetLayout, vk::PipelineLayout)> {
    let b: Vec<_> = bindings
        .iter()
        .map(|b| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(b.binding)
                .descriptor_type(b.ty)
                .descriptor_count(1)
                .stage_flags(b.stages)
        })
        .collect();
    let info = vk::DescriptorSetLayoutCreateInfo::default()
        .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
        .bindings(&b);
    // SAFETY: valid device and create info.
    let set_layout =
        unsafe { ctx.device.create_descriptor_set_layout(&info, None) }.vk("vkCreateDescriptorSetLayout")?;
    let ranges = [vk::PushConstantRange { stage_flags: push_stages, offset: 0, size: push_size }];
    let sets = [set_layout];
    let mut linfo = vk::PipelineLayoutCreateInfo::default().set_layouts(&sets);
    if push_size > 0 {
        linfo = linfo.push_constant_ranges(&ranges);
    }
    // SAFETY: valid device and create info.
    match unsafe { ctx.device.create_pipeline_layout(&linfo, None) } {
        Ok(l) => Ok((set_layout, l)),
        Err(e) => {
            ctx.defer_destroy(Garbage::DescriptorSetLayout(set_layout));
            Err(Error::Vulkan { call: "vkCreatePipelineLayout", result: e })
        }
    }
}

impl Pipeline {
    /// The layouts, with a null pipeline the caller fills in (dropping it frees the layouts).
    fn with_layouts(
        ctx: &Context,
        bind_point: vk::PipelineBindPoint,
        bindings: &[Binding],
        push_size: u32,
        push_stages: vk::ShaderStageFlags,
    ) -> Result<Self> {
        let (set_layout, layout) = layouts(ctx, bindings, push_size, push_stages)?;
        Ok(Self {
            ctx: ctx.clone(),
            raw: vk::Pipeline::null(),
            layout,
            set_layout,
            bind_point,
            bindings: bindings.to_vec(),
            push_stages,
            name: "",
        })
    }

    /// Creates a compute pipeline.
    pub fn compute(ctx: &Context, shader: &Shader, bindings: &[Binding], push_size: u32) -> Result<Self> {
        Self::compute_specialized(ctx, shader, bindings, push_size, &[])
    }

    /// A compute pipeline whose specialization constants 0, 1, … take the 32-bit `spec` values
    /// (booleans as 0 or 1): the driver folds them, so a feature switched off costs nothing.
    pub fn compute_specialized(
        ctx: &Context,
        shader: &Shader,
        bindings: &[Binding],
        push_size: u32,
        spec: &[u32],
    ) -> Result<Self> {
        if shader.stage != Stage::Compute {
            return Err(Error::Input(format!("{} is not a compute shader", shader.path)));
        }
        let mut me = Self::with_layouts(
            ctx,
            vk::PipelineBindPoint::COMPUTE,
            bindings,
            push_size,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        me.name = shader.path;
        let layout = me.layout;
        let module = Module::new(ctx, shader)?;
        let entries: Vec<vk::SpecializationMapEntry> = (0..spec.len() as u32)
            .map(|i| vk::SpecializationMapEntry { constant_id: i, offset: 4 * i, size: 4 })
            .collect();
        let data: &[u8] = bytemuck::cast_slice(spec);
        let spec_info = vk::SpecializationInfo::default().map_entries(&entries).data(data);
        let mut stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module.1)
            .name(ENTRY);
        if !spec.is_empty() {
            stage = stage.specialization_info(&spec_info);
        }
        let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout)];
        // SAFETY: valid create info; module alive for the call.
        me.raw = unsafe { ctx.device.create_compute_pipelines(ctx.pipeline_cache, &info, None) }
            .map_err(|(_, e)| Error::Vulkan { call: "vkCreateComputePipelines", result: e })?[0];
        ctx.set_name(me.raw, shader.path);
        Ok(me)
    }

    /// Creates a graphics pipeline for dynamic rendering from the given stages.
    pub fn graphics(
        ctx: &Context,
        shaders: &[&Shader],
        bindings: &[Binding],
        push_size: u32,
        desc: &GraphicsDesc,
    ) -> Result<Self> {
        let push_stages = shaders.iter().fold(vk::ShaderStageFlags::empty(), |a, s| a | stage_flags(s.stage));
        let mut me = Self::with_layouts(ctx, vk::PipelineBindPoint::GRAPHICS, bindings, push_size, push_stages)?;
        me.name = shaders.first().map_or("graphics", |s| s.path);
        let layout = me.layout;
        let modules = shaders.iter().map(|s| Module::new(ctx, s)).collect::<Result<Vec<_>>>()?;
        let stages: Vec<_> = shaders
            .iter()
            .zip(&modules)
            .map(|(s, m)| {
                vk::PipelineShaderStageCreateInfo::default().stage(stage_flags(s.stage)).module(m.1).name(ENTRY)
            })
            .collect();
        let vertex = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&desc.vertex_bindings)
            .vertex_attribute_descriptions(&desc.vertex_attributes);
        let ia = vk::PipelineInputAssemblyStateCreateInfo::default().topology(desc.topology);
        let vp = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
        let rs = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(desc.cull_mode)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let ms = vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let ds = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(desc.depth_test)
            .depth_write_enable(desc.depth_write)
            .depth_compare_op(vk::CompareOp::LESS_OR_EQUAL);
        let blend_att: Vec<_> = desc
            .color_formats
            .iter()
            .map(|_| {
                let a =
                    vk::PipelineColorBlendAttachmentState::default().color_write_mask(vk::ColorComponentFlags::RGBA);
                let one = vk::BlendFactor::ONE;
                let (src, dst) = match desc.blend {
                    Blend::Off => return a,
                    Blend::Additive => (one, one),
                    Blend::PremultipliedAlpha => (one, vk::BlendFactor::ONE_MINUS_SRC_ALPHA),
                };
                a.blend_enable(true)
                    .src_color_blend_factor(src)
                    .dst_color_blend_factor(dst)
                    .color_blend_op(vk::BlendOp::ADD)
                    .src_alpha_blend_factor(src)
                    .dst_alpha_blend_factor(dst)
                    .alpha_blend_op(vk::BlendOp::ADD)
            })
            .collect();
        let cb = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_att);
        let mut dyn_states = vec![vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        if desc.dynamic_cull {
            dyn_states.push(vk::DynamicState::CULL_MODE);
        }
        let dy = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dyn_states);
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&desc.color_formats)
            .depth_attachment_format(desc.depth_format.unwrap_or(vk::Format::UNDEFINED));
        let info = [vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex)
            .input_assembly_state(&ia)
            .viewport_state(&vp)
            .rasterization_state(&rs)
            .multisample_state(&ms)
            .depth_stencil_state(&ds)
            .color_blend_state(&cb)
            .dynamic_state(&dy)
            .layout(layout)
            .push_next(&mut rendering)];
        // SAFETY: valid create info; modules alive for the call.
        me.raw = unsafe { ctx.device.create_graphics_pipelines(ctx.pipeline_cache, &info, None) }
            .map_err(|(_, e)| Error::Vulkan { call: "vkCreateGraphicsPipelines", result: e })?[0];
        ctx.set_name(me.raw, shaders.first().map(|s| s.path).unwrap_or("graphics"));
        Ok(me)
    }

    /// Binds the pipeline and pushes descriptors (in binding order of `descriptors`) and constants.
    pub fn bind(&self, cmd: vk::CommandBuffer, descriptors: &[Descriptor], push: &[u8]) -> Result<()> {
        if descriptors.len() != self.bindings.len() {
            return Err(Error::Graph(format!(
                "pipeline {} expects {} descriptors, got {}",
                self.name,
                self.bindings.len(),
                descriptors.len()
            )));
        }
        for (b, d) in self.bindings.iter().zip(descriptors) {
            let ty = match d {
                Descriptor::StorageBuffer(_) => vk::DescriptorType::STORAGE_BUFFER,
                Descriptor::UniformBuffer(_) => vk::DescriptorType::UNIFORM_BUFFER,
                Descriptor::StorageImage(_) => vk::DescriptorType::STORAGE_IMAGE,
                Descriptor::CombinedImageSampler(..) => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            };
            if ty != b.ty {
                return Err(Error::Graph(format!(
                    "pipeline {}: binding {} is {:?} but got {:?}",
                    self.name, b.binding, b.ty, ty
                )));
            }
        }
        let infos: Vec<(Option<vk::DescriptorBufferInfo>, Option<vk::DescriptorImageInfo>)> = descriptors
            .iter()
            .map(|d| match *d {
                Descriptor::StorageBuffer(b) | Descriptor::UniformBuffer(b) => {
                    (Some(vk::DescriptorBufferInfo { buffer: b, offset: 0, range: vk::WHOLE_SIZE }), None)
                }
                Descriptor::StorageImage(v) => (
                    None,
                    Some(vk::DescriptorImageInfo {
                        sampler: vk::Sampler::null(),
                        image_view: v,
                        image_layout: vk::ImageLayout::GENERAL,
                    }),
                ),
                Descriptor::CombinedImageSampler(v, s) => (
                    None,
                    Some(vk::DescriptorImageInfo {
                        sampler: s,
                        image_view: v,
                        image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                    }),
                ),
            })
            .collect();
        let writes: Vec<_> = self
            .bindings
            .iter()
            .zip(&infos)
            .map(|(b, (bi, ii))| {
                let w = vk::WriteDescriptorSet::default().dst_binding(b.binding).descriptor_type(b.ty);
                match (bi, ii) {
                    (Some(bi), _) => w.buffer_info(std::slice::from_ref(bi)),
                    (_, Some(ii)) => w.image_info(std::slice::from_ref(ii)),
                    _ => w,
                }
            })
            .collect();
        let d = &self.ctx.device;
        // SAFETY: cmd is recording; descriptors reference live objects supplied by the caller.
        unsafe {
            d.cmd_bind_pipeline(cmd, self.bind_point, self.raw);
            if !writes.is_empty() {
                self.ctx.push_descriptor.cmd_push_descriptor_set(cmd, self.bind_point, self.layout, 0, &writes);
            }
            if !push.is_empty() {
                d.cmd_push_constants(cmd, self.layout, self.push_stages, 0, push);
            }
        }
        Ok(())
    }
}

impl Pipeline {
    /// Hands the raw pipeline, layout and set layout to a new owner (the context's cache).
    pub(crate) fn into_raw(mut self) -> (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSetLayout) {
        let out = (self.raw, self.layout, self.set_layout);
        // Null handles make the deferred destruction in `drop` a no-op.
        (self.raw, self.layout, self.set_layout) = Default::default();
        out
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        self.ctx.defer_destroy(Garbage::Pipeline(self.raw));
        self.ctx.defer_destroy(Garbage::PipelineLayout(self.layout));
        self.ctx.defer_destroy(Garbage::DescriptorSetLayout(self.set_layout));
    }
}

/// Bytes of a plain-old-data push-constant struct made of `u32`/`f32` words.
pub fn push_words(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}
