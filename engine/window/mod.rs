//! Windowed presentation: winit event loop, surface and swapchain.

pub mod runner;
pub mod swapchain;

pub use runner::{run_windowed, FrameOutput, WindowApp, WindowConfig, WindowStats};
pub use swapchain::Swapchain;
