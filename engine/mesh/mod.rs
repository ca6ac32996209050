//! Mesh scenes on the GPU: upload, G-buffer, cascaded and spot shadow maps, reflective shadow
//! maps and deferred direct lighting, all declared as frame-graph passes.

pub mod camera;
pub mod cull;
pub mod fog;
pub mod formats;
pub mod frame;
mod gbuffer;
mod geometry;
pub mod gpu_scene;
mod lighting;
pub mod lights;
mod lpv_frame;
pub mod reference;
pub mod renderer;
mod rsm;
pub mod settings;
pub mod shadow;
mod shadow_atlas;
mod sun_rays;
pub mod targets;
