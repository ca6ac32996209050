//! The mesh demos' program (`cornell`, `atrium`, `scene`): the headless run or the window,
//! whichever the arguments and the display ask for.

use crate::cli::DemoArgs;
use crate::{mesh_headless, mesh_window, runner};
use vkengine::Result;

/// Runs a mesh demo with parsed arguments (`builtin`: the scene without `--scene`).
pub fn run(args: &DemoArgs, demo: &str, builtin: &str) -> Result<()> {
    if args.windowed() {
        mesh_window::run(args, demo, builtin)
    } else {
        mesh_headless::run(args, demo, builtin)
    }
}

/// Runs a mesh demo: parses the shared command line, renders, and exits with the conventional code.
pub fn main(demo: &str, builtin: &str) {
    use clap::Parser;
    runner::exit_on_error(run(&DemoArgs::parse(), demo, builtin));
}
