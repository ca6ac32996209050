//! What every demo executable shares: CLI, exit codes, outputs.

pub mod cli;
pub mod output;

pub use cli::DemoArgs;

/// Maps an engine error to the conventional exit code: 2 for bad input, 1 for runtime failure.
pub fn exit_code(e: &crate::Error) -> i32 {
    match e {
        crate::Error::Input(_) => 2,
        _ => 1,
    }
}
