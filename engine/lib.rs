//! vkengine: a Vulkan-native rendering engine (volumetric path tracing and light propagation
//! volumes) built on `ash`, driven by its own frame graph. Its modules are layered, checked by
//! `tools/modcycles.py`: `vk` (device, resources) → `graph` (declare, compile, execute passes) →
//! `scene`, `settings`, `post`, `lpv` → the renderers `volume` and `mesh` → `ui`, `window`,
//! `profile`; within each module the files and folders import one way as well.
#![warn(missing_docs)]

pub mod error;
pub mod graph;
pub mod lpv;
pub mod mesh;
pub mod metrics;
pub mod plot;
pub mod post;
pub mod profile;
pub mod scene;
pub mod settings;
pub mod shaders;
pub mod spirv_reflect;
pub mod ui;
pub mod vk;
pub mod volume;
pub mod window;

pub use error::{Error, Result};
