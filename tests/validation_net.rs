//! Proof that the harness catches validation messages: provoke errors on purpose.

mod common;

use vkengine::shaders;
use vkengine::vk::{pipeline::push_words, vk, Binding, Buffer, Descriptor, MemoryLocation, Pipeline};

fn require_validation(ctx: &vkengine::vk::Context) -> bool {
    if !ctx.info.validation {
        assert!(!common::validation_required(), "CI / VKENGINE_VALIDATION=required must have the validation layer");
        eprintln!("skipping: validation layer not installed");
        return false;
    }
    true
}

#[test]
fn sync_validation_catches_missing_barrier() {
    let ctx = common::context();
    if !require_validation(&ctx) {
        return;
    }
    let sink = ctx.message_sink();
    assert!(common::check_messages(&sink).is_ok(), "clean before the provocation");
    let bindings = [Binding::new(0, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::COMPUTE)];
    let pipe = Pipeline::compute(&ctx, &shaders::TEST_FILL_BUFFER_COMP, &bindings, 12).expect("pipeline");
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
    let buf = Buffer::new(&ctx, "hazard", 256, usage, MemoryLocation::GpuOnly).expect("buffer");
    let dst =
        Buffer::new(&ctx, "copy", 256, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuOnly).expect("buffer");
    ctx.one_shot(|cmd| {
        pipe.bind(cmd, &[Descriptor::StorageBuffer(buf.raw)], &push_words(&[64, 0, 0]))?;
        // SAFETY: deliberately no barrier between the compute write and the copy: the hazard under test.
        unsafe {
            ctx.device.cmd_dispatch(cmd, 1, 1, 1);
            ctx.device.cmd_copy_buffer(
                cmd,
                buf.raw,
                dst.raw,
                &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size: 256 }],
            );
        }
        Ok(())
    })
    .expect("submit");
    drop((pipe, buf, dst));
    ctx.wait_idle().expect("idle");
    let err = common::check_messages(&sink).expect_err("harness must report the hazard");
    assert!(err.contains("SYNC-HAZARD-READ-AFTER-WRITE"), "unexpected messages: {err}");
}

#[test]
fn core_validation_catches_invalid_usage() {
    let ctx = common::context();
    if !require_validation(&ctx) {
        return;
    }
    let sink = ctx.message_sink();
    // An empty usage mask violates VUID-VkBufferCreateInfo-usage-requiredbitmask.
    let info = vk::BufferCreateInfo::default().size(64).usage(vk::BufferUsageFlags::empty());
    // SAFETY: invalid on purpose; lavapipe tolerates it and the layer must report it.
    if let Ok(b) = unsafe { ctx.device.create_buffer(&info, None) } {
        // SAFETY: the buffer was never used.
        unsafe { ctx.device.destroy_buffer(b, None) };
    }
    let err = common::check_messages(&sink).expect_err("harness must report the invalid usage");
    assert!(err.contains("VUID-VkBufferCreateInfo-usage-requiredbitmask"), "unexpected messages: {err}");
}
