//! Volume rendering: volume data, transfer functions, cameras, and the MIP / ISO / EAM renderers.

pub mod bricks;
pub mod camera;
pub mod cells;
pub mod convergence;
pub mod data;
pub mod envmap;
pub mod frame;
pub mod framing;
pub mod gpu_data;
pub mod layout;
pub mod march_bounds;
mod march_passes;
pub mod mc_loops;
pub mod mc_mode;
mod mc_pass;
pub mod mc_settings;
pub mod occlusion;
pub mod page_images;
pub mod page_table;
pub mod phase;
pub mod renderer;
pub mod settings;
pub mod sparse_bricks;
pub mod tf;
pub mod tf_choice;
pub mod uniforms;
pub mod variance;
