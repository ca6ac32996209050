//! Mesh scenes on the GPU: upload, G-buffer, cascaded and spot shadow maps, reflective shadow
//! maps and deferred direct lighting, all declared as frame-graph passes.

pub mod camera;
pub mod cull;
pub mod fog;
pub mod frame;
pub mod gpu_scene;
pub mod lights;
pub mod reference;
pub mod renderer;
pub mod settings;
pub mod shadow;
pub mod targets;
