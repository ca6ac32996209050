//! Finite GPU waits: a dispatch that runs longer than the context's GPU timeout ends the wait
//! with an error naming the frame and the pass, the context still tears down validation-clean,
//! and the same work under the default timeout completes with the CPU twin's values.

mod common;

use std::time::{Duration, Instant};
use vkengine::graph::execute::{run_graph, ExecuteOptions, Imports};
use vkengine::graph::{Access, GraphBuilder, ResourceState};
use vkengine::shaders;
use vkengine::vk::{vk, Context, DEFAULT_GPU_TIMEOUT};
use vkengine::Error;

/// Hash-chain steps per invocation: a uniform loop, so one SIMD row counts it once — well under
/// llvmpipe's 65,535 iterations per row, so no test result rests on truncated loops.
const ITERATIONS: u32 = 16_384;
/// Invocations (64 per workgroup); with `ITERATIONS` this is tens to hundreds of ms on lavapipe.
const COUNT: u32 = 64 * 512;

/// The shader's chain on the CPU.
fn spin_cpu(i: u32) -> u32 {
    let mut h = i;
    for _ in 0..ITERATIONS {
        h = h.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        h ^= h >> 16;
    }
    h
}

/// Most copies of the slow pass one run dispatches (along y; each computes the same `COUNT`
/// values): 2²⁷ invocations × 16,384 steps (2.2e12), of the order of 0.1 s on an H200, so a device that beats
/// every timeout the tests set still ends, well under a desktop GPU's ~2 s watchdog.
const MAX_COPIES: u32 = 4096;

/// Runs `copies` copies of the slow pass in frame 7 under `timeout` (the upload and readback
/// around it wait with the context's own); returns the run's result and the output buffer's
/// values (`None` when the run failed).
fn run_spin(ctx: &Context, timeout: Duration, copies: u32) -> (vkengine::Result<()>, Option<Vec<u32>>) {
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
    let out = ctx.upload_buffer("spin-out", &vec![0u8; COUNT as usize * 4], usage).expect("upload");
    let after_upload = ResourceState {
        layout: vk::ImageLayout::UNDEFINED,
        stage: vk::PipelineStageFlags2::TRANSFER,
        access: vk::AccessFlags2::TRANSFER_WRITE,
    };
    let mut g = GraphBuilder::new();
    let mut imports = Imports::default();
    let id = imports.buffer(&mut g, "spin-out", &out, after_upload);
    g.compute("runaway-spin", &shaders::TEST_SPIN_COMP)
        .write(id)
        .constants(&[ITERATIONS, COUNT])
        .dispatch([COUNT / 64, copies, 1])
        .expect("declare");
    g.export_buffer(id, Some(Access::TransferSrc)).expect("export");
    ctx.set_frame(7);
    let before = ctx.gpu_timeout();
    ctx.set_gpu_timeout(timeout);
    let run = run_graph(ctx, g.compile().expect("compile"), &imports, ExecuteOptions::default()).map(|_| ());
    ctx.set_gpu_timeout(before);
    let values = run.is_ok().then(|| {
        let bytes = ctx.read_buffer(&out).expect("read back");
        bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
    });
    (run, values)
}

#[test]
fn the_slow_pass_completes_correctly_under_the_default_timeout() {
    common::gpu_test(|ctx| {
        let start = Instant::now();
        let (run, values) = run_spin(ctx, DEFAULT_GPU_TIMEOUT, 1);
        let elapsed = start.elapsed();
        run.expect("the default timeout is generous");
        let values = values.expect("values");
        for i in [0, 1, 63, 64, 4097, COUNT - 1] {
            assert_eq!(values[i as usize], spin_cpu(i), "invocation {i}: the loop was cut short or skipped");
        }
        eprintln!("slow pass: {elapsed:?}");
    });
}

/// Runs the slow pass under `timeout` with 1, 8, 64, … copies until a run fails (a fast GPU
/// finishes one copy far inside a millisecond; llvmpipe needs tens of them), up to
/// [`MAX_COPIES`]; returns the first failure and the copies it took.
fn grow_until_timeout(ctx: &Context, timeout: Duration) -> (vkengine::Error, u32) {
    let mut copies = 1;
    loop {
        let (run, _) = run_spin(ctx, timeout, copies);
        match run {
            Err(e) => return (e, copies),
            Ok(()) if copies >= MAX_COPIES => panic!("{copies} copies of the slow pass finished within {timeout:?}"),
            Ok(()) => copies = (copies * 8).min(MAX_COPIES),
        }
    }
}

#[test]
fn a_pass_longer_than_the_gpu_timeout_fails_naming_frame_and_pass() {
    common::gpu_test(|ctx| {
        let start = Instant::now();
        let (err, copies) = grow_until_timeout(ctx, Duration::from_millis(1));
        let waited = start.elapsed();
        eprintln!("timed out at {copies} copies after {waited:?}");
        assert!(matches!(err, Error::GpuTimeout { .. }), "not a timeout: {err:?}");
        let msg = err.to_string();
        assert!(msg.contains("frame 7") && msg.contains("`runaway-spin`"), "{msg}");
        assert!(msg.contains("--gpu-timeout"), "the message should name the setting: {msg}");
        // The wait returned at the timeout, not after the work (no hang).
        assert!(waited < Duration::from_secs(5), "the waits took {waited:?}");
    });
    // gpu_test then waited for the timed-out work (default timeout) and tore the context down:
    // no validation message, no leak report.
}

#[test]
fn a_context_created_with_a_tiny_timeout_fails_its_first_long_wait_and_tears_down_cleanly() {
    // The option path (ContextOptions::gpu_timeout): here even the upload may time out, so
    // only "some wait failed with a timeout" is asserted. Teardown (still at 1 ms) waits a grace
    // period of at least 2 s for the GPU before destroying anything, so validation stays clean.
    let ctx = common::context_with(|o| o.gpu_timeout = Duration::from_millis(1));
    let sink = ctx.message_sink();
    let result =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| grow_until_timeout(&ctx, ctx.gpu_timeout()).0));
    match result {
        Ok(Error::GpuTimeout { .. }) => {}
        Ok(other) => panic!("expected a GPU timeout, got {other:?}"),
        // The upload's own wait (run_spin's expect) timed out: still the error under test.
        Err(p) => {
            let msg = p.downcast_ref::<String>().cloned().unwrap_or_default();
            assert!(msg.contains("GpuTimeout"), "{msg}");
        }
    }
    drop(ctx);
    if let Err(msgs) = common::check_messages(&sink) {
        panic!("validation reported messages:\n{msgs}");
    }
}

#[test]
fn gpu_timeout_settings_parse_and_reject_nonsense() {
    use vkengine::vk::parse_gpu_timeout;
    assert_eq!(parse_gpu_timeout("60"), Ok(Duration::from_secs(60)));
    assert_eq!(parse_gpu_timeout("0.001"), Ok(Duration::from_millis(1)));
    for bad in ["0", "-1", "nan", "inf", "", "ten", "1e300"] {
        assert!(parse_gpu_timeout(bad).is_err(), "`{bad}` accepted");
    }
}
