//! What every demo executable shares: CLI, exit codes, outputs.

pub mod cli;
pub mod mesh_app;
pub mod mesh_window;
pub mod output;
pub mod stats;
pub mod volume_app;
pub mod volume_session;
pub mod volume_window;

pub use cli::DemoArgs;

/// Maps an engine error to the conventional exit code: 2 for bad input, 1 for runtime failure.
pub fn exit_code(e: &crate::Error) -> i32 {
    match e {
        crate::Error::Input(_) => 2,
        _ => 1,
    }
}

/// Fails a run during which the validation layer reported anything (the messages were already
/// printed as they arrived), so a demo run under validation is as strict as a test.
pub fn check_validation(ctx: &crate::vk::Context) -> crate::Result<()> {
    let n = ctx.validation_messages().len();
    if n == 0 {
        Ok(())
    } else {
        Err(crate::Error::Validation(n))
    }
}

/// Opens a demo window titled `title` at `--size` and runs `make`'s app until it is closed; a
/// validation message during the run fails it, as in headless runs.
pub fn run_window<A: crate::window::WindowApp>(
    title: String,
    args: &DemoArgs,
    make: impl FnOnce(&crate::vk::Context) -> crate::Result<A>,
) -> crate::Result<()> {
    let config = crate::window::WindowConfig {
        title,
        size: args.size,
        max_frames: None,
        resize_script: vec![],
        any_thread: false,
    };
    let stats = crate::window::run_windowed(config, &args.context_options(), make)?;
    match stats.validation_messages.len() {
        0 => Ok(()),
        n => Err(crate::Error::Validation(n)),
    }
}
