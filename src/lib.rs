#![doc = include_str!("../README.md")]
//!
//! ## Crate map
//!
//! The facade re-exports the member crates: [`graph`] (networks, node library, linker, IR,
//! op semantics) and [`runtime`] (shading context, lights, interpreter); [`shade`] shades a
//! network over a grid without a renderer and [`output`] writes PNG and EXR images. It owns
//! the `shadenet` CLI and must not add shading semantics of its own.

pub mod output;
pub mod shade;

pub use shadenet_graph as graph;
pub use shadenet_runtime as runtime;

pub use shadenet_graph::{CompileError, Compiled, NodeLibrary, compile_json};
pub use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv};
