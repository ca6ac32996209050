//! Light propagation volumes and their reference.

pub mod bvh;
pub mod frame;
pub mod grid;
pub mod passes;
pub mod settings;
pub mod sh;
pub mod transport;
