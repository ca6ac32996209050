//! What the demo executables share: the command line ([`cli`]), how runs end ([`runner`]:
//! validation, exit codes, windows), outputs and per-pass statistics, the windows' UI shell, the
//! mesh and volume demos' programs (scene setup, headless run, window), and the device-limit
//! micro-benchmarks ([`limits`]) and the loader fuzzer ([`fuzz`]). The engine library (`vkengine`) depends on none of it.
//!
//! Module dependencies point one way: `*_app` (dispatch) → `*_headless` / `*_window` →
//! `*_scene` (shared setup) → `cli`, `output`, `stats`, `shell`, `runner`.
#![warn(missing_docs)]

pub mod clean_bench;
pub mod cli;
pub mod extremes;
pub mod fuzz;
pub mod label_bench;
pub mod layout_bench;
pub mod limits;
pub mod lpv_thesis;
pub mod mesh_app;
pub mod mesh_headless;
pub mod mesh_scene;
pub mod mesh_window;
pub mod output;
pub mod runner;
pub mod shell;
pub mod stats;
pub mod volume_app;
pub mod volume_headless;
pub mod volume_scene;
pub mod volume_session;
pub mod volume_window;
pub mod vpt_peer;

pub use cli::DemoArgs;
pub use runner::{check_validation, exit_code, run_window};
