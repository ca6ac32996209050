//! The volume demo program: MIP / ISO / EAM of a procedural scene (default: a 128³ cloud) or any supported
//! file (`--volume`). Headless: PNG (tone-mapped) or EXR (linear HDR) + JSON report; windowed:
//! drag to orbit, scroll to zoom, 1/2/3 = MIP/ISO/EAM, T = next tone mapper, E = toggle
//! empty-space skipping; the title shows GPU ms per frame.

use crate::cli::DemoArgs;
use crate::volume_session::VolumeSession;
use crate::{runner, volume_headless, volume_window};
use clap::Parser;
use vkengine::Result;

/// Runs the volume demo with parsed arguments: a window if there is a display, else headless.
/// `--scene` names a session file (what the window's "Save scene" writes).
pub fn run(args: &DemoArgs) -> Result<()> {
    let args = &VolumeSession::apply(args)?;
    if args.windowed() {
        volume_window::run(args)
    } else {
        volume_headless::run(args)
    }
}

/// Runs the volume demo: parses the shared command line, renders, exits with the conventional code.
pub fn main() {
    runner::exit_on_error(run(&DemoArgs::parse()));
}
