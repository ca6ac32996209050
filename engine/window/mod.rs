//! Windowed presentation: winit event loop, surface and swapchain.

pub mod runner;
pub mod swapchain;

pub use crate::graph::PresentTarget;
pub use runner::{run_windowed, WindowApp, WindowConfig, WindowStats};
pub use swapchain::Swapchain;
