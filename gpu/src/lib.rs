//! The wgpu back end (DESIGN §6): IR → WGSL compute passes over fragment buffers, pass
//! partitioning, buffers and dispatch. See `docs/gpu.md`.
//!
//! Owns: everything that knows about wgpu and WGSL. Must not touch: the IR and its passes
//! (graph), the CPU back ends, the tracer.

pub mod context;
pub mod emit;
pub mod kernel;
pub mod material;
pub mod plan;
pub mod testing;

pub use context::{GpuContext, GpuError};
pub use material::{GpuBackend, GpuMaterial, GpuOptions, PassMode};
pub use plan::{Plan, plan};
