//! Shader passes: each `.uniform/.read/.write/.sampled` call declares the graph access *and*
//! appends the next descriptor binding, so a pass states each binding once. The sequence is
//! checked against the bindings `build.rs` reflected from the shader's SPIR-V when the pass is
//! declared, and the pipeline comes from the context's lazy cache when the pass records.
//!
//! ```ignore
//! g.compute("lpv dilate 3", &shaders::LPV_DILATE_COMP)
//!     .uniform(params)
//!     .read(prev)
//!     .write(next)
//!     .dispatch(groups)?;
//! ```

use super::access::{Access, ShaderStage};
use super::builder::GraphBuilder;
use super::error::GraphError;
use super::pass_context::PassContext;
use super::resource::{BufferId, ImageId, ResourceId};
use super::work::Work;
use crate::error::Result;
use crate::shaders::{DescriptorKind, Shader};
use crate::vk::pipeline::cache::{CachedPipeline, Sampling};
use ash::vk;

/// One declared binding: what the record step pushes as descriptor `i`.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Slot {
    Uniform(BufferId),
    StorageBuffer(BufferId),
    StorageImage(ImageId),
    Sampled(ImageId, Sampling, vk::ImageLayout),
    /// A storage buffer read as an `imageBuffer` of this texel format.
    TexelBuffer(BufferId, vk::Format),
    /// A gap before a binding declared at a fixed number ([`ComputePass::read_at`]).
    Unused,
}

impl Slot {
    fn kind(&self) -> DescriptorKind {
        match self {
            Slot::Uniform(_) => DescriptorKind::UniformBuffer,
            Slot::StorageBuffer(_) => DescriptorKind::StorageBuffer,
            Slot::StorageImage(_) => DescriptorKind::StorageImage,
            Slot::Sampled(..) => DescriptorKind::CombinedImageSampler,
            Slot::TexelBuffer(..) => DescriptorKind::StorageTexelBuffer,
            // Never compared: `check_signature` refuses a shader binding that lands on a gap.
            Slot::Unused => DescriptorKind::Sampler,
        }
    }
}

/// The recording step of a compute pass after its pipeline and descriptors are bound.
pub struct Dispatcher<'p, 'r> {
    /// The pass's context (device, command buffer, resources).
    pub pc: &'p PassContext<'r>,
    layout: vk::PipelineLayout,
}

impl Dispatcher<'_, '_> {
    /// Records one dispatch of `groups` workgroups.
    pub fn dispatch(&self, [x, y, z]: [u32; 3]) {
        // SAFETY: the pass bound its compute pipeline and every descriptor just before.
        unsafe { self.pc.device().cmd_dispatch(self.pc.cmd, x, y, z) };
        self.pc.dispatches.set(self.pc.dispatches.get() + 1);
    }

    /// Replaces the push constants (for passes that dispatch several times with different ones).
    pub fn push(&self, bytes: &[u8]) {
        // SAFETY: the layout declares a compute push range of the shader's reflected size.
        unsafe {
            self.pc.device().cmd_push_constants(self.pc.cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, bytes)
        };
    }
}

type DispatchFn<'a> = Box<dyn FnOnce(&Dispatcher<'_, '_>) -> Result<()> + 'a>;

/// A compute pass under declaration; see the module docs.
#[must_use = "a compute pass is declared only by .dispatch()"]
pub struct ComputePass<'g, 'a> {
    g: &'g mut GraphBuilder<'a>,
    index: usize,
    shader: &'static Shader,
    slots: Vec<Slot>,
    push: Vec<u8>,
    spec: Vec<u32>,
    /// Bindings at fixed numbers past the positional ones.
    fixed: Vec<(u32, Slot)>,
    err: Option<GraphError>,
}

impl<'a> GraphBuilder<'a> {
    /// Declares a compute pass running `shader`; bindings follow from the calls on the result.
    pub fn compute(&mut self, name: impl Into<String>, shader: &'static Shader) -> ComputePass<'_, 'a> {
        let index = self.add_compute_pass(name).index();
        ComputePass {
            g: self,
            index,
            shader,
            slots: Vec::new(),
            push: Vec::new(),
            spec: Vec::new(),
            fixed: Vec::new(),
            err: None,
        }
    }
}

const CS: ShaderStage = ShaderStage::Compute;

impl<'a> ComputePass<'_, 'a> {
    fn bind(mut self, id: ResourceId, access: Access, slot: Slot) -> Self {
        if self.err.is_none() {
            let mut p = self.g.pass_builder(self.index);
            let r = match id {
                ResourceId::Image(i) if access.is_write() => p.write_image(i, access).map(|_| ()),
                ResourceId::Image(i) => p.read_image(i, access).map(|_| ()),
                ResourceId::Buffer(b) if access.is_write() => p.write_buffer(b, access).map(|_| ()),
                ResourceId::Buffer(b) => p.read_buffer(b, access).map(|_| ()),
            };
            self.err = r.err();
        }
        self.slots.push(slot);
        self
    }

    fn storage(self, id: impl Into<ResourceId>, access: Access) -> Self {
        let id = id.into();
        let slot = match id {
            ResourceId::Image(i) => Slot::StorageImage(i),
            ResourceId::Buffer(b) => Slot::StorageBuffer(b),
        };
        self.bind(id, access, slot)
    }

    /// Next binding: a uniform buffer.
    pub fn uniform(self, b: BufferId) -> Self {
        self.bind(ResourceId::Buffer(b), Access::UniformRead(CS), Slot::Uniform(b))
    }

    /// Next binding: a storage image or buffer the shader only reads.
    pub fn read(self, id: impl Into<ResourceId>) -> Self {
        self.storage(id, Access::StorageRead(CS))
    }

    /// Next binding: a storage image or buffer the shader overwrites without reading.
    pub fn write(self, id: impl Into<ResourceId>) -> Self {
        self.storage(id, Access::StorageWrite(CS))
    }

    /// Next binding: a storage image or buffer the shader reads and writes.
    pub fn read_write(self, id: impl Into<ResourceId>) -> Self {
        self.storage(id, Access::StorageReadWrite(CS))
    }

    /// Next binding: a storage image or buffer the shader adds into with atomics.
    pub fn atomic(self, id: impl Into<ResourceId>) -> Self {
        self.storage(id, Access::StorageAtomic(CS))
    }

    /// Next binding: a buffer the shader only reads, as a storage texel buffer (`imageBuffer`) of
    /// `format`. On llvmpipe, `imageLoad` gathers a texel per lane in one vector operation where
    /// a storage-buffer load loops over lanes per component, so a buffer that later passes
    /// gather from reads faster this way (and a pass writes it as a plain storage buffer).
    pub fn read_texels(self, b: BufferId, format: vk::Format) -> Self {
        self.bind(ResourceId::Buffer(b), Access::StorageRead(CS), Slot::TexelBuffer(b, format))
    }

    /// Next binding: a combined image sampler.
    pub fn sampled(self, img: ImageId, sampling: Sampling) -> Self {
        let access = Access::Sampled(CS);
        self.bind(ResourceId::Image(img), access, Slot::Sampled(img, sampling, access.image_layout()))
    }

    /// A storage image or buffer the shader only reads, at binding `binding` past every
    /// positional one: for a binding an include file declares for all the shaders that include
    /// it, whose own bindings differ in number (`volume/common.glsl`'s page table).
    pub fn read_at(self, binding: u32, id: impl Into<ResourceId>) -> Self {
        self.at(binding, |p| p.read(id))
    }

    /// A storage image or buffer the shader reads and writes, at binding `binding` past every
    /// positional one (as [`Self::read_at`]).
    pub fn read_write_at(self, binding: u32, id: impl Into<ResourceId>) -> Self {
        self.at(binding, |p| p.read_write(id))
    }

    /// A combined image sampler at binding `binding` past every positional one (as
    /// [`Self::read_at`]).
    pub fn sampled_at(self, binding: u32, img: ImageId, sampling: Sampling) -> Self {
        self.at(binding, |p| p.sampled(img, sampling))
    }

    fn at(self, binding: u32, declare: impl FnOnce(Self) -> Self) -> Self {
        let mut me = declare(self);
        if let Some(slot) = me.slots.pop() {
            me.fixed.push((binding, slot));
        }
        me
    }

    /// Several bindings of the same kind in a row.
    pub fn each<I: Copy>(mut self, ids: impl IntoIterator<Item = I>, f: impl Fn(Self, I) -> Self) -> Self {
        for id in ids {
            self = f(self, id);
        }
        self
    }

    /// The push constants, as the shader's reflected block lays them out.
    pub fn constants<T: bytemuck::NoUninit>(mut self, value: &T) -> Self {
        self.push = bytemuck::bytes_of(value).to_vec();
        self
    }

    /// The shader's specialization constants 0, 1, … (booleans as 0 or 1): features a pass may
    /// leave out without a variant per combination. llvmpipe runs both sides of a branch under a
    /// lane mask, so a uniform flag would still pay for what it skips; a constant is folded.
    pub fn specialize(mut self, values: &[u32]) -> Self {
        self.spec = values.to_vec();
        self
    }

    /// Push constants as raw bytes.
    pub fn push_bytes(mut self, bytes: Vec<u8>) -> Self {
        self.push = bytes;
        self
    }

    /// Declares the worst-case loop iterations of one SIMD row per dispatch (llvmpipe's limit).
    pub fn loop_bound(self, iterations: u64) -> Self {
        self.g.pass_builder(self.index).loop_bound(iterations);
        self
    }

    /// Declares the pass's work for profiles.
    pub fn work(self, work: Work) -> Self {
        self.g.pass_builder(self.index).work(work);
        self
    }

    /// Keeps the pass even if nothing exported depends on it.
    pub fn side_effect(self) -> Self {
        self.g.pass_builder(self.index).side_effect();
        self
    }

    /// Finishes the declaration with one dispatch of `groups` workgroups.
    pub fn dispatch(self, groups: [u32; 3]) -> Result<(), GraphError> {
        self.dispatch_with(move |d| {
            d.dispatch(groups);
            Ok(())
        })
    }

    /// Finishes the declaration with one dispatch whose group counts an earlier pass wrote into
    /// `args` at byte `offset` (a `VkDispatchIndirectCommand`): work sized on the device.
    pub fn dispatch_indirect(self, args: BufferId, offset: u64) -> Result<(), GraphError> {
        if self.err.is_none() {
            self.g.pass_builder(self.index).read_buffer(args, Access::IndirectArgs)?;
        }
        self.dispatch_with(move |d| {
            let raw = d.pc.buffer(args).raw;
            // SAFETY: the pass bound its compute pipeline and descriptors just before, and
            // declared `args` as indirect arguments (the graph's barrier made them visible).
            unsafe { d.pc.device().cmd_dispatch_indirect(d.pc.cmd, raw, offset) };
            d.pc.dispatches.set(d.pc.dispatches.get() + 1);
            Ok(())
        })
    }

    /// Finishes the declaration; `f` records the dispatches once pipeline and descriptors are bound.
    pub fn dispatch_with(self, f: impl FnOnce(&Dispatcher<'_, '_>) -> Result<()> + 'a) -> Result<(), GraphError> {
        if let Some(e) = self.err {
            return Err(e);
        }
        let name = self.g.passes[self.index].name.clone();
        let mut slots = self.slots;
        // In binding order, whatever order the pass declared them in (an include's bindings
        // before a shader's own higher ones).
        let mut fixed = self.fixed;
        fixed.sort_by_key(|(b, _)| *b);
        for (binding, slot) in fixed {
            let b = binding as usize;
            if b < slots.len() {
                return Err(GraphError::ShaderBinding {
                    pass: name,
                    shader: self.shader.label(),
                    binding: binding.to_string(),
                    problem: format!("a fixed binding collides with the pass's {} positional ones", slots.len()),
                });
            }
            slots.resize(b, Slot::Unused);
            slots.push(slot);
        }
        check_signature(&name, self.shader, &slots, self.push.len())?;
        let (shader, push, spec) = (self.shader, self.push, self.spec);
        let f: DispatchFn<'a> = Box::new(f);
        self.g.pass_builder(self.index).record(move |pc| {
            let pipe = pc.ctx.pipelines().compute_specialized(pc.ctx, shader, &spec)?;
            pc.push_descriptors(&pipe, &slots)?;
            // SAFETY: cmd is recording outside rendering; the pipeline's layout matches the shader.
            unsafe { pc.device().cmd_bind_pipeline(pc.cmd, vk::PipelineBindPoint::COMPUTE, pipe.raw) };
            let d = Dispatcher { pc, layout: pipe.layout };
            if !push.is_empty() {
                d.push(&push);
            }
            f(&d)
        });
        Ok(())
    }
}

fn kind_name(k: DescriptorKind) -> &'static str {
    match k {
        DescriptorKind::UniformBuffer => "uniform buffer",
        DescriptorKind::StorageBuffer => "storage buffer",
        DescriptorKind::StorageImage => "storage image",
        DescriptorKind::CombinedImageSampler => "sampled image (combined sampler)",
        DescriptorKind::SampledImage => "texture without sampler",
        DescriptorKind::Sampler => "sampler",
        DescriptorKind::StorageTexelBuffer => "storage texel buffer",
    }
}

/// The declared binding sequence against the shader's reflected set 0 and push-constant block.
pub(crate) fn check_signature(pass: &str, shader: &Shader, slots: &[Slot], push_len: usize) -> Result<(), GraphError> {
    let err = |binding: String, problem: String| GraphError::ShaderBinding {
        pass: pass.to_string(),
        shader: shader.label(),
        binding,
        problem,
    };
    for b in shader.bindings {
        if b.set != 0 {
            return Err(err(
                format!("set {} binding {}", b.set, b.binding),
                "only set 0 is bound (push descriptors)".into(),
            ));
        }
        match slots.get(b.binding as usize) {
            None => {
                return Err(err(
                    b.binding.to_string(),
                    format!(
                        "the shader declares {} `{}` but the pass binds only {} descriptor(s)",
                        kind_name(b.kind),
                        b.name,
                        slots.len()
                    ),
                ))
            }
            Some(Slot::Unused) => {
                return Err(err(
                    b.binding.to_string(),
                    format!("the shader declares {} `{}` but the pass binds nothing there", kind_name(b.kind), b.name),
                ))
            }
            Some(s) if s.kind() != b.kind => {
                return Err(err(
                    b.binding.to_string(),
                    format!(
                        "the pass binds a {} but the shader declares {} `{}`",
                        kind_name(s.kind()),
                        kind_name(b.kind),
                        b.name
                    ),
                ))
            }
            _ => {}
        }
    }
    let declared = |i: u32| matches!(slots[i as usize], Slot::Unused) || shader.bindings.iter().any(|b| b.binding == i);
    if let Some(extra) = (0..slots.len() as u32).find(|&i| !declared(i)) {
        return Err(err(
            extra.to_string(),
            format!("the pass binds a {} that the shader does not declare", kind_name(slots[extra as usize].kind())),
        ));
    }
    if push_len as u32 != shader.push_size {
        return Err(err(
            "push constants".into(),
            format!("the pass pushes {push_len} bytes but the shader's block is {} bytes", shader.push_size),
        ));
    }
    Ok(())
}

impl PassContext<'_> {
    /// Pushes one descriptor per declared slot, in binding order, with the layouts the graph
    /// put each image in.
    pub(crate) fn push_descriptors(&self, pipe: &CachedPipeline, slots: &[Slot]) -> Result<()> {
        if slots.is_empty() {
            return Ok(());
        }
        let mut buffers = Vec::with_capacity(slots.len());
        let mut images = Vec::with_capacity(slots.len());
        let mut texels = Vec::new();
        for s in slots {
            match *s {
                Slot::TexelBuffer(b, format) => texels.push(self.texel_view(b, format)?),
                Slot::Uniform(b) | Slot::StorageBuffer(b) => buffers.push(vk::DescriptorBufferInfo {
                    buffer: self.buffer(b).raw,
                    offset: 0,
                    range: vk::WHOLE_SIZE,
                }),
                Slot::StorageImage(i) => images.push(vk::DescriptorImageInfo {
                    sampler: vk::Sampler::null(),
                    image_view: self.image(i).view,
                    image_layout: vk::ImageLayout::GENERAL,
                }),
                Slot::Sampled(i, sampling, layout) => images.push(vk::DescriptorImageInfo {
                    sampler: self.ctx.pipelines().sampler(self.ctx, sampling)?,
                    image_view: self.image(i).view,
                    image_layout: layout,
                }),
                Slot::Unused => {}
            }
        }
        let (mut bi, mut ii, mut ti) = (0, 0, 0);
        let writes: Vec<_> = slots
            .iter()
            .enumerate()
            .filter(|(_, s)| !matches!(s, Slot::Unused))
            .map(|(binding, s)| {
                let w =
                    vk::WriteDescriptorSet::default().dst_binding(binding as u32).descriptor_type(pipe.types[binding]);
                match s {
                    Slot::Uniform(_) | Slot::StorageBuffer(_) => {
                        bi += 1;
                        w.buffer_info(std::slice::from_ref(&buffers[bi - 1]))
                    }
                    Slot::TexelBuffer(..) => {
                        ti += 1;
                        w.texel_buffer_view(std::slice::from_ref(&texels[ti - 1]))
                    }
                    _ => {
                        ii += 1;
                        w.image_info(std::slice::from_ref(&images[ii - 1]))
                    }
                }
            })
            .collect();
        // SAFETY: cmd is recording; every handle belongs to this graph's resources or the cache.
        unsafe {
            self.ctx.push_descriptor.cmd_push_descriptor_set(
                self.cmd,
                vk::PipelineBindPoint::COMPUTE,
                pipe.layout,
                0,
                &writes,
            )
        };
        Ok(())
    }
}
