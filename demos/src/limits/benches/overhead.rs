//! Per-command overhead: dispatches and draws.

use super::storage_buffer;
use crate::limits::cpu::*;
use crate::limits::{Bench, BenchGraph, Case, Rate};
use vkengine::graph::{Access, LoadOp, ShaderStage};
use vkengine::graph::{PersistentBuffer, PersistentImage};
use vkengine::shaders;
use vkengine::vk::pipeline::push_words;
use vkengine::vk::{vk, Context, GraphicsDesc, Image, ImageInfo, Pipeline};
use vkengine::Result;

/// Dispatch overhead: N one-invocation dispatches in one compute pass, each with its own
/// push-descriptor range (so no two dispatches touch the same bytes).
pub struct DispatchBench {
    ctx: Context,
    slots: PersistentBuffer,
    count: u32,
    stride: u64,
}

impl DispatchBench {
    /// `count` dispatches into `count` slots.
    pub fn new(ctx: &Context, count: u32) -> Result<Self> {
        let count = count.max(1);
        let stride = ctx.info.limits.min_storage_buffer_offset_alignment.max(4);
        let slots = storage_buffer(ctx, "dispatch slots", count as u64 * stride)?;
        Ok(Self { ctx: ctx.clone(), slots, count, stride })
    }

    /// Dispatches per pass.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The first word of every slot (after a run): [`TINY_MARKER`] where a dispatch ran.
    pub fn read_slots(&self) -> Result<Vec<u32>> {
        let words = u32s(&self.slots.read(&self.ctx)?);
        Ok(words.iter().step_by((self.stride / 4) as usize).copied().collect())
    }
}

impl Bench for DispatchBench {
    fn cases(&self) -> Vec<Case> {
        vec![Case {
            name: "dispatch".into(),
            detail: format!("{} x (push descriptor + vkCmdDispatch(1,1,1)) in one pass", self.count),
            unit: "us/dispatch",
            work: self.count as f64,
            work_unit: "dispatches",
            rate: Rate::MicrosEach,
            skipped: None,
        }]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let slots = g.output_buffer("dispatch slots", &self.slots);
        let (count, stride) = (self.count, self.stride);
        for i in 0..reps {
            g.g.add_transfer_pass(format!("clear slots #{i}")).write_buffer(slots, Access::TransferDst)?.record(
                move |pc| {
                    // SAFETY: transfer pass writing the declared buffer.
                    unsafe { pc.device().cmd_fill_buffer(pc.cmd, pc.buffer(slots).raw, 0, vk::WHOLE_SIZE, 0) };
                    Ok(())
                },
            );
            // A hand-recorded pass: the point is one push-descriptor range per dispatch, which the
            // shader-pass builder (one descriptor per binding per pass) does not express.
            let name = g.timed(i);
            g.g.add_compute_pass(name)
                .side_effect()
                .write_buffer(slots, Access::StorageWrite(ShaderStage::Compute))?
                .record(move |pc| {
                    let pipe = pc.ctx.pipelines().compute(pc.ctx, &shaders::PROFILE_TINY_COMP)?;
                    let buf = pc.buffer(slots).raw;
                    // SAFETY: compute pass; the pipeline's only binding is pushed before each dispatch.
                    unsafe { pc.device().cmd_bind_pipeline(pc.cmd, vk::PipelineBindPoint::COMPUTE, pipe.raw) };
                    for d in 0..count {
                        let info = [vk::DescriptorBufferInfo { buffer: buf, offset: d as u64 * stride, range: 4 }];
                        let write = [vk::WriteDescriptorSet::default()
                            .dst_binding(0)
                            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                            .buffer_info(&info)];
                        // SAFETY: aligned in-bounds range; set 0 is this pipeline's one-binding push set.
                        unsafe {
                            pc.ctx.push_descriptor.cmd_push_descriptor_set(
                                pc.cmd,
                                vk::PipelineBindPoint::COMPUTE,
                                pipe.layout,
                                0,
                                &write,
                            );
                            pc.device().cmd_dispatch(pc.cmd, 1, 1, 1);
                        }
                    }
                    Ok(())
                });
        }
        Ok(())
    }
}

/// Draw overhead: N one-point draws in one dynamic-rendering pass; draw i writes i + 1 into pixel i.
pub struct DrawBench {
    ctx: Context,
    pipe: Pipeline,
    target: PersistentImage,
    count: u32,
    size: [u32; 2],
}

impl DrawBench {
    /// `count` draws onto an R32_UINT target just large enough for one pixel each.
    pub fn new(ctx: &Context, count: u32) -> Result<Self> {
        let count = count.max(1);
        let w = (count as f64).sqrt().ceil() as u32;
        let size = [w, count.div_ceil(w)];
        let desc = GraphicsDesc {
            color_formats: vec![vk::Format::R32_UINT],
            topology: vk::PrimitiveTopology::POINT_LIST,
            ..Default::default()
        };
        let pipe = Pipeline::graphics(ctx, &[&shaders::PROFILE_TINY_VERT, &shaders::PROFILE_TINY_FRAG], &[], 8, &desc)?;
        let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let target = Image::new(ctx, "draw target", ImageInfo::d2(vk::Format::R32_UINT, size[0], size[1], usage))?;
        Ok(Self { ctx: ctx.clone(), pipe, target: PersistentImage::new(target), count, size })
    }

    /// Draws per pass.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The target's pixels, row-major (after a run): i + 1 at pixel i < N, 0 elsewhere.
    pub fn read_target(&self) -> Result<Vec<u32>> {
        Ok(u32s(&self.target.read(&self.ctx)?))
    }
}

impl Bench for DrawBench {
    fn cases(&self) -> Vec<Case> {
        vec![Case {
            name: "draw".into(),
            detail: format!("{} x vkCmdDraw(1 point) in one dynamic-rendering pass", self.count),
            unit: "us/draw",
            work: self.count as f64,
            work_unit: "draws",
            rate: Rate::MicrosEach,
            skipped: None,
        }]
    }

    fn declare<'a>(&'a self, g: &mut BenchGraph<'a>, _case: usize, reps: u32) -> Result<()> {
        let target = g.output_image("draw target", &self.target);
        let (pipe, count, push) = (&self.pipe, self.count, push_words(&self.size));
        for i in 0..reps {
            let name = g.timed(i);
            let push = push.clone();
            g.g.add_raster_pass(name).side_effect().color_attachment(target, LoadOp::Clear, [0.0; 4])?.record(
                move |pc| {
                    pipe.bind(pc.cmd, &[], &push)?;
                    for d in 0..count {
                        // SAFETY: inside the pass's rendering scope with the pipeline bound; no vertex buffers.
                        unsafe { pc.device().cmd_draw(pc.cmd, 1, 1, 0, d) };
                    }
                    Ok(())
                },
            );
        }
        Ok(())
    }
}
