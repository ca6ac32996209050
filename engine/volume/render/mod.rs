//! The volume renderers as frame-graph passes: the GPU state one volume carries
//! (`renderer`), settings (`settings`, `mc_settings`, `clip_settings`: each key once, in the
//! schema), the uniform blocks (`uniforms`), ray-marching passes and bounds (`march_passes`,
//! `march_bounds`, `occlusion`), Monte Carlo passes, modes and loop budgets (`mc_pass`,
//! `mc_mode`, `mc_loops`), each Monte Carlo pixel's error and adaptive sampling (`variance`,
//! `convergence`), the denoised image (`denoise`, `features`, `temporal`) and the frame driver
//! (`frame`), temperature-driven emission (`temperature`). The top layer: uses every other layer of `volume`; used by the demos, the Python
//! module and the UI.

pub mod clip_settings;
pub mod convergence;
pub mod denoise;
pub mod features;
pub mod frame;
pub mod label_settings;
pub mod label_texture;
mod labels;
pub mod march_bounds;
mod march_passes;
pub mod mc_calibrate;
pub mod mc_loops;
pub mod mc_mode;
mod mc_pass;
pub mod mc_settings;
pub mod occlusion;
pub mod renderer;
pub mod settings;
pub mod temperature;
mod temporal;
pub mod uniforms;
pub mod variance;
