//! Volume rendering: volume data, transfer functions, cameras, and the MIP / ISO / EAM renderers.

pub mod camera;
pub mod data;
pub mod envmap;
pub mod frame;
pub mod framing;
pub mod gpu_data;
pub mod mc_mode;
pub mod occlusion;
pub mod phase;
pub mod renderer;
pub mod settings;
pub mod tf;
pub mod tf_choice;
