//! Light propagation volumes: the 2-band SH basis (`sh`, the CPU twin of the shaders), settings,
//! cascade placement (`grid`), the per-frame uniform block (`frame`), the frame-graph passes that
//! inject, build the geometry volume and propagate (`passes`, with the device calibration that
//! picks their layout), and the f64 transport twin and BVH behind the reference. Its files are
//! layered: `passes` uses `frame`, `grid`, `settings` and `sh`; nothing below imports it. Uses
//! `crate::graph`, `crate::settings` and `crate::vk`; used by `crate::mesh`, whose renderer runs
//! the LPV.

pub mod bvh;
pub mod frame;
pub mod grid;
pub mod passes;
pub mod settings;
pub mod sh;
pub mod transport;
