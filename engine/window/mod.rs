//! Windowed presentation: the winit event loop (`runner`), surface and swapchain (`swapchain`,
//! which `runner` uses). Uses `crate::vk` and `crate::graph` (presenting through the frame
//! graph); used by the demos' windows.

pub mod runner;
pub mod swapchain;

pub use crate::graph::PresentTarget;
pub use runner::{run_windowed, WindowApp, WindowConfig, WindowStats};
pub use swapchain::Swapchain;
