//! How a demo run ends: validation messages fail it, errors map to exit codes, windows run
//! under the same rule.

use crate::cli::DemoArgs;
use vkengine::{Error, Result};

/// The conventional exit code of a failed run: 2 for bad input (an [`Error::Input`] message, or a
/// file the user named that cannot be read or written), 1 for everything else — frame-graph and
/// other internal failures, the device, the validation layer.
pub fn exit_code(e: &Error) -> i32 {
    match e {
        Error::Input(_) | Error::Io { .. } => 2,
        _ => 1,
    }
}

/// Prints `error: …` and exits with [`exit_code`] when `result` failed.
pub fn exit_on_error(result: Result<()>) {
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(exit_code(&e));
    }
}

/// [`exit_on_error`] for the benchmarks' mains, which also see I/O and CSV errors: an engine
/// error keeps its code (2 for bad input); a file the benchmark writes that fails is 1.
pub fn exit_on_bench_error(result: std::result::Result<(), Box<dyn std::error::Error>>) {
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(e.downcast_ref::<Error>().map_or(1, exit_code));
    }
}

/// Fails a run during which the validation layer reported anything (the messages were already
/// printed as they arrived), so a demo run under validation is as strict as a test.
pub fn check_validation(ctx: &vkengine::vk::Context) -> Result<()> {
    let n = ctx.validation_messages().len();
    if n == 0 {
        Ok(())
    } else {
        Err(Error::Validation(n))
    }
}

/// Opens a demo window titled `title` at `--size` and runs `make`'s app until it is closed; a
/// validation message during the run fails it, as in headless runs.
pub fn run_window<A: vkengine::window::WindowApp>(
    title: String,
    args: &DemoArgs,
    make: impl FnOnce(&vkengine::vk::Context) -> Result<A>,
) -> Result<()> {
    let config = vkengine::window::WindowConfig {
        title,
        size: args.size,
        max_frames: None,
        resize_script: vec![],
        any_thread: false,
    };
    let stats = vkengine::window::run_windowed(config, &args.context_options(), make)?;
    match stats.validation_messages.len() {
        0 => Ok(()),
        n => Err(Error::Validation(n)),
    }
}
