//! GPU test harness: pins lavapipe, requires the validation layer (with synchronization
//! validation) under CI or `VKENGINE_VALIDATION=required`, requires a display for window tests
//! under CI or `VKENGINE_REQUIRE_DISPLAY=1`, and fails a test on any validation warning or error.
#![allow(dead_code)]

pub mod scenes;

use std::sync::Once;
use vkengine::vk::{Context, ContextOptions, MessageSink, Validation};

static PIN: Once = Once::new();

/// Points the Vulkan loader at lavapipe's ICD unless `VKENGINE_TEST_DEVICE=system`.
pub fn pin_lavapipe() {
    PIN.call_once(|| {
        if on_system_device() {
            return;
        }
        let icd = std::fs::read_dir("/usr/share/vulkan/icd.d").ok().and_then(|d| {
            d.flatten()
                .map(|e| e.path())
                .find(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("lvp_icd")))
        });
        match icd {
            // Runs once, before this process makes any Vulkan call (every test goes through here first).
            Some(path) => {
                std::env::set_var("VK_DRIVER_FILES", &path);
                std::env::set_var("VK_ICD_FILENAMES", &path);
            }
            None => panic!("lavapipe ICD not found in /usr/share/vulkan/icd.d; run tools/setup.sh"),
        }
    });
}

/// True when the suite runs on the system's own device (`VKENGINE_TEST_DEVICE=system`, as
/// `tools/gpu_check.sh` runs it on a GPU) instead of lavapipe.
pub fn on_system_device() -> bool {
    std::env::var("VKENGINE_TEST_DEVICE").as_deref() == Ok("system")
}

/// For a test pinned to lavapipe on purpose: on the system device, prints why it is skipped
/// and returns true (the caller returns); on lavapipe, false.
pub fn skip_pinned_to_lavapipe(reason: &str) -> bool {
    let skip = on_system_device();
    if skip {
        eprintln!("skipped on the system device: pinned to lavapipe on purpose: {reason}");
    }
    skip
}

/// Points a demo process at the device the suite tests: lavapipe, or with
/// `VKENGINE_TEST_DEVICE=system` whatever the loader finds.
pub fn child_device(c: &mut std::process::Command) {
    if !on_system_device() {
        c.env("VK_DRIVER_FILES", lavapipe_icd().expect("lavapipe ICD installed (tools/setup.sh)"));
    }
}

/// Path of lavapipe's ICD manifest, if installed.
pub fn lavapipe_icd() -> Option<std::path::PathBuf> {
    std::fs::read_dir("/usr/share/vulkan/icd.d").ok().and_then(|d| {
        d.flatten()
            .map(|e| e.path())
            .find(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("lvp_icd")))
    })
}

/// True when running under CI (missing validation or display is then a failure, not a skip).
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
}

/// True when a missing validation layer must fail the test: under CI, or whenever
/// `VKENGINE_VALIDATION=required` (what `tools/test.sh` sets), on any machine.
pub fn validation_required() -> bool {
    in_ci() || std::env::var("VKENGINE_VALIDATION").is_ok_and(|v| v == "required")
}

/// `/usr/bin/python3` where it can import OpenVDB's Python module (Debian python3-openvdb, which
/// tools/setup.sh installs); `None` (the caller skips) where it cannot — a failure where
/// validation is required (CI).
pub fn openvdb_python() -> Option<&'static str> {
    let python = "/usr/bin/python3";
    let has =
        std::process::Command::new(python).args(["-c", "import pyopenvdb"]).output().is_ok_and(|o| o.status.success());
    if !has {
        assert!(!validation_required(), "{python} cannot import pyopenvdb: install python3-openvdb (tools/setup.sh)");
        eprintln!("skipped: {python} cannot import pyopenvdb (Debian python3-openvdb, tools/setup.sh)");
    }
    has.then_some(python)
}

/// The `VKENGINE_VALIDATION` value for demo processes a test starts: the same rule as in-process.
pub fn child_validation() -> &'static str {
    if validation_required() {
        "required"
    } else {
        "1"
    }
}

/// True when a window test must fail, not skip, without a display: under CI, or with
/// `VKENGINE_REQUIRE_DISPLAY=1` (what `tools/test.sh` sets, since it runs everything in Xvfb).
pub fn display_required() -> bool {
    in_ci() || std::env::var("VKENGINE_REQUIRE_DISPLAY").is_ok_and(|v| v == "1" || v == "true")
}

/// Whether a window test can run: true with `DISPLAY` set; otherwise skips (false, with a note)
/// or, when [`display_required`], fails.
pub fn have_display(what: &str) -> bool {
    if std::env::var_os("DISPLAY").is_some() {
        return true;
    }
    assert!(
        !display_required(),
        "{what} needs a display (DISPLAY is unset) and CI or VKENGINE_REQUIRE_DISPLAY=1 requires it: run under xvfb-run"
    );
    eprintln!(
        "skipping {what}: no DISPLAY (run under xvfb-run, or set VKENGINE_REQUIRE_DISPLAY=1 to make this a failure)"
    );
    false
}

/// The largest error a linear filter's weight may carry on this device: 0 on llvmpipe, whose
/// texture unit filters in f32 (pinned to lavapipe on purpose; `volume_absolute::exact_filtering_…`
/// checks it against f32 filtering to 1e-4), else one step of its sub-texel fractions,
/// 2^-subTexelPrecisionBits.
#[allow(dead_code)]
pub fn quantized_filter_step(ctx: &vkengine::vk::Context) -> f32 {
    if ctx.info.name.starts_with("llvmpipe") {
        0.0
    } else {
        0.5f32.powi(ctx.info.limits.sub_texel_precision_bits as i32)
    }
}

/// The validation policy of every test context.
pub fn validation_policy() -> Validation {
    if validation_required() {
        Validation::Required
    } else {
        Validation::IfAvailable
    }
}

/// Creates a test context on lavapipe with validation + synchronization validation.
pub fn context() -> Context {
    context_with(|_| {})
}

/// [`context`] with options adjusted by `adjust` (e.g. a tiny GPU timeout).
pub fn context_with(adjust: impl FnOnce(&mut ContextOptions)) -> Context {
    pin_lavapipe();
    let mut opts = ContextOptions {
        validation: validation_policy(),
        device: None,
        display: None,
        gpu_timeout: vkengine::vk::DEFAULT_GPU_TIMEOUT,
        max_allocation: None,
        // `VKENGINE_PAGE_LEVELS=2` runs every sparse test through two-level page tables.
        page_levels: ContextOptions::from_env().page_levels,
    };
    adjust(&mut opts);
    let ctx = Context::new(&opts).unwrap_or_else(|e| panic!("could not create Vulkan context: {e}"));
    if !ctx.info.validation {
        eprintln!("warning: running GPU test WITHOUT the validation layer");
    }
    ctx
}

/// Formats recorded messages; `Err` if there are any.
pub fn check_messages(sink: &Option<MessageSink>) -> Result<(), String> {
    let Some(sink) = sink else { return Ok(()) };
    let msgs = sink.lock().map(|v| v.clone()).unwrap_or_default();
    if msgs.is_empty() {
        Ok(())
    } else {
        Err(msgs.iter().map(|m| format!("  {m}")).collect::<Vec<_>>().join("\n"))
    }
}

/// Runs `f` with a fresh validated context, tears the context down (so leaks are reported by
/// the layer too), and fails on any validation message.
pub fn gpu_test(f: impl FnOnce(&Context)) {
    gpu_test_with(|_| {}, f)
}

/// [`gpu_test`] on a context whose options `adjust` changes (e.g. a capped allocation).
pub fn gpu_test_with(adjust: impl FnOnce(&mut ContextOptions), f: impl FnOnce(&Context)) {
    let ctx = context_with(adjust);
    let sink = ctx.message_sink();
    f(&ctx);
    ctx.wait_idle().expect("wait idle");
    drop(ctx);
    if let Err(msgs) = check_messages(&sink) {
        panic!("validation reported messages:\n{msgs}");
    }
}

/// Writes a `dims` u16 raw volume (little-endian, x fastest) of `voxel` as a sparse file: rows
/// that are all 0 are left as holes.
pub fn write_sparse_u16(path: &std::path::Path, dims: [u32; 3], voxel: impl Fn(u32, u32, u32) -> u16) {
    use std::io::{Seek, SeekFrom, Write};
    let [nx, ny, nz] = dims.map(u64::from);
    let mut f = std::fs::File::create(path).expect("create");
    f.set_len(nx * ny * nz * 2).expect("sparse file");
    let mut row = vec![0u8; nx as usize * 2];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            let mut any = false;
            for x in 0..dims[0] {
                let v = voxel(x, y, z);
                any |= v != 0;
                row[2 * x as usize..][..2].copy_from_slice(&v.to_le_bytes());
            }
            if any {
                f.seek(SeekFrom::Start((u64::from(z) * ny + u64::from(y)) * nx * 2)).expect("seek");
                f.write_all(&row).expect("write");
            }
        }
    }
}
