//! vkengine: a Vulkan-native rendering engine (volumetric path tracing and light propagation
//! volumes) built on `ash`, driven by its own frame graph.
#![warn(missing_docs)]

pub mod error;
pub mod graph;
pub mod shaders;
pub mod vk;

pub use error::{Error, Result};
