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
