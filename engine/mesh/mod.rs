//! Mesh scenes on the GPU: upload, G-buffer, cascaded and spot shadow maps, reflective shadow
//! maps, LPV global illumination, deferred lighting, fog and sun rays, all declared as frame-graph
//! passes. Its files are layered: data and formats (`settings`, `formats`, `frame`, `camera`,
//! `gpu_scene`) → drawing (`cull`, `shadow`, `geometry`) → features, one file each (`gbuffer`,
//! `rsm`, `lights`, `shadow_atlas`, `lpv_frame`, `lighting`, `fog`, `sun_rays`, `targets`) →
//! `renderer`, which composes a frame; `reference` is the CPU reference. Uses `crate::scene`,
//! `crate::lpv`, `crate::graph` and `crate::vk`; used by the demos and the Python module.

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
