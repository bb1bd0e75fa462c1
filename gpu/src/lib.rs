//! The wgpu back end (DESIGN §6): IR → WGSL compute passes over fragment buffers, pass
//! partitioning, buffers and dispatch. See `docs/gpu.md`.
//!
//! Owns: everything that knows about wgpu and WGSL. Must not touch: the IR and its passes
//! (graph), the CPU back ends, the tracer.
//!
//! The modules import each other in one direction only, from the bottom up:
//!
//! - [`options`], [`context`], [`emit`]: import nothing of this crate;
//! - [`plan`](mod@plan): the plan as data (options);
//! - [`kernel`]: the WGSL kernel of one pass (plan, emit);
//! - [`planner`]: a program cut into a plan, kernels included (plan, kernel, options, emit);
//! - [`material`]: the back end and the material on the device (planner, plan, context,
//!   options, emit);
//! - [`testing`]: helpers for the tests (context).

pub mod context;
pub mod emit;
pub mod kernel;
pub mod material;
pub mod options;
pub mod plan;
pub mod planner;
pub mod testing;
pub mod textures;

pub use context::{Accuracy, GpuContext, GpuError};
pub use material::{GpuBackend, GpuMaterial};
pub use options::{GpuOptions, PassMode};
pub use plan::Plan;
pub use planner::plan;
