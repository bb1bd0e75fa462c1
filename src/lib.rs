//! shadenet: shading networks, partially evaluated and compiled.
//!
//! The facade re-exports the public API of the member crates.

pub use shadenet_graph as graph;
pub use shadenet_runtime as runtime;
