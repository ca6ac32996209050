//! Light propagation volumes and their reference.

pub mod sh;
pub mod grid;
pub mod settings;
pub mod passes;
