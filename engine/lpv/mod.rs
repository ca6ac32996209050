//! Light propagation volumes and their reference.

pub mod grid;
pub mod passes;
pub mod settings;
pub mod sh;
