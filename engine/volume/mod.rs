//! Volume rendering, in five layers whose imports run one way (lower never imports higher):
//! `data` (host volumes: loaders, sparse grids, the host-side bricks and their statistics) →
//! `optics` (transfer functions and their choice, phase functions, environment maps) →
//! `camera` (the orbit camera and framing a volume's visible part) → `device` (the volume's
//! layout on the device: dense or sparse atlases, page tables, upload) → `render` (the renderer,
//! its settings, passes, uniforms and the frame driver). Used by the demos, the Python module
//! and the UI; it uses the frame graph (`crate::graph`), `crate::vk` and `crate::post`.

pub mod camera;
pub mod data;
pub mod device;
pub mod optics;
pub mod render;
